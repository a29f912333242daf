"""Ground clutter at scale (``[[scene.scatter]]``, spectral_cam/presets/scatter.py): the scene-file
checks, the Poisson layout, the memory of instances and the radiance of instanced and merged
copies against the same objects as separate shapes.

References: the homogeneous Poisson process (Illian et al. 2008, §2.4): the count in a region is
Poisson with mean density × area; the memory is the process's peak resident set (Linux's
VmHWM), each case in a fresh interpreter."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from spectral_cam.errors import ConfigError
from spectral_cam.presets.scatter import (MAX_INSTANCES, SCATTER_KINDS, parse_distribution, scatter_layout)
from spectral_cam.scene import load_scene, scene_from_dict

pytestmark = pytest.mark.timeout(600)


def _outdoor(scatter, pitch_um=6.0, **scene):
    return scene_from_dict({"scene": {"preset": "tabletop", "object_count": 0, "ground": "flat", "scatter": scatter,
                                      **scene},
                            "sensor": {"width_px": 48, "height_px": 32, "pixel_pitch_um": pitch_um},
                            "render": {"spp": 4}})


# ----------------------------------------------------------------------------- the scene file
def test_distributions_parse_draw_and_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    lognormal = parse_distribution("k", {"lognormal": [-3.0, 0.5]}, low=0.0, high=10.0)
    draws = lognormal.draw(rng, 20000)
    assert abs(np.median(draws) - np.exp(-3.0)) < 0.02 * np.exp(-3.0)
    uniform = parse_distribution("k", [0.1, 0.3], low=0.0, high=1.0)
    assert uniform.kind == "uniform" and 0.1 <= uniform.draw(rng, 100).min() <= uniform.draw(rng, 100).max() <= 0.3
    assert parse_distribution("k", 5, low=0.0, high=10.0).draw(rng) == 5.0
    scene = _outdoor([{"kind": "stones", "density_per_m2": {"log_uniform": [10.0, 100.0]},
                       "size_m": {"lognormal": [-4.0, 0.4]}}, {"kind": "straw", "density_per_m2": 20, "name": "hay"}])
    (tmp_path / "s.toml").write_text(scene.to_toml())
    assert load_scene(tmp_path / "s.toml") == scene


@pytest.mark.parametrize("entry, message", [
    ({"kind": "boulders", "density_per_m2": 1}, "unknown kind; valid: stones"),
    ({"kind": "stones"}, "density_per_m2"),
    ({"kind": "stones", "density_per_m2": -1}, "density_per_m2"),
    ({"kind": "stones", "density_per_m2": 10, "size_m": [0.2, 0.1]}, "size_m"),
    ({"kind": "stones", "density_per_m2": 10, "size_m": {"gamma": [1, 2]}}, "unknown distribution"),
    ({"kind": "stones", "density_per_m2": 10, "size_m": {"lognormal": [3.0, 1.0]}}, "99.9 % quantile"),
    ({"kind": "stones", "density_per_m2": 10, "variants": 0}, "variants"),
    ({"kind": "stones", "density_per_m2": 10, "colour": 1}, "unknown key"),
])
def test_bad_scatter_is_refused_with_a_message(entry, message):
    with pytest.raises(ConfigError, match=message):
        _outdoor([entry])


def test_a_density_past_the_memory_bound_is_refused_at_load():
    """~1 m² in view at 90 000 per m² passes MAX_INSTANCES: refused when the scene is read."""
    table = {"scene": {"preset": "tabletop", "scatter": [{"kind": "stones", "density_per_m2": 90000}]},
             "sensor": {"width_px": 48, "height_px": 32, "pixel_pitch_um": 60.0}}
    with pytest.raises(ConfigError, match="more than 60,000"):
        scene_from_dict(table)


def test_scatter_needs_an_outdoor_preset():
    with pytest.raises(ConfigError, match="outdoor preset"):
        scene_from_dict({"scene": {"preset": "dead_leaves", "scatter": [{"kind": "stones", "density_per_m2": 1}]}})


# ----------------------------------------------------------------------------- the layout
def test_layout_is_a_poisson_process_over_the_ground_in_view():
    """Counts over 40 seeds have the Poisson mean density × area (within 4 standard errors) and
    a variance near the mean; every foot lies in the region; a seed repeats its layout."""
    from spectral_cam.optics import ThinLens
    from spectral_cam.presets.assets import ground_in_view
    from spectral_cam.presets.scatter import _area

    density = 200.0
    counts = []
    for seed in range(40):
        config = _outdoor([{"kind": "stones", "density_per_m2": density, "size_m": 0.02}], pitch_um=40.0,
                          layout_seed=seed)
        lens = ThinLens.from_config(config.lens, config.sensor)
        layout = scatter_layout(config, lens, 0)
        counts.append(len(layout))
        box, inside = ground_in_view(config, lens, 3.0 * config.scene.distance_m)
        assert inside(np.array([[p.east_m, p.north_m] for p in layout])).all()
    mean = density * _area(box, inside, samples=400)
    counts = np.array(counts)
    assert abs(counts.mean() - mean) < 4 * np.sqrt(mean / len(counts)), (counts.mean(), mean)
    assert 0.5 < counts.var(ddof=1) / mean < 1.7
    assert scatter_layout(config, lens, 0) == layout


def test_every_kind_makes_a_closed_small_mesh():
    import types

    for kind in SCATTER_KINDS:
        vertices, faces, bsdf = SCATTER_KINDS[kind](np.random.default_rng(1), types.SimpleNamespace())
        assert np.all(np.isfinite(vertices)) and faces.max() < len(vertices) and len(faces) <= 200
        extent = np.ptp(vertices, axis=0)
        assert 0.5 < max(extent[:2].max(), extent[2] if kind == "grass_blades" else 0) <= 1.5


# ----------------------------------------------------------------------------- memory
_PROBE = textwrap.dedent("""
    import resource, sys
    import numpy as np
    import mitsuba as mi
    mi.set_variant(sys.argv[1])
    from spectral_cam.presets.assets import MeshData, place_copies
    from spectral_cam.presets.meshes import lathe
    count = int(sys.argv[2])
    t = np.linspace(0.0, np.pi, 12)
    vertices, faces = lathe(np.sin(t) + 1e-6, np.cos(t), 24)  # a 528-triangle stone
    side = int(np.ceil(np.sqrt(count)))
    places = []
    for k in range(count):
        m = np.eye(4) * 0.3
        m[3, 3] = 1.0
        m[:3, 3] = (k % side, k // side, 0.0)
        places.append(m)
    bsdf = {"type": "twosided", "bsdf": {"type": "diffuse"}}
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": 3},
             "sensor": {"type": "perspective", "fov": 60, "to_world": mi.ScalarTransform4f().look_at(
                 [side / 2, side / 2, 2.0 * side], [side / 2, side / 2, 0], [0, 1, 0]),
                 "film": {"type": "hdrfilm", "width": 32, "height": 32}},
             "light": {"type": "directional", "direction": [0, 0, -1]}}
    scene.update(place_copies(mi, np.eye(4), MeshData(vertices, faces), bsdf, places, name="stone",
                              group_key="group", merged_key="stones"))
    assert any(v.get("type") == "instance" for v in scene.values() if isinstance(v, dict))
    image = np.asarray(mi.render(mi.load_dict(scene), spp=1))
    assert image.max() > 0
    try:  # this process's own peak: ru_maxrss keeps the forking parent's across exec on Linux
        with open("/proc/self/status") as status:
            print(next(int(line.split()[1]) for line in status if line.startswith("VmHWM:")))
    except OSError:
        print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
