"""The classes of the segmentation, semantic and coverage labels: :data:`PRESET_CLASSES` (ids
fixed, append only), :data:`SHAPE_RULES` (which shapes are one object, of which class),
:func:`spec_class_table` (a spec's class map, what every item's ids come from) and
:func:`write_classes` (the dataset's ``classes.json``).

References
----------
.. [1] docs/design.md, "Dataset layouts" (classes.json).
.. [2] COCO data format, https://cocodataset.org/#format-data (categories).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

from ....scene import SceneConfig

__all__ = ["ShapeClass", "PRESET_CLASSES", "USER_CLASS_BASE", "SHAPE_RULES", "CLASS_LABELS", "shape_class",
           "shape_reflectance", "class_table", "spec_class_table", "sky_visible", "write_classes"]


def shape_class(name: str) -> str:
    """A shape's class: its name without the index its preset numbers it by (``patch_07`` →
    ``patch``, ``plant_3`` → ``plant``); an XML scene's shape id as it is."""
    stem, _, tail = name.rpartition("_")
    return stem if stem and tail.isdigit() else name


def shape_reflectance(config: SceneConfig, name: str) -> str | None:
    """Where a preset shape's reflectance comes from, where its preset names it by it (the
    ColorChecker patches, dead-leaves samples, plants, depth-target checkers); None otherwise
    (an XML scene's materials are its own)."""
    from ....spectra import COLORCHECKER_PATCH_NAMES

    scene = config.scene
    if scene.mitsuba_xml:
        return None
    kind, number = shape_class(name), name.rpartition("_")[2]
    if kind in ("patch", "chart_patch") and number.isdigit() and int(number) < len(COLORCHECKER_PATCH_NAMES):
        return f"ColorChecker '{COLORCHECKER_PATCH_NAMES[int(number)]}' (BabelColor average)"
    if kind == "leaves" and scene.preset == "dead_leaves":
        from ....reflectance_sets import reflectance_set

        return f"{scene.leaf_reflectances}: {reflectance_set(scene.leaf_reflectances).names[int(number)]}"
    if kind == "backdrop" and scene.preset == "dead_leaves":
        from ....presets.dead_leaves import BACKDROP_REFLECTANCE

        return f"flat {BACKDROP_REFLECTANCE:g}"
    if kind == "plant":
        return "PROSPECT-D leaf (health state in health.exr)" if scene.plant_reflectances == "prospect" \
            else f"reflectance set {scene.plant_reflectances}"
    if kind == "plane" and scene.preset == "dof_targets":
        return "checkerboard of flat 0.1 and 0.8"
    return None


# ----------------------------------------------------------------------------- classes and instances
@dataclass(frozen=True)
class ShapeClass:
    """A class of the dataset-wide class map: its ``name`` (what a pixel shows: ``sphere``,
    ``plant``, ``chart_patch``), its ``category`` (the coarse kind a vision user groups it by:
    ``object``, ``vegetation``, ``ground``, ``chart``, ``sky``, ``structure``, ``furniture``,
    ``light``, ``background``, ``texture``, ``asset``, ``scatter``, ``scene``, ``unknown``) and what it
    is."""

    name: str
    category: str
    description: str = ""


