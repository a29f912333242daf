"""Each preset's registry entry declares the sharp-lobed materials it places
(``Preset.sharp_materials``, which ``render.estimator = "auto"`` reads to decide whether fireflies
can arise), and the declaration is held here to the BSDFs the preset actually builds: every
delta lobe, and every GGX lobe of α < ``SHARP_ALPHA``, in a bundled scene's Mitsuba dict is a
plugin its preset declares.

The threshold's meaning is checked against Mitsuba's own GGX distribution: the normal
distribution's peak D(n) is 1/(π·α²) (Walter et al. 2007, eq. 33 at θm = 0), which
``SHARP_ALPHA`` = 0.1 puts at 1/(0.01·π) ≈ 32 sr⁻¹.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

pytestmark = pytest.mark.timeout(300)

ROOT = Path(__file__).resolve().parents[2]
#: Mitsuba plugins whose lobe is a delta (a perfect mirror or refraction).
DELTA_PLUGINS = {"conductor", "dielectric", "thindielectric", "plastic"}
#: Plugins with a GGX roughness ``alpha`` (the leaf's only with a cuticle, ``eta`` given).
ROUGH_PLUGINS = {"roughconductor", "roughdielectric", "roughplastic"}


#: Mitsuba's class names of the sharp-capable plugins, as ``str(bsdf)`` starts them.
CLASS_PLUGINS = {"SmoothConductor": "conductor", "SmoothDielectric": "dielectric", "ThinDielectric": "thindielectric",
                 "SmoothPlastic": "plastic", "RoughConductor": "roughconductor", "RoughDielectric": "roughdielectric",
                 "RoughPlastic": "roughplastic"}


def _sharp_in_dict(value, found: set) -> None:
    """Sharp plugins among a scene dict's BSDF dicts (nested ``twosided``, ``blendbsdf``,
    shape groups included); Mitsuba's default α where a dict gives none: 0.1, the leaf's 0.3."""
    from spectral_cam.leaves import LEAF_PLUGIN
    from spectral_cam.presets.common import SHARP_ALPHA

    if isinstance(value, dict):
        kind = value.get("type")
        rough = kind in ROUGH_PLUGINS or (kind == LEAF_PLUGIN and "eta" in value)
        alpha = float(value.get("alpha", 0.3 if kind == LEAF_PLUGIN else 0.1))
        if kind in DELTA_PLUGINS or (rough and alpha < SHARP_ALPHA):
            found.add(kind)
        for item in value.values():
            _sharp_in_dict(item, found)
    else:
        import mitsuba as mi

        if isinstance(value, mi.Shape) and value.bsdf() is not None:
            _sharp_in_object(value.bsdf(), found)


def _sharp_in_object(bsdf, found: set) -> None:
    """A loaded BSDF (a preset's ``mi.Mesh`` carries one): sharp if a delta lobe, or a glossy
    lobe of α < SHARP_ALPHA (α from ``mi.traverse``, or the leaf plugin's own attribute)."""
    import re

    import mitsuba as mi

    from spectral_cam.leaves import LEAF_PLUGIN
    from spectral_cam.presets.common import SHARP_ALPHA

    flags = int(bsdf.flags())
    text = str(bsdf)
    names = {CLASS_PLUGINS[c] for c in re.findall(r"\b(" + "|".join(CLASS_PLUGINS) + r")\[", text)}
    if text.startswith(LEAF_PLUGIN):
        names.add(LEAF_PLUGIN)
    if flags & int(mi.BSDFFlags.Delta):
        found.update(names & DELTA_PLUGINS or {text.split("[")[0]})
    if flags & int(mi.BSDFFlags.Glossy):
        params = mi.traverse(bsdf)
        alphas = [float(params[k][0]) if hasattr(params[k], "__len__") else float(params[k])
                  for k in params.keys() if re.search(r"alpha(_u|_v)?(\.value)?$", k)]
        alphas += [bsdf.alpha] if hasattr(bsdf, "alpha") else []
        assert alphas, f"a glossy BSDF whose roughness the test cannot read: {text[:80]}"
        if min(alphas) < SHARP_ALPHA:
            found.update((names - DELTA_PLUGINS) or {text.split("[")[0]})


def _sharp_built(objects) -> set[str]:
    found: set[str] = set()
    for value in objects.values():
        _sharp_in_dict(value, found)
    return found


def _preset_scenes():
    """One bundled scene per preset: the one named after it, else the first in name order (field,
    field_litter and meadow build the vegetation and tabletop presets again, at 3-4 s each)."""
    import tomllib

    seen = {}
    for path in sorted((ROOT / "scenes").glob("*.toml")):
        scene = tomllib.loads(path.read_text()).get("scene", {})
        preset = scene.get("preset", "colorchecker")
        if not scene.get("mitsuba_xml") and (preset not in seen or path.stem == preset):
            seen[preset] = path.stem
    return sorted(seen.values())


@pytest.mark.parametrize("scene", _preset_scenes())
def test_a_bundled_scene_builds_no_sharp_material_its_preset_does_not_declare(scene):
    """Built at the scene's own frame and view (the layout depends on the view)."""
    import mitsuba as mi

    import spectral_cam as sc
    from spectral_cam.optics import ThinLens
    from spectral_cam.presets import PRESETS, build_objects
    from spectral_cam.render.leaf_bsdf import register as register_leaf
    from spectral_cam.render.variants import choose_variant

    mi.set_variant(choose_variant("auto"))
    register_leaf(mi)
    config = sc.load_scene(ROOT / "scenes" / f"{scene}.toml")
    lens = ThinLens.from_config(config.lens, config.sensor)
    built = _sharp_built(build_objects(config, lens, mi))
    declared = set(PRESETS[config.scene.preset].sharp_materials(config))
    assert built <= declared, f"{scene}: builds {sorted(built - declared)} that its preset does not declare"


def test_the_tabletop_declares_its_glass_and_polished_objects_and_nothing_without_objects():
    import spectral_cam as sc
    from spectral_cam.presets import PRESETS
    from spectral_cam.presets.common import SHARP_ALPHA
    from spectral_cam.presets.tabletop import ROUGHNESS_RANGE

    assert ROUGHNESS_RANGE[0] < SHARP_ALPHA  # why plastics and metals are declared at all
    entry = PRESETS["tabletop"]
    config = sc.load_scene(ROOT / "scenes" / "tabletop.toml")
    assert set(entry.sharp_materials(config)) == {"dielectric", "roughplastic", "roughconductor"}
    only_diffuse = sc.load_scene(ROOT / "scenes" / "tabletop.toml", overrides={"scene.object_materials": ["diffuse"]})
    assert entry.sharp_materials(only_diffuse) == ()
    empty = sc.load_scene(ROOT / "scenes" / "tabletop.toml", overrides={"scene.object_count": 0})
    assert entry.sharp_materials(empty) == ()


def test_auto_estimator_reads_the_declaration():
    """A preset declaring none keeps the unbiased mean without probing; the tabletop's glass
    takes the median at 8 passes of 8 spp."""
    import spectral_cam as sc
    from spectral_cam.render.decisions import decide_estimator

    def no_probe(config, lens):
        raise AssertionError("a preset without sharp materials must not be probed")

    room = sc.load_scene(ROOT / "scenes" / "room.toml")
    k, record = decide_estimator(room, 64, probe=no_probe)
    assert k == 1 and "room preset's materials are Lambertian or rough" in record["reason"]
    table = sc.load_scene(ROOT / "scenes" / "tabletop.toml")
    k, record = decide_estimator(table, 64, probe=no_probe)
    assert k == 8 and "dielectric" in record["reason"]


def test_sharp_alpha_is_a_ggx_peak_of_32_per_steradian():
    """Mitsuba's GGX D at the normal equals 1/(π·α²) (Walter et al. 2007), so α = SHARP_ALPHA
    peaks at about 32 sr⁻¹."""
    import mitsuba as mi

    from spectral_cam.presets.common import SHARP_ALPHA
    from spectral_cam.render.variants import choose_variant

    mi.set_variant(choose_variant("auto"))
    for alpha in (0.05, SHARP_ALPHA, 0.3):
        ggx = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, alpha, alpha, True)
        peak = float(ggx.eval(mi.Vector3f(0, 0, 1))[0])
        assert peak == pytest.approx(1 / (math.pi * alpha ** 2), rel=1e-5)
    assert 1 / (math.pi * SHARP_ALPHA ** 2) == pytest.approx(31.8, abs=0.1)


def test_the_detector_finds_delta_and_polished_lobes_and_passes_rough_ones():
    """The check above is only as good as its detector: a loaded glass, a polished metal inside a
    ``twosided`` and a GGX-0.05 plastic dict are found; a satin plastic (α 0.2) and a matte
    diffuse are not."""
    import mitsuba as mi

    from spectral_cam.render.variants import choose_variant

    mi.set_variant(choose_variant("auto"))
    found: set[str] = set()
    for bsdf in ({"type": "dielectric"}, {"type": "twosided", "bsdf": {"type": "roughconductor", "alpha": 0.05}},
                 {"type": "roughplastic", "alpha": 0.2}, {"type": "diffuse"}):
        _sharp_in_object(mi.load_dict(bsdf), found)
    assert found == {"dielectric", "roughconductor"}
    in_dict: set[str] = set()
    _sharp_in_dict({"a": {"type": "twosided", "bsdf": {"type": "roughplastic", "alpha": 0.05}},
                    "b": {"type": "roughplastic", "alpha": 0.3}}, in_dict)
    assert in_dict == {"roughplastic"}