""")


def _peak_kb(variant: str, count: int) -> int:
    done = subprocess.run([sys.executable, "-c", _PROBE, variant, str(count)], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return int(done.stdout.split()[-1])


def test_ten_thousand_instances_cost_at_most_one_and_a_half_times_one():
    """In a variant that instances (scalar_spectral: one transform per instance), a scene of
    10 000 instances of a 528-triangle stone peaks at ≤ 1.5× the memory of the scene of one,
    and below a 5-kB-per-instance bound (measured: 118 → 165 MB)."""
    one, many = _peak_kb("scalar_spectral", 1), _peak_kb("scalar_spectral", 10000)
    print(f"peak RSS: 1 instance {one / 1024:.0f} MB, 10 000 instances {many / 1024:.0f} MB, ratio {many / one:.2f}")
    assert many <= 1.5 * one
    assert (many - one) / 10000 < 6.0  # kB per instance
    assert MAX_INSTANCES * 6.0 / 1024 < 400  # the scene bound keeps instances under 0.4 GB


# ----------------------------------------------------------------------------- radiance
def _render(mi, objects: dict, spp: int, seed: int) -> np.ndarray:
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": 4},
             "sensor": {"type": "perspective", "fov": 40, "to_world": mi.ScalarTransform4f().look_at(
                 [0.0, -1.2, 1.0], [0.0, 0.0, 0.0], [0, 0, 1]),
                 "film": {"type": "hdrfilm", "width": 32, "height": 24, "rfilter": {"type": "box"}},
                 "sampler": {"type": "independent", "sample_count": spp}},
             "light": {"type": "directional", "direction": [0.3, 0.2, -1.0], "irradiance": {"type": "uniform",
                                                                                             "value": 3.0}},
             "floor": {"type": "rectangle", "bsdf": {"type": "diffuse", "reflectance": {"type": "uniform", "value": 0.3}}},
             **objects}
    return np.asarray(mi.render(mi.load_dict(scene), spp=spp, seed=seed), dtype=np.float64)


@pytest.mark.parametrize("variant_kind", ["scalar", "jit"])
def test_copies_render_the_radiance_of_separate_shapes(variant_kind, variant):
    """40 stones as place_copies makes them (instances in the scalar variant, one merged mesh in
    the JIT variants of Mitsuba ≤ 3.9.1) render the radiance of the same stones as 40
    separate meshes: the frame's mean within 1 %, the per-pixel difference no larger than
    between two seeds of the separate render (Monte-Carlo noise)."""
    import mitsuba as mi

    from spectral_cam.presets.assets import MeshData, asset_mesh, place_copies, use_instances

    name = "scalar_spectral" if variant_kind == "scalar" else variant
    if variant_kind == "jit" and variant.startswith("scalar"):
        pytest.skip("no JIT variant on this machine")
    mi.set_variant(name)
    vertices, faces, bsdf = SCATTER_KINDS["stones"](np.random.default_rng(4), mi)
    data = MeshData(vertices, faces)
    rng = np.random.default_rng(5)
    places = []
    for _ in range(40):
        c, s = np.cos(rng.uniform(0, 2 * np.pi)), np.sin(rng.uniform(0, 2 * np.pi))
        m = np.eye(4)
        m[:3, :3] = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) * rng.uniform(0.05, 0.15)
        m[:3, 3] = (rng.uniform(-0.5, 0.5), rng.uniform(-0.4, 0.4), 0.0)
        places.append(m)
    copies = place_copies(mi, np.eye(4), data, bsdf, places, name="stones", group_key="group", merged_key="stones_0")
    assert any(isinstance(v, dict) and v.get("type") == "instance" for v in copies.values()) == use_instances(mi)
    separate = {f"stone_{k}": asset_mesh(mi, f"stone_{k}", data, bsdf, m) for k, m in enumerate(places)}
    spp = 64
    a = _render(mi, copies, spp, seed=1)
    b = _render(mi, separate, spp, seed=1)
    c = _render(mi, separate, spp, seed=2)
    noise = np.abs(b - c).mean()
    print(f"{name}: mean copies {a.mean():.5f}, separate {b.mean():.5f}; |copies − separate| {np.abs(a - b).mean():.5f}, "
          f"|seed 1 − seed 2| {noise:.5f}")
    assert abs(a.mean() - b.mean()) < 0.01 * b.mean()
    assert np.abs(a - b).mean() <= 1.2 * noise


def test_the_shape_map_names_assets_and_scatter(variant):
    """The segmentation's shape map (Mitsuba's shape_index AOV) names the pixels of an asset, an
    asset's copies and each scatter kind: merged copies (the JIT variants of Mitsuba ≤ 3.9.1) as
    ``<name>_<variant>``, whose class is the name."""
    from spectral_cam.apps.dataset.labels import shape_class
    from spectral_cam.render import render_shape_map

    if variant.startswith("scalar"):
        pytest.skip("no JIT variant on this machine")
    config = scene_from_dict({
        "scene": {"preset": "tabletop", "object_count": 0, "ground": "flat", "distance_m": 1.0, "view_pitch_deg": -60.0,
                  "assets": [{"file": "rock", "scale": 0.2, "position_m": [0.04, 0.0, 0.0]},
                             {"file": "crate", "name": "box", "count": 3, "scale": 0.2, "spread_m": 0.1,
                              "position_m": [-0.05, 0.0, 0.0]}],
                  "scatter": [{"kind": "stones", "density_per_m2": 3000, "size_m": 0.01, "variants": 2}]},
        "sensor": {"width_px": 64, "height_px": 48, "pixel_pitch_um": 24.0},
        "render": {"variant": variant}})
    index, names = render_shape_map(config)
    shown = [names[k] for k in np.unique(index) if k >= 0]
    assert {"rock", "box", "stones", "ground"} <= {shape_class(n) for n in shown}, shown


def test_scalar_instances_each_have_their_own_shape_index():
    """In the scalar variant the shape_index AOV reports an instance's own place in
    ``scene.shapes()`` (from 1, as render/depth.py reads the scalar variant), so each copy
    placed as an instance is its own segment ``<name>_<n>`` (the JIT variants report the
    shapegroup's inner mesh instead: scatter.instanced_meshes)."""
    import mitsuba as mi

    from spectral_cam.presets.assets import MeshData, place_copies

    mi.set_variant("scalar_spectral")
    vertices, faces, bsdf = SCATTER_KINDS["clods"](np.random.default_rng(2), mi)
    places = []
    for k in range(3):
        m = np.eye(4) * 0.6
        m[3, 3], m[:3, 3] = 1.0, (k - 1.0, 0.0, 0.0)
        places.append(m)
    scene = mi.load_dict({"type": "scene", "integrator": {"type": "aov", "aovs": "index:shape_index"},
                          "sensor": {"type": "orthographic", "to_world": mi.ScalarTransform4f().look_at(
                              [0, 0, 5], [0, 0, 0], [0, 1, 0]).scale([1.8, 0.6, 1]),
                              "film": {"type": "hdrfilm", "width": 48, "height": 16, "rfilter": {"type": "box"}}},
                          **place_copies(mi, np.eye(4), MeshData(vertices, faces), bsdf, places, name="clods",
                                         group_key="g", merged_key="clods_0")}, optimize=False)
    names = [shape.id() for shape in scene.shapes()]
    value = np.rint(np.asarray(mi.render(scene, spp=1))[..., 0]).astype(int)
    seen = {names[v - 1] for v in np.unique(value) if v > 0}
    assert seen == {"clods_0", "clods_1", "clods_2"}, seen