#: Every class the presets build, in id order: class id = place + 1 (0: unlabelled, where the
#: pinhole ray meets nothing and no sky is there). Append only: an id, once given, is never
#: reused, so a class keeps its id across items, resumed runs, datasets and versions.
PRESET_CLASSES = (
    ShapeClass("ground", "ground", "the ground plane and its far strips (tabletop, vegetation)"),
    ShapeClass("hills", "ground", "the ring of distant hills (ground = 'hills')"),
    ShapeClass("sky", "sky", "rays that leave the scene under a sun-and-sky or overcast sky (semantic map only)"),
    ShapeClass("clouds", "sky", "the cloud layer under a sun and sky"),
    ShapeClass("sphere", "object", "a tabletop sphere"),
    ShapeClass("box", "object", "a tabletop cube, or the Cornell box's two boxes"),
    ShapeClass("cylinder", "object", "a tabletop cylinder (tube and top disc: one instance)"),
    ShapeClass("torus", "object", "a tabletop torus (procedural mesh)"),
    ShapeClass("vase", "object", "a tabletop vase (procedural mesh)"),
    ShapeClass("table_object", "object", "a thing on the room's table (vase, bowl, mug or a stack of books)"),
    ShapeClass("plant", "vegetation", "a crop plant (vegetation)"),
    ShapeClass("weed", "vegetation", "a weed (vegetation)"),
    ShapeClass("chart_patch", "chart", "a ColorChecker patch (its BabelColor reflectance in the instance table)"),
    ShapeClass("chart_board", "chart", "the ColorChecker's black board or frame"),
    ShapeClass("chart_surround", "background", "the grey surround behind the colorchecker preset's chart"),
    ShapeClass("flat_field", "chart", "the flat_field preset's uniform target"),
    ShapeClass("edge_dark", "chart", "the slanted_edge preset's dark side"),
    ShapeClass("edge_bright", "chart", "the slanted_edge preset's bright half"),
    ShapeClass("depth_plane", "chart", "a dof_targets checkered plane"),
    ShapeClass("point_source", "light", "a point_sources emitter"),
    ShapeClass("dead_leaf", "texture", "a dead_leaves disc (each its own instance)"),
    ShapeClass("backdrop", "background", "the dead_leaves backdrop"),
    ShapeClass("wall", "structure", "a wall (room, Cornell box, the tabletop's backdrop)"),
    ShapeClass("floor", "structure", "a floor (room, Cornell box)"),
    ShapeClass("ceiling", "structure", "a ceiling (room, Cornell box)"),
    ShapeClass("skirting", "structure", "the room's skirting boards"),
    ShapeClass("table", "furniture", "the room's table (top and legs)"),
    ShapeClass("rug", "furniture", "the room's rug"),
    ShapeClass("sofa", "furniture", "the room's sofa (base, back, arms, seats, feet)"),
    ShapeClass("cushion", "furniture", "a cushion on the sofa"),
    ShapeClass("painting", "furniture", "the room's painting and its frame"),
    ShapeClass("bookshelf", "furniture", "the room's bookshelf (sides, back, boards)"),
    ShapeClass("book", "furniture", "a book on the shelf"),
    ShapeClass("floor_lamp", "furniture", "the room's floor lamp (base, pole, shade and its diffusers)"),
    ShapeClass("sideboard", "furniture", "the room's sideboard (body, doors, knobs, feet)"),
    ShapeClass("ceiling_lamp", "light", "the room's ceiling panel"),
    ShapeClass("area_light", "light", "an area light seen directly (the Cornell box's, the overhead lamp)"),
    ShapeClass("other", "unknown", "a shape no rule names (its own name is in the instance table)"),
)
#: First id of the classes a spec names itself (assets, scatter, an XML scene's shapes), in
#: (category, name) order: ids below it stay :data:`PRESET_CLASSES`' however that list grows.
USER_CLASS_BASE = 256


@dataclass(frozen=True)
class _Rule:
    """Shape names matching ``pattern`` (in one of ``presets``; None: any) are of class
    ``cls`` (a name, or ``"{kind}"``: the tabletop object's shape) and belong to the instance
    ``instance`` (a template of the match's groups)."""

    presets: tuple | None
    pattern: str
    cls: str
    instance: str = r"\g<0>"


