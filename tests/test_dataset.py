"""Dataset generation (issue 8): a LocalCluster renders tiny items; resume, regeneration,
a worker killed mid-item, defocus labels and poison items behave as specified."""

from __future__ import annotations

import io
import json
import math
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from spectral_cam.errors import ConfigError
from spectral_cam import dataset as ds

SPEC = """
[dataset]
seed = 7
outputs = ["raw", "image", "radiance", "depth", "defocus", "all_in_focus", "clean_rgb"]

[scene]
preset = "dof_targets"
depths_m = [1.0, 2.0, 4.0]

[sensor]
width_px = 24
height_px = 16
model = { choice = ["nikon_d850", "sony_ilce_7m3"] }

[render]
spp = 4

[lens]
focal_length_mm = 25.0
f_number = { log_uniform = [1.4, 8.0] }
focus_distance_m = { uniform = [0.8, 4.0] }

[exposure]
iso = { choice = [100, 400], weights = [3, 1] }
"""

ITEM_FILES = {"raw.dng", "image.png", "radiance.exr", "depth.exr", "defocus.exr", "all_in_focus.png",
              "clean_rgb.exr", "meta.json"}


def _exr(path: Path) -> dict[str, np.ndarray]:
    import OpenEXR

    out = {}
    with OpenEXR.File(str(path)) as exr:
        for name, channel in exr.channels().items():
            pixels = np.array(channel.pixels)
            if pixels.ndim == 3:  # the bindings group R, G, B (and A) into one "RGB" entry
                out.update({letter: pixels[..., i] for i, letter in enumerate(name)})
            else:
                out[name] = pixels
    return out


def _png(path: Path) -> np.ndarray:
    import cv2

    return cv2.imread(str(path), cv2.IMREAD_UNCHANGED)


def _manifest(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "manifest.jsonl").read_text().splitlines()]


def _without_timings(value):
    """meta.json minus what legitimately changes between runs: timings."""
    if isinstance(value, dict):
        return {k: _without_timings(v) for k, v in value.items()
                if "timing" not in k and not k.endswith("_cpu_s")}
    if isinstance(value, list):
        return [_without_timings(v) for v in value]
    return value


def _pixels(item: Path) -> dict[str, np.ndarray]:
    import tifffile  # LibRaw refuses frames under 22 px high, so read the DNG's CFA page directly

    out = {"raw": tifffile.imread(item / "raw.dng"), "image": _png(item / "image.png"),
           "all_in_focus": _png(item / "all_in_focus.png")}
    for name in ("radiance", "depth", "defocus", "clean_rgb"):
        for channel, pixels in _exr(item / f"{name}.exr").items():
            out[f"{name}/{channel}"] = pixels
    return out


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """One LocalCluster (2 spawned workers × 1 thread) for the module. Its workers carry the
    test hook: the first attempt at ``killed/items/000001`` SIGKILLs its own worker."""
    base = tmp_path_factory.mktemp("dataset")
    kill_target = base / "killed" / "items" / "000001"
    with ds.local_cluster(2, env={ds.TEST_KILL_ENV: str(kill_target)}) as client:
        yield SimpleNamespace(client=client, executor=client.get_executor(pure=False), base=base,
                              kill_target=kill_target)


@pytest.fixture(scope="module")
def spec_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("spec") / "spec.toml"
    path.write_text(SPEC)
    return path


@pytest.fixture(scope="module")
def first_run(cluster, spec_file):
    out = cluster.base / "six"
    summary = ds.generate_dataset(ds.load_spec(spec_file), out, n=6, executor=cluster.executor, progress=False)
    return SimpleNamespace(out=out, summary=summary, spec=ds.load_spec(spec_file))


