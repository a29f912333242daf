"""The capture plan (issue 26, :mod:`spectral_cam.render.plan`): every decision made once, the
records agreeing with what was done, and ``--dry-run`` showing it before rendering.

Counts are instrumented by wrapping the functions that build the lens, choose the variant,
resolve the focus, render depth and check memory and tiling. The optics recorded are checked
against a lens built independently from the resolved ``scene.toml``; reproduction against the
DNG's bytes from a fresh folder with the cache emptied."""

from __future__ import annotations

import collections
import hashlib
import importlib
import shutil
import tomllib
import warnings
from pathlib import Path

import pytest

import spectral_cam as sc
from spectral_cam.job import run_render_job
from spectral_cam.optics import ThinLens

pytestmark = pytest.mark.timeout(300)

ROOT = Path(__file__).resolve().parents[2]
SMALL = {"sensor.width_px": 48, "sensor.height_px": 32}
#: The bundled scenes and the variants the issue names: the layered and prescription lens
#: models, a user's XML scene, and a focus object.
JOBS = {**{p.stem: (p.name, {}) for p in sorted((ROOT / "scenes").glob("*.toml"))},
        "dof_layered": ("dof.toml", {"lens.model": "layered"}),
        "dof_prescription": ("dof.toml", {"lens.model": "prescription", "lens.f_number": 4.0}),  # dof.toml: f/1.4
        "tabletop_focus_object": ("tabletop.toml", {"lens.focus_object": "object_3"})}


def _config(job: str):
    name, overrides = JOBS[job]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sc.errors.SceneWarning)  # a prescription replacing f and N, said
        config = sc.load_scene(ROOT / "scenes" / name, overrides={**SMALL, **overrides})
    if config.render.spp != "auto":
        config = config.replace(**{"render.spp": min(int(config.render.spp), 8)})
    return config


def _module(name: str):
    return importlib.import_module(f"spectral_cam.render.{name}")


@pytest.fixture
def counted(monkeypatch):
    """Counts of the calls a job should make once."""
    counts: collections.Counter = collections.Counter()

    def wrap(module, name, key):
        original = getattr(module, name)

        def counting(*args, **kwargs):
            counts[key] += 1
            return original(*args, **kwargs)
        monkeypatch.setattr(module, name, counting)

    wrap(_module("variants"), "choose_variant_record", "variant")
    wrap(_module("variants"), "choose_variant", "variant")
    wrap(_module("focus"), "resolve_focus", "focus")
    wrap(_module("depth"), "render_depth", "depth")
    wrap(_module("layered"), "render_depth", "layered_depth")  # the layered model's own supersampled input
    wrap(_module("memory"), "check_render_memory", "memory")
    wrap(_module("trace"), "check_tiling", "tiling")
    original = ThinLens.from_config.__func__

    def from_config(cls, *args, **kwargs):
        counts["lens"] += 1
        return original(cls, *args, **kwargs)
    monkeypatch.setattr(ThinLens, "from_config", classmethod(from_config))
    return counts


@pytest.mark.parametrize("job", ["glass_sphere", "tabletop_focus_object", "dof_prescription", "dof_layered"])
def test_a_job_decides_each_thing_once(tmp_path, counted, job):
    """Issue 26 measured up to 5 lens builds, 5 variant choices, 2 focus resolutions, 2 memory and
    tiling checks and 3 renders of one depth map per job."""
    config = _config(job)
    counted.clear()
    run_render_job(config, tmp_path / "out")
    assert counted["lens"] == 1 and counted["variant"] == 1 and counted["focus"] == 1
    assert counted["memory"] == 1 and counted["tiling"] == 1
    assert counted["depth"] == 1  # the plan's probe: the lens decision, the layered margin and depth.exr
    # the layered model blurs from its own 4²-sample nearest depth over its widened area
    assert counted["layered_depth"] == (1 if job == "dof_layered" else 0)


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.timeout(600)
@pytest.mark.parametrize("job", sorted(set(JOBS) - {"tabletop_focus_object"}))
def test_records_are_what_was_done_and_scene_toml_renders_the_same_dng(tmp_path, monkeypatch, job):
    """On the renderer's own threads (issue 39 #17: the meshes' normals no longer follow their
    timing, so no one-thread fixture is needed). The focus-object variant is the bundled tabletop
    itself (scenes/tabletop.toml focuses on object_0), so its object_3 copy is left to
    test_a_job_decides_each_thing_once (two jobs of ~3 s each saved)."""
    config = _config(job)
    meta = run_render_job(config, tmp_path / "first")
    written = (tmp_path / "first" / "scene.toml").read_text()
    table = tomllib.loads(written)
    # no "auto" left where the plan chose before rendering
    assert table["lens"]["model"] == meta["render"]["lens_model"] != "auto"
    assert table["render"]["variant"] == meta["render"]["variant"]
    assert table["render"]["bands"] == meta["render"]["bands"] != "auto"
    assert table["render"]["estimator"] in ("mean", "amon") and table["render"]["diffraction"] in ("on", "off")
    if not table["scene"].get("mitsuba_xml"):
        assert table["scene"]["light"] != "auto"
    # meta.optics is the frame's lens, built here from the resolved scene
    resolved = sc.load_scene(tmp_path / "first" / "scene.toml")
    frame = ThinLens.from_config(resolved.lens, resolved.sensor).describe()
    optics = {k: v for k, v in meta["optics"].items() if k not in ("rendered_margin_px", "rendered_size_px")}
    assert optics == pytest.approx(frame, rel=1e-12)
    assert meta["plan"]["lens_model"] == meta["render"]["lens_model"]
    # the folder alone renders the same DNG elsewhere, the cache emptied
    moved = tmp_path / "moved"
    shutil.copytree(tmp_path / "first", moved)
    shutil.rmtree(tmp_path / "first")
    monkeypatch.setenv("SPECTRAL_CAM_CACHE_DIR", str(tmp_path / "empty_cache"))
    run_render_job(sc.load_scene(moved / "scene.toml"), tmp_path / "again")
    assert _digest(tmp_path / "again" / "raw.dng") == _digest(moved / "raw.dng")