_OUTDOOR = ("tabletop", "vegetation")
#: How each preset's shape names become classes and instances (first match wins): the parts of
#: one object (a cylinder's tube and top, a table's top and legs) share an instance.
SHAPE_RULES = (
    _Rule(_OUTDOOR, r"ground|ground_far_(north|south|east|west)", "ground", "ground"),
    _Rule(_OUTDOOR, r"terrain", "hills"),
    _Rule(_OUTDOOR, r"clouds", "clouds"),
    _Rule(_OUTDOOR, r"backdrop", "wall"),
    _Rule(_OUTDOOR, r"lamp", "area_light"),
    _Rule(("tabletop",), r"(object_\d+)(_top)?", "{kind}", r"\1"),
    _Rule(("vegetation",), r"plant_\d+", "plant"),
    _Rule(("vegetation",), r"weed_\d+", "weed"),
    _Rule(None, r"(chart_)?patch_\d+", "chart_patch"),
    _Rule(None, r"chart_board|chart_frame", "chart_board"),
    _Rule(("colorchecker",), r"surround", "chart_surround"),
    _Rule(("flat_field",), r"target", "flat_field"),
    _Rule(("slanted_edge",), r"background", "edge_dark"),
    _Rule(("slanted_edge",), r"bright_half", "edge_bright"),
    _Rule(("dof_targets",), r"plane_\d+", "depth_plane"),
    _Rule(("point_sources",), r"source_\d+", "point_source"),
    _Rule(("dead_leaves",), r"leaf_\d+", "dead_leaf"),
    _Rule(("dead_leaves",), r"backdrop", "backdrop"),
    _Rule(("cornell_box",), r"back|green_wall|red_wall", "wall"),
    _Rule(("cornell_box",), r"floor|ceiling", r"\g<0>"),
    _Rule(("cornell_box",), r"small_box|large_box", "box"),
    _Rule(("cornell_box",), r"light", "area_light"),
    _Rule(("room",), r"wall_(back|left|right|front)", "wall"),
    _Rule(("room",), r"floor|ceiling|rug", r"\g<0>"),
    _Rule(("room",), r"skirting_\w+", "skirting", "skirting"),
    _Rule(("room",), r"table_(top|leg_\d+)", "table", "table"),
    _Rule(("room",), r"sofa_\w+", "sofa", "sofa"),
    _Rule(("room",), r"cushion_\d+", "cushion"),
    _Rule(("room",), r"painting(_frame_\w+)?", "painting", "painting"),
    _Rule(("room",), r"shelf_\w+", "bookshelf", "bookshelf"),
    _Rule(("room",), r"book_\d+", "book"),
    _Rule(("room",), r"lamp_(base|pole|shade|light_down|light_up)", "floor_lamp", "floor_lamp"),
    _Rule(("room",), r"sideboard(_\w+)?", "sideboard", "sideboard"),
    _Rule(("room",), r"ceiling_lamp", "ceiling_lamp"),
    _Rule(("room",), r"(object_\d+)(_\d+)?", "table_object", r"\1"),
)


def _class_colour(class_id: int) -> list[int]:
    """A display colour (sRGB 0–255) of a class id: hues a golden angle apart, so neighbouring
    ids differ; fixed by the id alone (the same in every dataset)."""
    import colorsys

    if class_id == 0:
        return [0, 0, 0]
    hue = (class_id * 0.6180339887498949) % 1.0
    value = 0.95 if class_id % 2 else 0.75
    return [int(round(255 * c)) for c in colorsys.hsv_to_rgb(hue, 0.7, value)]


def _xml_shape_ids(path: str | Path) -> list[str]:
    """The ``id`` of every ``<shape>`` of a Mitsuba XML file (its own, not those of included files)."""
    import xml.etree.ElementTree as ElementTree

    try:
        root = ElementTree.parse(path).getroot()
    except (OSError, ElementTree.ParseError):
        return []
    return [shape.get("id") for shape in root.iter("shape") if shape.get("id")]


