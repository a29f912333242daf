"""Running a dataset (issue 8): a LocalCluster renders tiny items; resume, regeneration,
a worker killed mid-item, poison items, the CLI on a scheduler address and the progress
bar behave as specified."""

from __future__ import annotations

import io
import json
import os
import shutil
import signal
from pathlib import Path

import numpy as np
import pytest

from spectral_cam.apps.dataset import ProgressBar, generate_dataset, load_spec, render_item, spec_from_dict
from spectral_cam.errors import ConfigError
from spectral_cam.io import staged_directory

from .reading import item_pixels, read_exr, read_manifest, without_timings

ITEM_FILES = {"raw.dng", "image.png", "radiance.exr", "depth.exr", "defocus.exr", "all_in_focus.png",
              "clean_rgb.exr", "meta.json"}


@pytest.mark.timeout(300)
def test_six_items_write_manifest_and_files(first_run):
    out, summary = first_run.out, first_run.summary
    assert (summary.items, summary.rendered, summary.resumed, summary.failed) == (6, 6, 0, 0)
    rows = read_manifest(out)
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
        clean = read_exr(item / "clean_rgb.exr")
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
    summary = generate_dataset(first_run.spec, out, n=6, executor=cluster.executor, progress=False)
    assert (summary.rendered, summary.resumed, summary.failed) == (0, 6, 0)
    assert all(r["resumed"] and r["status"] == "done" for r in read_manifest(out))
    assert before == {p: p.stat().st_mtime_ns for p in (out / "items").rglob("*")}
    # another spec is refused for this folder
    other = spec_from_dict({"dataset": {"seed": 8}, "sensor": {"width_px": 24, "height_px": 16}})
    with pytest.raises(ConfigError, match="another spec"):
        generate_dataset(other, out, n=1, executor=cluster.executor, progress=False)


@pytest.mark.timeout(300)
def test_deleted_item_regenerates_identically(first_run, cluster, tmp_path):
    out = tmp_path / "copy"
    shutil.copytree(first_run.out, out)
    item = out / "items" / "000003"
    old_pixels = item_pixels(item)
    old_meta = json.loads((item / "meta.json").read_text())
    shutil.rmtree(item)
    (out / "items" / "000004" / "defocus.exr").unlink()  # an incomplete folder is not finished either
    summary = generate_dataset(first_run.spec, out, n=6, executor=cluster.executor, progress=False)
    assert (summary.rendered, summary.resumed, summary.failed) == (2, 4, 0)
    assert [r["index"] for r in read_manifest(out) if not r["resumed"]] == [3, 4]
    new_pixels = item_pixels(item)
    assert new_pixels.keys() == old_pixels.keys()
    for name, pixels in old_pixels.items():
        np.testing.assert_array_equal(new_pixels[name], pixels, err_msg=name)
    assert without_timings(json.loads((item / "meta.json").read_text())) == without_timings(old_meta)


@pytest.mark.timeout(300)
def test_killed_worker_is_retried(cluster, spec_file):
    out = cluster.base / "killed"
    target = out / "items" / "000001"
    marker = cluster.base / "killed.marker"

    def kill_first_attempt(task):
        """The first attempt at item 000001 dies mid-item (SIGKILL of its worker), leaving a
        half-written staging folder; every other attempt renders normally."""
        if task["id"] == "000001":
            try:
                fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                pass
            else:
                os.close(fd)
                with staged_directory(task["path"], force=True) as stage:
                    (stage / "raw.dng").write_bytes(b"half an item")
                    os.kill(os.getpid(), signal.SIGKILL)
        return render_item(task)

    spec = load_spec(spec_file, overrides=["render.spp=2"])
    summary = generate_dataset(spec, out, n=3, executor=cluster.executor, progress=False,
                               item_function=kill_first_attempt)
    assert marker.is_file(), "the worker was not killed"
    assert (summary.rendered, summary.failed, summary.retried) == (3, 0, 1)
    rows = read_manifest(out)
    assert [r["status"] for r in rows] == ["done"] * 3
    assert [r["attempts"] for r in rows] == [1, 2, 1]
    assert (target / "meta.json").is_file()
    assert not [p for p in (out / "items").iterdir() if p.name.startswith(".")]