def test_dry_run_prints_the_plan_and_renders_no_radiance(tmp_path, monkeypatch, capsys):
    from spectral_cam.cli import main

    def no_radiance(*args, **kwargs):
        raise AssertionError("--dry-run traced radiance")
    monkeypatch.setattr(_module("trace"), "build_scene", no_radiance)
    assert main(["render", str(ROOT / "scenes" / "dof.toml"), "--dry-run", "--set", "sensor.width_px=96",
                 "--set", "sensor.height_px=64"]) == 0
    out = capsys.readouterr().out
    for line in ("variant:", "lens_model:", "diffraction:", "bands:", "estimator:", "optics: 25 mm f/1.4",
                 "budget: about", "outputs: radiance"):
        assert line in out, line
    assert "96 × 64 px, +8 px crop margin" in out
    assert not list(tmp_path.iterdir())
    assert main(["render", str(ROOT / "scenes" / "dof.toml")]) == 2  # neither -o nor --dry-run
    assert "-o OUTDIR" in capsys.readouterr().err


@pytest.mark.timeout(600)
@pytest.mark.parametrize("scene, width", [("colorchecker.toml", 960), ("tabletop.toml", 480)])
def test_dry_run_memory_is_within_15_percent_of_the_jobs_peak(tmp_path, request, scene, width):
    """Issue 26: ``--dry-run``'s peak-memory estimate against the job's own peak resident set,
    ``ru_maxrss`` of the waited-for process (Linux wait4(2)), each in its own process; the bundled
    scenes at their own spp (64), as docs/bench/plan.csv measures them. (At 16 spp the tabletop's
    median of 4 pass means is estimated 20 % high: the model's median-of-means share is fitted at
    8 passes; docs/design.md.) The tabletop at its defaults is the job test_fireflies.py reads
    (``tabletop_job``, tests/render/conftest.py): run once for both. The two jobs are the model's
    two regimes: the tabletop's resident scene (its displaced ground) outweighs its frame, the
    ColorChecker at 2× its size is two thirds frame (docs/bench/plan.csv: 12 % high, the
    closest to the bound; at its own 480 px, 2 % low, the same terms with the frame's share
    smaller, so that case is left out)."""
    from .conftest import planned_and_run

    if (scene, width) == ("tabletop.toml", 480):
        plan, peak, _ = request.getfixturevalue("tabletop_job")
    else:
        plan, peak, _ = planned_and_run(scene, width, tmp_path)
    assert plan["budget"]["memory_bytes"] == pytest.approx(peak, rel=0.15)


def test_focus_object_keeps_an_xml_cameras_field_of_view(tmp_path):
    """Issue 26: an XML scene's focal length was derived from its camera's 40° at the file's
    focus distance, then ``focus_object`` moved the focus (changing the image distance, so the
    view) and a warning blamed a focal length the user never set. 2·atan(w/2v) must stay 40°."""
    import math

    xml = tmp_path / "near.xml"
    xml.write_text('''<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, -1" target="0, 0, 0" up="0, 1, 0"/></transform>
    </sensor>
    <shape type="sphere" id="ball"><point name="center" x="0" y="0" z="-0.6"/><float name="radius" value="0.05"/>
        <emitter type="area"><rgb name="radiance" value="5"/></emitter></shape>
</scene>''')
    from spectral_cam.render import execute
    from spectral_cam.render.plan import make_plan

    config = sc.scene_from_dict({"scene": {"mitsuba_xml": str(xml)}, "lens": {"focus_object": "ball"},
                                 "sensor": {"width_px": 48, "height_px": 32}, "render": {"spp": 2}})
    with warnings.catch_warnings():
        warnings.simplefilter("error", sc.errors.SceneWarning)
        plan = make_plan(config, with_margin=False)
        image = execute(plan)
    record = image.meta["model_decisions"]
    assert record["focus"]["choice"] == pytest.approx(0.35, abs=1e-4)  # the ball's near surface, 0.35 m away
    assert record["field_of_view"]["choice"] == "kept"
    resolved = plan.config  # what scene.toml writes, rebuilt here into a lens
    lens = ThinLens.from_config(resolved.lens, resolved.sensor)
    assert resolved.lens.focus_distance_m == pytest.approx(0.35, abs=1e-4)
    assert math.degrees(2 * math.atan(lens.sensor_width_m / 2 / lens.image_distance_m)) == pytest.approx(40.0, abs=1e-6)
