"""``tabletop``: objects on a ground plane — spheres, boxes, cylinders and procedural meshes
(a torus, a vase) in Lambertian, rough-plastic, rough-metal and glass materials — under the
sun and sky of a date, time and place, or under a lamp.

Materials: ``diffuse`` and ``plastic`` (Mitsuba's ``roughplastic``: a GGX coat of index 1.49
over the diffuse base) take a reflectance from ``scene.object_reflectances``; ``conductor``
(``roughconductor``) one of gold, copper, aluminium, silver and chromium with Mitsuba's
measured spectral complex indices (η(λ), k(λ)); ``glass`` is a smooth ``dielectric`` of BK7's
index. The ground is a two-tone Lambertian checkerboard (10 % and 40 %) whose squares are
1/12 of the view's width, so depth of field shows at every depth.

Layout (``scene.layout_seed``): sizes uniform over ``scene.object_size`` (fractions of the
view's width at the look point), positions drawn on the ground until each object's centre
projects inside the middle 85 % of the frame and no two footprints overlap (centres drawn
uniformly over the frame and cast onto the ground, no farther than 3·``distance_m``).

References
----------
.. [1] Weidlich, A., & Wilkie, A. (2007). Arbitrarily layered micro-facet surfaces; Walter,
   B., et al. (2007). Microfacet models for refraction through rough surfaces. Mitsuba 3,
   plugins ``roughplastic``, ``roughconductor``, ``dielectric``.
.. [2] Palik, E. D. (1985). Handbook of Optical Constants of Solids (the source of Mitsuba's
   conductor tables).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..keys import Key, boolean
from . import outdoor
from .common import PRESETS, diffuse, reflectance_spectrum
from .meshes import mitsuba_mesh, torus, vase

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

__all__ = ["TabletopObject", "tabletop_layout", "SHAPES", "CONDUCTORS"]

SHAPES = ("sphere", "box", "cylinder", "torus", "vase")
#: Mitsuba's measured conductors used for ``conductor`` objects.
CONDUCTORS = ("Au", "Cu", "Al", "Ag", "Cr")
#: Ground checkerboard: reflectances and squares per view width.
GROUND_REFLECTANCES, GROUND_SQUARES_PER_VIEW = (0.1, 0.4), 12
PLASTIC_IOR, GLASS_IOR = 1.49, "bk7"
#: GGX roughness α of plastic and metal objects (uniform draws), from polished to satin.
ROUGHNESS_RANGE = (0.05, 0.3)
#: The Mitsuba plugin each non-diffuse object material becomes (:func:`_bsdf`), each of whose lobes
#: can be sharp: glass is a smooth dielectric; plastics and metals draw GGX α from
#: :data:`ROUGHNESS_RANGE`, which reaches below :data:`~spectral_cam.presets.common.SHARP_ALPHA`.
SHARP_PLUGINS = {"glass": "dielectric", "plastic": "roughplastic", "conductor": "roughconductor"}
#: Fraction of the frame (each way) object centres must project inside.
FRAME_MARGIN = 0.85


@dataclass(frozen=True)
class TabletopObject:
    """One object in the ground frame (m): its shape, footprint centre, size, turn about the
    vertical and material (``reflectance`` is an index into the reflectance set, or -1)."""

    shape: str
    east_m: float
    north_m: float
    size_m: float
    turn_deg: float
    material: str
    reflectance: int
    conductor: str
    roughness: float


def tabletop_layout(config: "SceneConfig", lens: "ThinLens", reflectance_count: int) -> list[TabletopObject]:
    """Draw the objects of ``config``'s tabletop on ``lens``'s view.

    Raises
    ------
    ConfigError
        When ``scene.object_count`` objects of ``scene.object_size`` do not fit in the view.
    """
    s = config.scene
    rng = np.random.default_rng(np.random.SeedSequence([s.layout_seed, 0x7AB1E]))
    objects: list[TabletopObject] = []
    reserved = [(0.0, 0.0, chart_width_m(config, lens))] if s.chart else []
    for east, north, size in outdoor.scatter_on_ground(config, lens, rng, margin=FRAME_MARGIN, spacing=0.66,
                                                       centre_height=0.5, noun="objects (without overlapping)",
                                                       reserved=reserved):
        material = s.object_materials[rng.integers(len(s.object_materials))]
        objects.append(TabletopObject(
            shape=SHAPES[rng.integers(len(SHAPES))], east_m=east, north_m=north, size_m=size,
            turn_deg=float(rng.uniform(0, 360)), material=material,
            reflectance=int(rng.integers(reflectance_count)) if material in ("diffuse", "plastic") else -1,
            conductor=CONDUCTORS[rng.integers(len(CONDUCTORS))], roughness=float(rng.uniform(*ROUGHNESS_RANGE))))
    return objects


#: A ColorChecker in the scene (``scene.chart``): its width as a fraction of the view's, and the
#: board's slope (it leans back, facing the camera, at the look point).
CHART_VIEW_FRACTION, CHART_TILT_DEG = 0.3, 60.0


def chart_width_m(config: "SceneConfig", lens: "ThinLens") -> float:
    """Width of the board of a ColorChecker placed in the tabletop (m)."""
    return CHART_VIEW_FRACTION * outdoor.view_width_m(config, lens)


def colorchecker_board(config: "SceneConfig", lens: "ThinLens", mi, view: outdoor.GroundView) -> dict:
    """A ColorChecker (the 24 BabelColor patches on a black board, the classic 6 × 4 layout, brown
    top left as the camera sees it) standing at the look point, leaning back
    :data:`CHART_TILT_DEG` from the ground and facing the camera's heading: a colour reference
    inside the scene, lit by the scene's own light."""
    from .. import spectra
    from .common import CHART_FRAME_REFLECTANCE

    width = chart_width_m(config, lens)
    pitch = width / 6.4
    height = 4.4 * pitch
    h, t = np.radians(config.sky.heading_deg), np.radians(CHART_TILT_DEG)
    right = np.array([np.cos(h), -np.sin(h), 0.0])
    up = np.array([np.sin(h) * np.cos(t), np.cos(h) * np.cos(t), np.sin(t)])
    normal = np.cross(right, up)
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2] = right, up, normal
    frame[:3, 3] = up * height / 2 + np.array([0.0, 0.0, 0.002])  # its bottom edge on the ground
    board = mi.ScalarTransform4f(frame)
    objects = {"chart_board": {"type": "rectangle", "bsdf": diffuse(CHART_FRAME_REFLECTANCE),
                               "to_world": view.transform(mi, board @ mi.ScalarTransform4f().scale(
                                   [width / 2, height / 2, 1.0]))}}
    half = 0.85 * pitch / 2
    for index, (name, sd) in enumerate(spectra.colorchecker_reflectances().items()):
        row, col = divmod(index, 6)
        local = mi.ScalarTransform4f().translate([(col - 2.5) * pitch, (1.5 - row) * pitch, 1e-3]).scale(
            [half, half, 1.0])
        objects[f"chart_patch_{index:02d}"] = {"type": "rectangle", "bsdf": diffuse(sd),
                                               "to_world": view.transform(mi, board @ local)}
    return objects