@pytest.mark.timeout(300)
def test_poison_items_fail_and_the_rest_complete(cluster, tmp_path):
    (tmp_path / "broken.xml").write_text("<scene version='3.0.0'><shape type='no_such_plugin'/></scene>")
    spec_path = tmp_path / "poison.toml"
    # 0.05 m is a possible focus at 25 mm, not at 100 mm: the spec loads (no value is impossible
    # everywhere, issue 39 #14) and only the item drawing both is rejected
    spec_path.write_text("""
[dataset]
outputs = ["raw", "image", "depth", "defocus"]
[dataset.sweep]
"scene.mitsuba_xml" = ["", "broken.xml"]
"lens.focal_length_mm" = [25.0, 100.0]
"lens.focus_distance_m" = [0.05, 2.0]
[sensor]
width_px = 24
height_px = 16
[render]
spp = 2
""")
    out = tmp_path / "poison"
    summary = generate_dataset(load_spec(spec_path), out, executor=cluster.executor, progress=False)
    rows = read_manifest(out)
    assert [tuple(r["params"].values()) for r in rows] == [
        (xml, f, d) for xml in ("", "broken.xml") for f in (25.0, 100.0) for d in (0.05, 2.0)]
    assert [r["status"] for r in rows] == ["done", "done", "failed", "done"] + ["failed"] * 4
    assert (summary.rendered, summary.failed) == (3, 5)
    for index in (2, 6):  # impossible values: rejected before rendering, with what would be valid
        assert "lens.focus_distance_m" in rows[index]["error"] and "focal length" in rows[index]["error"]
        assert rows[index]["attempts"] == 0
    for index in (4, 5, 7):
        assert rows[index]["error"].startswith("RenderError") and rows[index]["attempts"] == 1
        assert not (out / "items" / rows[index]["id"]).exists()
    assert rows[1]["error"] is None and (out / "items" / "000001" / "raw.dng").is_file()


@pytest.mark.timeout(300)
def test_cli_sweep_on_a_scheduler_address(cluster, points_spec_file, tmp_path, capsys):
    from spectral_cam import cli

    spec = points_spec_file
    out = tmp_path / "sweep"
    status = cli.main(["dataset", str(spec), "-o", str(out), "--sweep", "lens.focus_distance_m=1:2:2",
                       "--scheduler", cluster.client.scheduler.address])
    assert status == 0, capsys.readouterr().err
    err = capsys.readouterr().err
    assert "2 items, 2 rendered, 0 resumed, 0 failed" in err and "items/min" in err
    assert [r["params"] for r in read_manifest(out)] == [{"lens.focus_distance_m": 1.0},
                                                         {"lens.focus_distance_m": 2.0}]
    assert (out / "contact_sheet.png").is_file() and (out / "blur_vs_depth.png").is_file()
    # a bad sweep is a user error: one message, exit 2
    assert cli.main(["dataset", str(spec), "-o", str(out), "--sweep", "lens.nope=1:2:2"]) == 2
    assert "unknown key 'lens.nope'" in capsys.readouterr().err
    # two items per grid point re-plans which index gets which focus: resume must re-render
    # the items whose planned parameters changed, never relabel an old folder
    status = cli.main(["dataset", str(spec), "-o", str(out), "-n", "2", "--sweep", "lens.focus_distance_m=1:2:2",
                       "--scheduler", cluster.client.scheduler.address])
    assert status == 0, capsys.readouterr().err
    for row in read_manifest(out):
        meta = json.loads((out / row["path"] / "meta.json").read_text())
        assert meta["config"]["lens"]["focus_distance_m"] == row["params"]["lens.focus_distance_m"]
    # items 0 and 1 held f = 1 m and 2 m; now 0 and 1 are 1 m, 2 and 3 are 2 m
    assert [r["resumed"] for r in read_manifest(out)] == [True, False, False, False]