# ----------------------------------------------------------------------------- acceptance
@pytest.mark.timeout(300)
def test_six_items_write_manifest_and_files(first_run):
    out, summary = first_run.out, first_run.summary
    assert (summary.items, summary.rendered, summary.resumed, summary.failed) == (6, 6, 0, 0)
    rows = _manifest(out)
    assert [r["index"] for r in rows] == list(range(6))
    assert all(r["status"] == "done" and r["error"] is None and not r["resumed"] for r in rows)
    assert len({r["seed"] for r in rows}) == 6
    for row in rows:
        item = out / row["path"]
        assert {Path(f).name for f in row["files"]} == ITEM_FILES == {p.name for p in item.iterdir()}
        assert all((out / f).is_file() for f in row["files"])
        params = row["params"]
        assert set(params) == {"sensor.model", "lens.f_number", "lens.focus_distance_m", "exposure.iso"}
        assert 1.4 <= params["lens.f_number"] <= 8.0 and 0.8 <= params["lens.focus_distance_m"] <= 4.0
        assert params["exposure.iso"] in (100, 400)
        # the plan is a pure function of (spec, index): seeds and draws are reproducible
        plan = first_run.spec.plan_item(row["index"])
        assert (plan.seed, plan.params) == (row["seed"], params)
        meta = json.loads((item / "meta.json").read_text())
        assert meta["dataset"]["seed"] == row["seed"] == meta["config"]["render"]["seed"]
        assert meta["config"]["lens"]["f_number"] == pytest.approx(params["lens.f_number"])
        assert meta["config"]["lens"]["model"] == "thin" and meta["render"]["lens_model"] == "thin"
        # the all-in-focus image: same pose through a pinhole at the main item's exposure
        assert meta["all_in_focus"]["lens_model"] == "pinhole"
        assert meta["all_in_focus"]["exposure_s"] == meta["sensor"]["exposure_s"]
        clean = _exr(item / "clean_rgb.exr")
        assert set(clean) == {"R", "G", "B"} and clean["G"].shape == (16, 24) and clean["G"].max() > 0
    assert (out / "contact_sheet.png").is_file()
    info = json.loads((out / "dataset.json").read_text())
    assert info["spec_hash"] == first_run.spec.hash and info["items"] == 6
    assert not [p for p in (out / "items").iterdir() if p.name.startswith(".")]


@pytest.mark.timeout(300)
def test_rerun_skips_all_six(first_run, cluster, tmp_path):
    out = tmp_path / "copy"
    shutil.copytree(first_run.out, out)
    before = {p: p.stat().st_mtime_ns for p in (out / "items").rglob("*")}
    summary = ds.generate_dataset(first_run.spec, out, n=6, executor=cluster.executor, progress=False)
    assert (summary.rendered, summary.resumed, summary.failed) == (0, 6, 0)
    assert all(r["resumed"] and r["status"] == "done" for r in _manifest(out))
    assert before == {p: p.stat().st_mtime_ns for p in (out / "items").rglob("*")}
    # another spec is refused for this folder
    other = ds.spec_from_dict({"dataset": {"seed": 8}, "sensor": {"width_px": 24, "height_px": 16}})
    with pytest.raises(ConfigError, match="another spec"):
        ds.generate_dataset(other, out, n=1, executor=cluster.executor, progress=False)


@pytest.mark.timeout(300)
def test_deleted_item_regenerates_identically(first_run, cluster, tmp_path):
    out = tmp_path / "copy"
    shutil.copytree(first_run.out, out)
    item = out / "items" / "000003"
    old_pixels = _pixels(item)
    old_meta = json.loads((item / "meta.json").read_text())
    shutil.rmtree(item)
    (out / "items" / "000004" / "defocus.exr").unlink()  # an incomplete folder is not finished either
    summary = ds.generate_dataset(first_run.spec, out, n=6, executor=cluster.executor, progress=False)
    assert (summary.rendered, summary.resumed, summary.failed) == (2, 4, 0)
    assert [r["index"] for r in _manifest(out) if not r["resumed"]] == [3, 4]
    new_pixels = _pixels(item)
    assert new_pixels.keys() == old_pixels.keys()
    for name, pixels in old_pixels.items():
        np.testing.assert_array_equal(new_pixels[name], pixels, err_msg=name)
    assert _without_timings(json.loads((item / "meta.json").read_text())) == _without_timings(old_meta)


@pytest.mark.timeout(300)
def test_killed_worker_is_retried(cluster, spec_file):
    out = cluster.base / "killed"
    spec = ds.load_spec(spec_file, overrides=["render.spp=2"])
    summary = ds.generate_dataset(spec, out, n=3, executor=cluster.executor, progress=False)
    assert Path(f"{cluster.kill_target}.killed").is_file(), "the test hook did not fire"
    assert (summary.rendered, summary.failed, summary.retried) == (3, 0, 1)
    rows = _manifest(out)
    assert [r["status"] for r in rows] == ["done"] * 3
    assert [r["attempts"] for r in rows] == [1, 2, 1]
    assert (cluster.kill_target / "meta.json").is_file()
    assert not [p for p in (out / "items").iterdir() if p.name.startswith(".")]