def _bsdf(item: TabletopObject, samples) -> dict:
    if item.material == "diffuse":
        return diffuse(samples.sds[item.reflectance])
    plugin = SHARP_PLUGINS[item.material]
    if item.material == "plastic":
        return {"type": plugin, "distribution": "ggx", "alpha": item.roughness, "int_ior": PLASTIC_IOR,
                "diffuse_reflectance": reflectance_spectrum(samples.sds[item.reflectance])}
    if item.material == "conductor":
        return {"type": plugin, "distribution": "ggx", "alpha": item.roughness, "material": item.conductor}
    return {"type": plugin, "int_ior": GLASS_IOR, "ext_ior": "air"}


def _shape(mi, view: outdoor.GroundView, item: TabletopObject, bsdf: dict, name: str) -> dict:
    """Scene-dict entries of one object (a cylinder is a tube and a top disc)."""
    place = mi.ScalarTransform4f().translate([item.east_m, item.north_m, 0.0]).rotate([0, 0, 1], item.turn_deg)
    s = item.size_m
    if item.shape == "sphere":
        local = place @ mi.ScalarTransform4f().translate([0, 0, s / 2]).scale(s / 2)
        return {name: {"type": "sphere", "to_world": view.transform(mi, local), "bsdf": bsdf}}
    if item.shape == "box":
        local = place @ mi.ScalarTransform4f().translate([0, 0, 0.4 * s]).scale(0.4 * s)
        return {name: {"type": "cube", "to_world": view.transform(mi, local), "bsdf": bsdf}}
    if item.shape == "cylinder":
        tube = place @ mi.ScalarTransform4f().scale([0.35 * s, 0.35 * s, s])
        lid = place @ mi.ScalarTransform4f().translate([0, 0, s]).scale(0.35 * s)
        return {name: {"type": "cylinder", "to_world": view.transform(mi, tube), "bsdf": bsdf},
                f"{name}_top": {"type": "disk", "to_world": view.transform(mi, lid), "bsdf": bsdf}}
    vertices, faces = torus(0.35 * s, 0.15 * s) if item.shape == "torus" else vase(s)
    return {name: mitsuba_mesh(mi, name, vertices, faces, bsdf, view.transform(mi, place))}