@pytest.mark.timeout(60)
def test_progress_bar_shows_rate_and_eta():
    stream = io.StringIO()
    bar = ProgressBar(10, resumed=2, stream=stream, every_s=0.0)
    bar.started -= 60.0  # one minute in
    bar.update(done=3, failed=1)
    bar.close()
    lines = stream.getvalue().splitlines()
    assert lines[-1].startswith("dataset [") and "6/10 items" in lines[-1]
    assert "2 resumed" in lines[-1] and "1 failed" in lines[-1]
    assert "4.0 items/min" in lines[-1] and "ETA 1 min 00 s" in lines[-1]


def test_the_local_cluster_listens_on_loopback_only_and_serves_no_pages(cluster):
    """Issue 12 #16: Dask's identity, worker, log and exception pages were served on 0.0.0.0:8787."""
    import urllib.error
    import urllib.request

    import psutil

    me = psutil.Process()
    pids = {me.pid} | {child.pid for child in me.children(recursive=True)}
    listening = [c.laddr for c in psutil.net_connections(kind="inet")
                 if c.status == psutil.CONN_LISTEN and c.pid in pids]
    assert listening, "the cluster's servers were not found"
    assert {address.ip for address in listening} == {"127.0.0.1"}, listening
    port = cluster.client.cluster.scheduler.http_server.port
    assert port != 8787
    for page in ("/info/main/workers.html", "/status", "/json/identity.json"):
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(f"http://127.0.0.1:{port}{page}", timeout=10)
        assert refused.value.code == 404, page