def test_defocus_map_is_the_thin_lens_coc(first_run):
    checked = 0
    for row in _manifest(first_run.out):
        item = first_run.out / row["path"]
        meta = json.loads((item / "meta.json").read_text())
        lens, sensor = meta["config"]["lens"], meta["config"]["sensor"]
        f = lens["focal_length_mm"] * 1e-3
        aperture = f / lens["f_number"]
        z_f = lens["focus_distance_m"]
        pitch = sensor["pixel_pitch_um"] * 1e-6
        depth = _exr(item / "depth.exr")["Z"]
        defocus = _exr(item / "defocus.exr")["CoC"]
        assert defocus.shape == depth.shape == (16, 24)
        for r, c in [(0, 0), (8, 12), (15, 23), (4, 3), (11, 20)]:
            z = float(depth[r, c])
            assert math.isfinite(z)
            expected = aperture * f * (z - z_f) / (z * (z_f - f)) / pitch  # signed, + behind focus
            assert defocus[r, c] == pytest.approx(expected, rel=1e-5, abs=1e-6)
            checked += 1
        assert np.abs(defocus).max() > 0.1
    assert checked == 30


@pytest.mark.timeout(300)
def test_poison_items_fail_and_the_rest_complete(cluster, tmp_path):
    (tmp_path / "broken.xml").write_text("<scene version='3.0.0'><shape type='no_such_plugin'/></scene>")
    spec_path = tmp_path / "poison.toml"
    spec_path.write_text("""
[dataset]
outputs = ["raw", "image", "depth", "defocus"]
[dataset.sweep]
"scene.mitsuba_xml" = ["", "broken.xml"]
"lens.focus_distance_m" = [0.01, 2.0]
[sensor]
width_px = 24
height_px = 16
[render]
spp = 2
[lens]
focal_length_mm = 25.0
""")
    out = tmp_path / "poison"
    summary = ds.generate_dataset(ds.load_spec(spec_path), out, executor=cluster.executor, progress=False)
    rows = _manifest(out)
    assert [(r["params"]["scene.mitsuba_xml"], r["params"]["lens.focus_distance_m"]) for r in rows] == [
        ("", 0.01), ("", 2.0), ("broken.xml", 0.01), ("broken.xml", 2.0)]
    assert [r["status"] for r in rows] == ["failed", "done", "failed", "failed"]
    assert (summary.rendered, summary.failed) == (1, 3)
    for index in (0, 2):  # impossible values: rejected before rendering, with what would be valid
        assert "lens.focus_distance_m" in rows[index]["error"] and "focal length" in rows[index]["error"]
        assert rows[index]["attempts"] == 0
    assert rows[3]["error"].startswith("RenderError") and rows[3]["attempts"] == 1
    assert rows[1]["error"] is None and (out / "items" / "000001" / "raw.dng").is_file()
    assert not (out / "items" / "000003").exists()


@pytest.mark.timeout(300)
def test_cli_sweep_on_a_scheduler_address(cluster, tmp_path, capsys):
    from spectral_cam import cli

    spec = tmp_path / "points.toml"
    spec.write_text("""
[scene]
preset = "point_sources"
depths_m = [0.5, 2.0]
source_radius_m = 0.0005
[sensor]
width_px = 48
height_px = 16
[render]
spp = 4
[lens]
focal_length_mm = 25.0
f_number = 8.0
""")
    out = tmp_path / "sweep"
    status = cli.main(["dataset", str(spec), "-o", str(out), "--sweep", "lens.focus_distance_m=1:2:2",
                       "--scheduler", cluster.client.scheduler.address])
    assert status == 0, capsys.readouterr().err
    err = capsys.readouterr().err
    assert "2 items, 2 rendered, 0 resumed, 0 failed" in err and "items/min" in err
    assert [r["params"] for r in _manifest(out)] == [{"lens.focus_distance_m": 1.0}, {"lens.focus_distance_m": 2.0}]
    assert (out / "contact_sheet.png").is_file() and (out / "blur_vs_depth.png").is_file()
    import csv

    with open(out / "blur_vs_depth.csv") as handle:
        table = list(csv.DictReader(handle))
    assert {round(float(r["depth_m"]), 3) for r in table} == {0.5, 2.0}
    for r in table:
        z, z_f, f = float(r["depth_m"]), float(r["lens.focus_distance_m"]), 0.025
        predicted = (f / 8.0) * f * abs(z - z_f) / (z * (z_f - f)) / 6e-6
        assert float(r["predicted_coc_px"]) == pytest.approx(predicted, rel=1e-4)
    # a bad sweep is a user error: one message, exit 2
    assert cli.main(["dataset", str(spec), "-o", str(out), "--sweep", "lens.nope=1:2:2"]) == 2
    assert "unknown key 'lens.nope'" in capsys.readouterr().err
    # two items per grid point re-plans which index gets which focus: resume must re-render
    # the items whose planned parameters changed, never relabel an old folder
    status = cli.main(["dataset", str(spec), "-o", str(out), "-n", "2", "--sweep", "lens.focus_distance_m=1:2:2",
                       "--scheduler", cluster.client.scheduler.address])
    assert status == 0, capsys.readouterr().err
    for row in _manifest(out):
        meta = json.loads((out / row["path"] / "meta.json").read_text())
        assert meta["config"]["lens"]["focus_distance_m"] == row["params"]["lens.focus_distance_m"]
    # items 0 and 1 held f = 1 m and 2 m; now 0 and 1 are 1 m, 2 and 3 are 2 m
    assert [r["resumed"] for r in _manifest(out)] == [True, False, False, False]


