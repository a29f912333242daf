"""The ``scene.*`` keys several presets read (a preset's own keys are declared where it is
registered: ``PRESETS.register(name, keys=...)``). :func:`preset_keys` is what the scene's
``[scene]`` section is assembled from, besides its own core keys.

References
----------
.. [1] docs/design.md, "Scene file" and "Where to make a change".
"""

from __future__ import annotations

from .. import spectra
from ..keys import Key, fraction_in, non_negative_whole, one_of, whole_in
from .common import PRESETS, reads_light

__all__ = ["SHARED_KEYS", "SCENE_LIGHTS", "GROUND_KINDS", "preset_keys", "reflectance_set", "outdoor_presets"]

#: scene.light: "auto" is each preset's own light ("sunsky" for the outdoor presets, else
#: "illuminant"); "sunsky" is Mitsuba's sun and sky per [sky] (presets that declare "light").
SCENE_LIGHTS = ("auto", "sunsky", "illuminant", "overcast")
#: scene.ground of the outdoor presets.
GROUND_KINDS = ("textured", "checker", "flat", "table")


def outdoor_presets() -> list[str]:
    """The presets on the ground of ``outdoor.GroundView`` under the sky (those reading ``light``)."""
    return [name for name in PRESETS if reads_light(name)]


def reflectance_set(*, also: tuple[str, ...] = ()):
    """A check: a bundled reflectance set (or one of ``also``) or a CSV (wavelength_nm, a column a sample)."""
    def check(value, scene):
        if value in also or value in spectra.REFLECTANCE_SET_NAMES or str(value).lower().endswith(".csv"):
            return None
        return (f"valid: {', '.join(spectra.REFLECTANCE_SET_NAMES)} or a CSV (wavelength_nm, one column per "
                "sample)")
    return check


def _depths(value, scene):
    return "give at least one depth in metres" if not value else None


def _light(value, scene):
    if value not in SCENE_LIGHTS:
        return f"valid: {', '.join(SCENE_LIGHTS)}"
    if value in ("sunsky", "overcast") and (scene.mitsuba_xml or not reads_light(scene.preset)):
        return (f"the sun and sky light the outdoor presets ({', '.join(outdoor_presets())}); "
                f"{scene.mitsuba_xml or scene.preset!r} brings its own light")
    return None


def _object_size(value, scene):
    if len(value) != 2 or not 0.005 <= value[0] <= value[1] <= 0.5:
        return ("scene.object_size", list(value), "give [smallest, largest] object size as fractions of the view's "
                "width at the look point, within [0.005, 0.5]")
    return None


def _parse_asset(table, index, base_dir):
    from .assets import asset_from_table

    return asset_from_table(table, index, base_dir)


def _parse_scatter(table, index, base_dir):
    from .scatter import scatter_from_table

    return scatter_from_table(table, index)


def _on_outdoor_ground(value, scene):
    if not (scene.assets or scene.scatter):
        return None
    if scene.mitsuba_xml or scene.preset not in outdoor_presets():
        return ("scene.assets/scatter", scene.mitsuba_xml or scene.preset,
                f"assets and scatter stand on the ground of an outdoor preset ({', '.join(outdoor_presets())})")
    names = [a.name for a in scene.assets] + [s.name for s in scene.scatter]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        return "scene.assets/scatter name", repeated, "each entry needs a name of its own (the segmentation's)"
    return None


#: The keys several presets read; each preset's ``options`` names those it reads.
SHARED_KEYS = (
    Key("distance_m", 2.0, "float", "the subject distance (charts, cornell_box) or the ground point the camera "
        "looks at (outdoor presets, room)", range=(1e-4, 1e6, "m")),
    Key("depths_m", (1.0, 2.0, 4.0), "tuple[float, ...]", "plane or source depths (dof_targets, point_sources, "
        "dead_leaves)", (_depths,), range=(1e-4, 1e6, "m")),
    Key("light", "auto", "str", "auto (sunsky outdoors), sunsky, illuminant or overcast (the CIE overcast sky)",
        (_light,)),
    Key("view_pitch_deg", -25.0, "float", "the camera's tilt (< 0 looks down)",
        (fraction_in(-89.0, -1.0, "must lie in [-89, -1] degrees (the camera looks down at the ground point "
                     "distance_m away)"),)),
    Key("object_count", 8, "int", "how many objects or plants", (whole_in(0, 200, "must be a whole number in 0..200"),)),
    Key("object_size", (0.08, 0.2), "tuple[float, ...]", "[smallest, largest] size, fractions of the view's width "
        "at the look point", (_object_size,)),
    Key("object_reflectances", "cie2017", "str", "the reflectance set objects' colours come from, or a CSV",
        (reflectance_set(),)),
    Key("layout_seed", 0, "int", "draws the layout", (non_negative_whole(),)),
    Key("ground", "textured", "str", "textured (measured soils and litter in fractal patches with relief), "
        "checker, flat (one soil) or table (a wooden table top before a stone wall)",
        (one_of(GROUND_KINDS, "textured: measured soils and litter mixed in fractal patches with relief; checker: "
                "the tabletop's 10 %/40 % checkerboard; flat: one soil sample; table: a wooden table top before a "
                "stone wall"),)),
    Key("soil_reflectances", "usgs_soils", "str", "the soil's reflectance set, or a CSV", (reflectance_set(),)),
    Key("assets", (), "tuple", "[[scene.assets]] tables: users' PLY/OBJ/glTF meshes on an outdoor preset's ground "
        "(spectral_cam.presets.assets)", entries=_parse_asset),
    Key("scatter", (), "tuple", "[[scene.scatter]] tables: instanced stones, clods, straw or grass tufts by "
        "density and size distributions (spectral_cam.presets.scatter)", (_on_outdoor_ground,),
        entries=_parse_scatter),
)


def preset_keys() -> list[tuple[str, Key]]:
    """``(owner, Key)`` of every ``scene.*`` key presets declare: the shared ones, then each preset's own."""
    return [("several presets", key) for key in SHARED_KEYS] + PRESETS.declared_keys()