def _user_classes(config: SceneConfig) -> set[tuple[str, str]]:
    """(category, name) of the classes a scene names itself: its assets, its scatter entries and
    its XML file's shapes (a shape's id without its index, :func:`shape_class`)."""
    scene = config.scene
    found = {("asset", spec.name) for spec in scene.assets} | {("scatter", spec.name) for spec in scene.scatter}
    if scene.mitsuba_xml:
        found |= {("scene", shape_class(name)) for name in _xml_shape_ids(scene.mitsuba_xml)}
    return found


def class_table(configs: Sequence[SceneConfig]) -> list[dict]:
    """The class map of a set of scenes: every :data:`PRESET_CLASSES` entry (id = place + 1),
    then the classes the scenes name themselves (:func:`_user_classes`) from
    :data:`USER_CLASS_BASE` in (category, name) order.

    Returns
    -------
    list of dict
        ``{"id", "name", "category", "colour", "description"}`` in id order; ``colour`` sRGB 0–255.
    """
    table = [{"id": k + 1, "name": c.name, "category": c.category, "colour": _class_colour(k + 1),
              "description": c.description} for k, c in enumerate(PRESET_CLASSES)]
    preset_names = {c.name for c in PRESET_CLASSES}
    user = sorted({pair for config in configs for pair in _user_classes(config) if pair[1] not in preset_names})
    table += [{"id": USER_CLASS_BASE + k, "name": name, "category": category,
               "colour": _class_colour(USER_CLASS_BASE + k), "description": f"named by the spec ({category})"}
              for k, (category, name) in enumerate(user)]
    return table


def spec_class_table(spec) -> list[dict]:
    """:func:`class_table` of a dataset spec: the scenes its fixed values make with every value
    its choices and sweeps give the keys that name classes (``scene.preset``,
    ``scene.mitsuba_xml``, ``scene.assets``, ``scene.scatter``). It depends on the spec alone, so
    every item of a dataset, and every resumed run, numbers the classes alike."""
    import itertools

    keys = ("scene.preset", "scene.mitsuba_xml", "scene.assets", "scene.scatter")
    options: dict[str, list] = {}
    for distribution in spec.distributions.values():
        if distribution.key in keys and distribution.kind == "choice":
            options.setdefault(distribution.key, []).extend(distribution.values)
    for sweep in spec.sweeps:
        if sweep.key in keys:
            options.setdefault(sweep.key, []).extend(sweep.values)
    configs = []
    for values in itertools.product(*options.values()):
        try:
            configs.append(spec.scene(dict(zip(options, values))))
        except Exception:  # a combination the spec never draws (refused at load); its items fail on their own
            continue
    if not configs:  # the fixed values need a drawn one to make a scene: the first item's stands for them
        from ....scene import scene_from_dict

        plan = spec.plan_item(0)
        configs = [scene_from_dict(plan.scene)] if plan.scene is not None else []
    return class_table(configs)


def _shape_class_and_instance(config: SceneConfig, name: str, user: Mapping[str, str],
                              kinds: Sequence[str]) -> tuple[str, str]:
    """(class name, instance key) of a shape by :data:`SHAPE_RULES`, the scene's own names
    (``user``: shape class → class name) and the tabletop objects' shapes (``kinds``)."""
    import re

    if name in user or shape_class(name) in user:
        return user.get(name) or user[shape_class(name)], name
    preset = "" if config.scene.mitsuba_xml else config.scene.preset
    for rule in SHAPE_RULES:
        if rule.presets is not None and preset not in rule.presets:
            continue
        match = re.fullmatch(rule.pattern, name)
        if match:
            cls = match.expand(rule.cls) if "\\" in rule.cls else rule.cls
            if cls == "{kind}":
                number = int(re.search(r"\d+", name).group())
                cls = kinds[number] if number < len(kinds) else "other"
            return cls, match.expand(rule.instance)
    return "other", name