@pytest.mark.timeout(300)
def test_truncated_or_empty_files_are_not_taken_for_finished_items(first_run, cluster, tmp_path):
    """Issue 12 #13: resume trusted file existence; each file's size and SHA-256 are kept and checked."""
    out = tmp_path / "copy"
    shutil.copytree(first_run.out, out)
    dng = out / "items" / "000001" / "raw.dng"
    good = dng.read_bytes()
    dng.write_bytes(good[: len(good) // 2])                       # truncated
    (out / "items" / "000002" / "image.png").write_bytes(b"")      # 0 bytes
    png = out / "items" / "000005" / "image.png"
    flipped = bytearray(png.read_bytes())
    flipped[-20] ^= 0xFF                                            # same size, other bytes
    png.write_bytes(bytes(flipped))
    summary = generate_dataset(first_run.spec, out, n=6, executor=cluster.executor, progress=False)
    assert (summary.rendered, summary.resumed) == (3, 3)
    assert dng.read_bytes() == good  # regenerated identically
    rows = read_manifest(out)
    assert all(set(r["file_checks"]) == {Path(f).name for f in r["files"]} - {"meta.json"} for r in rows)


@pytest.mark.timeout(300)
def test_resuming_on_another_variant_warns(first_run, cluster, tmp_path):
    """Issue 12 #4: items of two Mitsuba variants were mixed silently."""
    from spectral_cam.apps.dataset.run import ResumeVariantWarning

    out = tmp_path / "copy"
    shutil.copytree(first_run.out, out)
    meta_path = out / "items" / "000000" / "meta.json"
    meta = json.loads(meta_path.read_text())
    here = meta["render"]["variant"]
    assert here in ("llvm_ad_spectral", "scalar_spectral", "cuda_ad_spectral")
    other = "scalar_spectral" if here != "scalar_spectral" else "llvm_ad_spectral"
    meta["render"]["variant"] = other  # as if rendered on another machine
    meta_path.write_text(json.dumps(meta))
    shutil.rmtree(out / "items" / "000004")
    with pytest.warns(ResumeVariantWarning, match=f"rendered with {other}"):
        generate_dataset(first_run.spec, out, n=6, executor=cluster.executor, progress=False)
    variants = {r["index"]: r["variant"] for r in read_manifest(out)}  # the manifest records each item's
    assert variants[0] == other and variants[4] == here


@pytest.mark.timeout(60)
def test_without_dask_nothing_is_created(tmp_path, monkeypatch):
    """Issue 12 #8: without the dask extra the folder, a lock and manifest rows appeared first."""
    import sys

    monkeypatch.setitem(sys.modules, "dask.distributed", None)  # import fails as if not installed
    spec = spec_from_dict({"sensor": {"width_px": 24, "height_px": 16}})
    with pytest.raises(ConfigError, match=r"needs dask.distributed: pip install 'spectral_cam\[dask\]'"):
        generate_dataset(spec, tmp_path / "ds", n=1, progress=False)
    assert not (tmp_path / "ds").exists()


@pytest.mark.timeout(60)
def test_a_huge_dataset_starts_rendering_at_once(tmp_path, monkeypatch):
    """Issue 12 #12: -n 100000000000 planned every item before rendering any (growing ~6.5 MB/s)."""
    import time

    usage = shutil.disk_usage(tmp_path)  # an exabyte free: the disk check (below) passes
    monkeypatch.setattr(shutil, "disk_usage", lambda path: usage._replace(free=10 ** 18))
    spec = spec_from_dict({"sensor": {"width_px": 24, "height_px": 16},
                           "lens": {"f_number": {"log_uniform": [2.0, 8.0]}}})
    calls = []

    def item_function(task):
        calls.append(task["index"])
        if len(calls) > 3:
            raise KeyboardInterrupt  # the user stops the run
        return {"status": "done", "files": [], "error": None}

    started = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        generate_dataset(spec, tmp_path / "huge", n=10 ** 11, scheduler="inline", progress=False,
                         item_function=item_function)
    assert time.perf_counter() - started < 20
    assert calls == [0, 1, 2, 3]
    rows = read_manifest(tmp_path / "huge")  # the manifest holds what was planned, not 10^11 rows
    assert [r["status"] for r in rows] == ["done", "done", "done", "pending"]


def test_a_dataset_that_cannot_fit_on_the_disk_is_refused_before_rendering(tmp_path):
    """Issue 25 #8: 10^11 items of 24 × 16 px, each at least its DNG, PNG and depth map
    (job.estimate_result_bytes), need millions of GB: refused before any item renders."""
    spec = spec_from_dict({"sensor": {"width_px": 24, "height_px": 16}})
    with pytest.raises(ConfigError, match=r"100000000000 items of about .* MB each needs about .* GB but .* free"):
        generate_dataset(spec, tmp_path / "huge", n=10 ** 11, scheduler="inline", progress=False,
                         item_function=lambda task: pytest.fail("rendered before the disk check"))


def test_dataset_dry_run_totals_the_plans_of_its_first_items(capsys):
    """Issue 26: ``dataset --dry-run`` plans the first items (their cost measured by probes) and
    totals them: time over the workers, memory per worker, files; nothing rendered to disk."""
    from spectral_cam.apps.dataset import PLANNED_SAMPLE, plan_dataset
    from spectral_cam.cli import main

    spec = spec_from_dict({"sensor": {"width_px": 24, "height_px": 16}, "render": {"spp": 4},
                           "lens": {"f_number": {"log_uniform": [2.0, 8.0]}}})
    text = plan_dataset(spec, n=40, workers=4)
    assert text.count("\nitem ") + text.startswith("item ") == PLANNED_SAMPLE
    total = text.splitlines()[-1]
    assert total.startswith("dataset: 40 items on 4 worker processes: about ")
    item_s = float(total.split("(")[1].split(" s an item")[0])
    assert float(total.split("about ")[1].split(" s")[0]) == pytest.approx(item_s * 40 / 4, rel=0.01)
    assert "inline" not in plan_dataset(spec, n=40, scheduler="inline") and \
        "on 1 worker process:" in plan_dataset(spec, n=40, scheduler="inline")
    capsys.readouterr()
    assert main(["dataset", str(Path(__file__).resolve().parents[3] / "plans" / "dataset_example.toml")]) == 2
    assert "-o DIR" in capsys.readouterr().err