# ----------------------------------------------------------------------------- units
def test_spec_draws_sweeps_and_errors(tmp_path):
    spec = ds.spec_from_dict({
        "dataset": {"seed": 3, "n": 50},
        "sensor": {"width_px": {"uniform": [20, 40]}, "height_px": 16},
        "scene": {"preset": "dof_targets", "depths_m": {"uniform": [[0.5, 1.0, 2.0], [1.0, 3.0, 8.0]]}},
        "lens": {"f_number": {"log_uniform": [1.4, 16.0]}},
    })
    plans = [spec.plan_item(i) for i in range(50)]
    assert all(p.error is None for p in plans)
    widths = [p.params["sensor.width_px"] for p in plans]
    assert all(isinstance(w, int) and 20 <= w <= 40 for w in widths) and len(set(widths)) > 5
    depths = np.array([p.params["scene.depths_m"] for p in plans])
    assert np.all(depths >= [0.5, 1.0, 2.0]) and np.all(depths <= [1.0, 3.0, 8.0])
    logs = np.log([p.params["lens.f_number"] for p in plans])
    assert np.log(1.4) <= logs.min() and logs.max() <= np.log(16.0)
    # an item's draw does not depend on how many items there are, nor on the outputs
    more = ds.spec_from_dict({**{"dataset": {"seed": 3, "outputs": ["raw"]}},
                              "sensor": {"width_px": {"uniform": [20, 40]}, "height_px": 16},
                              "scene": {"preset": "dof_targets",
                                        "depths_m": {"uniform": [[0.5, 1.0, 2.0], [1.0, 3.0, 8.0]]}},
                              "lens": {"f_number": {"log_uniform": [1.4, 16.0]}}})
    assert more.hash == spec.hash and more.plan_item(7).params == plans[7].params
    assert ds.spec_from_dict({"dataset": {"seed": 4}}).hash != ds.spec_from_dict({"dataset": {"seed": 3}}).hash

    sweep = ds.parse_sweep("lens.f_number=1.4:5.6:3:log")
    assert sweep.values == pytest.approx((1.4, 2.8, 5.6))
    assert ds.parse_sweep("lens.focus_distance_m=0.5:5:10").values[-1] == 5.0
    assert ds.parse_sweep("sensor.width_px=[32, 48]").values == (32, 48)
    grid = ds.spec_from_dict({}, sweeps=["lens.f_number=[2.0, 4.0]", "lens.focus_distance_m=1:3:3"])
    assert grid.item_count(2) == 12
    assert [grid.plan_item(i, 2).params for i in (0, 1, 2, 11)] == [
        {"lens.f_number": 2.0, "lens.focus_distance_m": 1.0}, {"lens.f_number": 2.0, "lens.focus_distance_m": 1.0},
        {"lens.f_number": 2.0, "lens.focus_distance_m": 2.0}, {"lens.f_number": 4.0, "lens.focus_distance_m": 3.0}]

    bad = [
        ({"lens": {"f_numbr": 2.0}}, "unknown key 'lens.f_numbr'"),
        ({"lens": {"f_number": {"gaussian": [1, 2]}}}, "exactly one of uniform, log_uniform, choice"),
        ({"lens": {"f_number": {"log_uniform": [0, 2]}}}, "must be > 0"),
        ({"lens": {"f_number": {"uniform": [4, 2]}}}, "low <= high"),
        ({"sensor": {"model": {"choice": ["a", "b"], "weights": [1]}}}, "weights must be 2 numbers"),
        ({"dataset": {"outputs": ["raw", "jpeg"]}}, "unknown output 'jpeg'"),
        ({"dataset": {"sede": 1}}, "valid keys of \\[dataset\\]"),
        ({"render": {"spectral_output": True}}, "add or remove 'radiance'"),
    ]
    for data, message in bad:
        with pytest.raises(ConfigError, match=message):
            ds.spec_from_dict(data)
    for text, message in [("lens.f_number=1:2", "start:stop:count"), ("lens.f_number=0:2:3:log", "start, stop > 0"),
                          ("lens.f_number", "section.key=start:stop:count")]:
        with pytest.raises(ConfigError, match=message):
            ds.parse_sweep(text)
    with pytest.raises(ConfigError, match="both swept and drawn"):
        ds.spec_from_dict({"lens": {"f_number": {"uniform": [2, 4]}}}, sweeps=["lens.f_number=[2.0]"])
    with pytest.raises(ConfigError, match="-n N"):
        ds.spec_from_dict({}).item_count()


