"""Issue 41 #4: a label is one registry entry — writer, reader, description, files and size —
so a label registered from this test module, touching no file of the package, runs end to end:
the spec takes it, a dataset run writes it and records it in meta.json, the card describes it,
:class:`SyntheticDataset` reads it back through its reader, and the dry run counts its size."""

from __future__ import annotations

import json

import numpy as np
import pytest

from spectral_cam.apps.dataset import SyntheticDataset, generate_dataset, plan_dataset, read_item, spec_from_dict
from spectral_cam.apps.dataset.labels import LABELS
from spectral_cam.exr import write_exr_channels
from spectral_cam.spectral_exr import read_exr

TOY = "inverse_depth"
#: A deliberately large size, so the dry run's total shows it at its three significant figures.
TOY_BYTES_PER_PIXEL = 1.0e5


def _read_toy(path):
    return {TOY: read_exr(path)[1]["D"].astype(np.float32)}


def _write_toy(item, folder):
    """Disparity 1/z (1/m; 0 where nothing was hit): a label no module of the package knows."""
    depth = np.asarray(item.sim.radiance.depth_m, dtype=np.float64)
    with np.errstate(divide="ignore"):
        disparity = np.where(np.isfinite(depth), 1.0 / depth, 0.0).astype(np.float32)
    path = write_exr_channels({"D": disparity}, folder / f"{TOY}.exr", {"spectral_cam_units": "1/m"})
    item.records[TOY] = {"file": path.name, "channel": "D", "units": "1/m"}
    return [path]


@pytest.fixture
def toy_label():
    LABELS.add(TOY, _write_toy, options=(TOY,), files=(f"{TOY}.exr",), reader=_read_toy,
               bytes_per_pixel=TOY_BYTES_PER_PIXEL,
               description=f"{TOY}.exr: disparity 1/z, 1/m (channel D; 0 where no surface)")
    try:
        yield LABELS[TOY]
    finally:
        LABELS.unregister(TOY)


SPEC = {"dataset": {"seed": 3, "outputs": ["depth", TOY]},
        "scene": {"preset": "dof_targets", "depths_m": [1.0, 2.0, 4.0]},
        "sensor": {"width_px": 24, "height_px": 16}, "render": {"spp": 2},
        "lens": {"focal_length_mm": 25.0, "f_number": 4.0, "focus_distance_m": 2.0}}


@pytest.mark.timeout(600)
def test_a_label_registered_from_outside_the_package_runs_end_to_end(toy_label, tmp_path):
    out = tmp_path / "toy"
    summary = generate_dataset(spec_from_dict(SPEC), out, n=2, scheduler="inline", progress=False)
    assert (summary.rendered, summary.failed) == (2, 0)
    data = SyntheticDataset(out)
    assert len(data) == 2
    for index in range(2):
        item = data[index]
        depth = item["depth"]  # the renderer's depth label, read by the package's own reader
        hit = np.isfinite(depth)
        assert hit.any() and item[TOY].shape == depth.shape
        np.testing.assert_allclose(item[TOY][hit], 1.0 / depth[hit], rtol=1e-6)
        assert np.all(item[TOY][~hit] == 0)
        meta = data.records(index)["meta"]
        assert meta[TOY] == {"file": f"{TOY}.exr", "channel": "D", "units": "1/m"}
        assert f"{TOY}.exr" in meta["dataset"]["file_checks"] and meta["dataset"]["labels"][TOY] == [f"{TOY}.exr"]
    folder = out / "items" / data.rows[0]["id"]
    assert set(read_item(folder, [TOY])) == {"meta", TOY}
    assert toy_label.description.partition(": ")[2] in (out / "README.md").read_text(encoding="utf-8")
    rows = [json.loads(line) for line in (out / "manifest.jsonl").read_text().splitlines() if line.strip()]
    assert all(any(name.endswith(f"{TOY}.exr") for name in row["files"]) for row in rows)
    # a rerun finds the items whole (their toy files checked like any other) and renders nothing
    again = generate_dataset(spec_from_dict(SPEC), out, n=2, scheduler="inline", progress=False)
    assert (again.rendered, again.resumed) == (0, 2)


@pytest.mark.timeout(600)
def test_the_dry_run_totals_a_labels_size_estimate(toy_label):
    """The toy's 10^5 B/px × 24 × 16 px = 38.4 MB an item dwarfs the depth map (about 6 kB), so the
    dry run's file total for 100 items is the toy's 3.84 GB within 1 %."""
    assert toy_label.estimate_bytes(24, 16) == pytest.approx(toy_label.fixed_bytes + 24 * 16 * TOY_BYTES_PER_PIXEL)
    total = plan_dataset(spec_from_dict(SPEC), n=100, scheduler="inline").splitlines()[-1]
    gigabytes = float(total.split("files about ")[1].split(" GB")[0])
    assert gigabytes == pytest.approx(100 * toy_label.estimate_bytes(24, 16) / 1e9, rel=0.01)


def test_a_label_registered_twice_or_with_a_negative_size_is_refused():
    with pytest.raises(ValueError, match="registered twice"):
        LABELS.add("depth", _write_toy)
    with pytest.raises(ValueError, match="bytes_per_pixel"):
        LABELS.add("negative_size", _write_toy, bytes_per_pixel=-1.0)
    assert "negative_size" not in LABELS