def checker_ground_bsdf(config: "SceneConfig", lens: "ThinLens", mi) -> dict:
    """The 10 %/40 % Lambertian checkerboard, :data:`GROUND_SQUARES_PER_VIEW` squares across the view."""
    square = outdoor.view_width_m(config, lens) / GROUND_SQUARES_PER_VIEW
    dark, light = GROUND_REFLECTANCES
    half = outdoor.GROUND_SIZE_M / 2
    return {"type": "diffuse", "reflectance": {
        "type": "checkerboard", "color0": {"type": "uniform", "value": dark},
        "color1": {"type": "uniform", "value": light},
        "to_uv": mi.ScalarTransform4f().scale([half / square, half / square, 1.0])}}


#: scene.object_materials of ``tabletop``: Lambert, rough plastic, rough measured metal, glass.
OBJECT_MATERIALS = ("diffuse", "plastic", "conductor", "glass")


def _materials(value, scene):
    if not value or any(m not in OBJECT_MATERIALS for m in value):
        return "scene.object_materials", list(value), f"give one or more of {', '.join(OBJECT_MATERIALS)}"
    return None


_TABLETOP_KEYS = (
    Key("object_materials", OBJECT_MATERIALS, "tuple[str, ...]", "the materials objects are drawn from: "
        "diffuse, plastic, conductor (measured metals), glass", (_materials,)),
    Key("chart", False, "bool", "true stands a ColorChecker in the tabletop, facing the camera",
        (boolean("true places a ColorChecker in the tabletop, false none"),)),
)


def _sharp_objects(config: "SceneConfig") -> tuple[str, ...]:
    """The sharp-lobed plugins the tabletop's objects may be (none without objects)."""
    if config.scene.object_count == 0:
        return ()
    return tuple(SHARP_PLUGINS[m] for m in config.scene.object_materials if m in SHARP_PLUGINS)


@PRESETS.register("tabletop", options=("distance_m", "view_pitch_deg", "light", "object_count", "object_size",
                                       "object_reflectances", "layout_seed", "ground", "soil_reflectances"),
                  keys=_TABLETOP_KEYS, sharp_materials=_sharp_objects,
                  description="objects (plastic, metal, glass, meshes) on a textured or checkered ground under the "
                              "sun and sky")
def tabletop(config: "SceneConfig", lens: "ThinLens", mi) -> dict:
    """The ground, the objects of :func:`tabletop_layout` and the light
    (:func:`spectral_cam.presets.outdoor.light`)."""
    from ..reflectance_sets import reflectance_set

    samples = reflectance_set(config.scene.object_reflectances)
    view = outdoor.GroundView.from_config(config)
    if config.scene.ground == "checker":
        ground_bsdf = checker_ground_bsdf(config, lens, mi)
    elif config.scene.ground == "flat":
        ground_bsdf = diffuse(reflectance_set(config.scene.soil_reflectances).sds[0])
    elif config.scene.ground == "table":
        ground_bsdf = outdoor.table_bsdf(config, lens, mi)
    else:
        ground_bsdf = outdoor.textured_ground_bsdf(config, lens, mi)
    far = (diffuse(sum(GROUND_REFLECTANCES) / 2) if config.scene.ground == "checker"
           else diffuse(reflectance_set(config.scene.soil_reflectances).sds[0]))
    objects = {"ground": outdoor.ground(view, mi, ground_bsdf), **outdoor.far_ground(view, mi, far, seed=config.scene.layout_seed)}
    if config.scene.ground == "table":  # a room: the table stands before a wall
        objects.update(outdoor.backdrop(config, lens, mi, view))
    if config.scene.chart:
        objects.update(colorchecker_board(config, lens, mi, view))
    for n, item in enumerate(tabletop_layout(config, lens, len(samples))):
        objects.update(_shape(mi, view, item, _bsdf(item, samples), f"object_{n}"))
    objects.update(outdoor.light(config, view, mi))
    return objects