def test_clean_rgb_is_the_noise_free_raw(make_scene):
    """With every noise term off, the RAW is the clean camera RGB through the CFA, quantised."""
    from spectral_cam import spectra
    from spectral_cam.image import SpectralImage
    from spectral_cam.sensor import expose

    config = make_scene(sensor={"shot_noise": False, "read_noise_e": 0.0, "dark_current_e_per_s": 0.0,
                                "dsnu_e": 0.0, "prnu": 0.0, "cfa": "GRBG"},
                        exposure={"time_s": 0.01}, lens={"f_number": 4.0})
    bands = spectra.parse_bands("400:700:10")
    rng = np.random.default_rng(1)
    cube = rng.uniform(0.0, 0.02, (16, 24, len(bands.centres_nm))).astype(np.float32)
    radiance = SpectralImage(cube, np.asarray(bands.centres_nm), np.asarray(bands.edges_nm))
    raw = expose(radiance, config)
    clean = ds.clean_camera_rgb(radiance, config, exposure_s=0.01)
    assert clean.shape == (16, 24, 3) and 0.05 < clean.max() < 1.0
    layout = ((1, 0), (2, 1))  # GRBG
    through_cfa = np.empty((16, 24))
    for a in (0, 1):
        for b in (0, 1):
            through_cfa[a::2, b::2] = clean[a::2, b::2, layout[a][b]]
    span = raw.white_level - raw.black_level
    measured = (raw.mosaic.astype(float) - raw.black_level) / span
    np.testing.assert_allclose(measured, through_cfa, atol=0.5 / span + 1e-6)


def test_measure_blur_recovers_a_disc_on_supersampled_texture():
    """A smooth texture rendered at 16× and box-averaged (as the renderer integrates pixels),
    blurred by known discs before averaging: the fit recovers the diameters."""
    import cv2

    ss, height, width = 16, 40, 48
    rng = np.random.default_rng(0)
    coarse = rng.uniform(0.1, 0.9, (height // 4 + 2, width // 4 + 2)).astype(np.float32)
    fine = cv2.resize(coarse, ((width // 4 + 2) * 4 * ss, (height // 4 + 2) * 4 * ss),
                      interpolation=cv2.INTER_CUBIC)[:height * ss, :width * ss]

    def down(image):
        return image.reshape(height, ss, width, ss).mean(axis=(1, 3))

    sharp = down(fine)
    mask = np.zeros((height, width), dtype=bool)
    mask[10:-10, 10:-10] = True
    for diameter in (0.0, 2.5, 6.0):
        radius = diameter / 2 * ss
        reach = int(math.ceil(radius)) + 1
        yy, xx = np.mgrid[-reach:reach + 1, -reach:reach + 1]
        kernel = ((xx ** 2 + yy ** 2) <= radius ** 2).astype(np.float32)
        kernel /= kernel.sum()
        blurred = down(cv2.filter2D(fine, -1, kernel, borderType=cv2.BORDER_REFLECT))
        measured = ds.measure_blur(sharp, blurred, mask, max_diameter_px=12.0)
        assert measured == pytest.approx(diameter, abs=0.03 + 0.02 * diameter)
    assert math.isnan(ds.measure_blur(sharp, sharp, np.zeros_like(mask), max_diameter_px=4.0))


def test_progress_bar_shows_rate_and_eta():
    stream = io.StringIO()
    bar = ds.ProgressBar(10, resumed=2, stream=stream, every_s=0.0)
    bar.started -= 60.0  # one minute in
    bar.update(done=3, failed=1)
    bar.close()
    lines = stream.getvalue().splitlines()
    assert lines[-1].startswith("dataset [") and "6/10 items" in lines[-1]
    assert "2 resumed" in lines[-1] and "1 failed" in lines[-1]
    assert "4.0 items/min" in lines[-1] and "ETA 1 min 00 s" in lines[-1]


def test_whole_number_bounds_beyond_float_precision_are_refused():
    with pytest.raises(ConfigError, match="below 2\\*\\*53"):
        ds.spec_from_dict({"sensor": {"width_px": {"uniform": [1e30, 2e30]}}})