def _tabletop_kinds(config: SceneConfig, lens) -> list[str]:
    """The shape kind of each tabletop object (``object_<n>``: :func:`tabletop_layout`'s n-th)."""
    if config.scene.mitsuba_xml or config.scene.preset != "tabletop":
        return []
    from ....presets.tabletop import tabletop_layout
    from ....reflectance_sets import reflectance_set

    count = len(reflectance_set(config.scene.object_reflectances).sds)
    return [item.shape for item in tabletop_layout(config, lens.layout_lens, count)]


def sky_visible(config: SceneConfig) -> bool:
    """Whether a ray that leaves the scene sees a sky (an outdoor preset under a sun and sky or
    an overcast sky): the semantic map's ``sky`` there, not 0."""
    if config.scene.mitsuba_xml or config.scene.preset not in _OUTDOOR:
        return False
    from ....presets.outdoor import light_kind

    return light_kind(config) in ("sunsky", "overcast")


#: Outputs whose ids classes.json names.
CLASS_LABELS = ("segmentation", "semantic", "coverage")


def write_classes(output: str | Path, table: Sequence[Mapping], rows: Mapping[int, Mapping]) -> Path | None:
    """``output/classes.json``: the dataset's class map (``table``, :func:`spec_class_table`) with
    the classes no finished item shows dropped, each kept one with its pixels, items and
    instances over the dataset (from the items' meta.json); written atomically, nothing where no
    item holds a segmentation or semantic label.

    Class ids come from the spec alone, so they agree across the items, across resumed runs and
    between datasets of one spec, whichever items finished first; a class first shown by items a
    resumed run adds joins the file with the id it always had.

    Returns
    -------
    pathlib.Path or None
        The file, or None when no item holds the labels.
    """
    import json

    from ....io import atomic_path

    pixels: dict[int, int] = {}
    items: dict[int, int] = {}
    instances: dict[int, int] = {}
    labelled = 0
    for row in rows.values():
        if row.get("status") != "done":
            continue
        try:
            meta = json.loads((Path(output) / "items" / str(row["id"]) / "meta.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        semantic, segmentation = meta.get("semantic") or {}, meta.get("segmentation") or {}
        shown: dict[int, int] = {int(k): int(n) for k, n in (semantic.get("class_pixels") or {}).items()}
        for record in segmentation.get("instances") or []:
            if "class_id" not in record or not record.get("pixels"):
                continue
            instances[record["class_id"]] = instances.get(record["class_id"], 0) + 1
            if not semantic:
                shown[record["class_id"]] = shown.get(record["class_id"], 0) + int(record["pixels"])
        labelled += bool(semantic or segmentation.get("instances") is not None)
        for k, n in shown.items():
            pixels[k] = pixels.get(k, 0) + n
            items[k] = items.get(k, 0) + 1
    if not labelled:
        return None
    kept = [{**{key: entry[key] for key in ("id", "name", "category", "colour")}, "pixels": pixels[entry["id"]],
             "items": items[entry["id"]], "instances": instances.get(entry["id"], 0),
             "description": entry.get("description", "")}
            for entry in table if pixels.get(entry["id"])]
    document = {
        "format": 1, "unlabelled_id": 0, "files": ["segmentation.png (instance ids)", "semantic.png (class ids)"],
        "ids": f"fixed by the spec: ids 1-{USER_CLASS_BASE - 1} the presets' classes (the same in every dataset), "
               f"from {USER_CLASS_BASE} the classes the spec names (assets, scatter, an XML scene's shapes) in "
               "(category, name) order; a class no finished item shows is left out, ids keep their gaps",
        "colour": "display sRGB 0-255", "items_labelled": labelled, "classes": kept}
    path = Path(output) / "classes.json"
    with atomic_path(path) as tmp:
        text = json.dumps(document, indent=1)  # one class a line: readable, and diffable between runs
        lines = ",\n  ".join(json.dumps(entry, ensure_ascii=False) for entry in kept)
        text = text[:text.rindex('"classes": [')] + '"classes": [\n  ' + lines + "\n ]\n}"
        Path(tmp).write_text(text + "\n", encoding="utf-8")
    return path

