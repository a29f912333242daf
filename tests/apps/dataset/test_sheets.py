"""Dataset summaries: the blur chart's numbers are the thin-lens prediction beside the
measurement, and the contact sheet is redrawn from a folder; no pyplot state is touched."""

from __future__ import annotations

import csv
import sys

import pytest

from spectral_cam.apps.dataset import generate_dataset, load_spec, write_blur_chart, write_contact_sheet

pytestmark = pytest.mark.timeout(300)


@pytest.fixture(scope="module")
def point_sweep(cluster, points_spec_file):
    """Two point-source items focused at 1 and 2 m: each measures its blur at 0.5 and 2 m."""
    out = cluster.base / "points"
    spec = load_spec(points_spec_file, sweeps=["lens.focus_distance_m=1:2:2"])
    summary = generate_dataset(spec, out, executor=cluster.executor, progress=False)
    assert summary.rendered == 2
    return out


def test_blur_chart_is_the_thin_lens_beside_the_measurement(point_sweep, tmp_path):
    pyplot_before = "matplotlib.pyplot" in sys.modules
    png = write_blur_chart(point_sweep, png=tmp_path / "blur.png", csv_path=tmp_path / "blur.csv")
    assert png == tmp_path / "blur.png" and png.stat().st_size > 0
    with open(tmp_path / "blur.csv") as handle:
        table = list(csv.DictReader(handle))
    assert {round(float(r["depth_m"]), 3) for r in table} == {0.5, 2.0}
    for r in table:
        z, z_f, f = float(r["depth_m"]), float(r["lens.focus_distance_m"]), 0.025
        predicted = (f / 8.0) * f * abs(z - z_f) / (z * (z_f - f)) / 6e-6
        assert float(r["predicted_coc_px"]) == pytest.approx(predicted, rel=1e-4)
    assert (point_sweep / "blur_vs_depth.csv").read_text() == (tmp_path / "blur.csv").read_text()
    assert pyplot_before or "matplotlib.pyplot" not in sys.modules


def test_contact_sheet_is_redrawn_from_the_folder(point_sweep, tmp_path):
    import cv2

    column = write_contact_sheet(point_sweep, tmp_path / "column.png", columns=1)
    row = write_contact_sheet(point_sweep, tmp_path / "row.png", columns=2)
    assert (column, row) == (tmp_path / "column.png", tmp_path / "row.png")
    (column_h, column_w), (row_h, row_w) = (cv2.imread(str(p)).shape[:2] for p in (column, row))
    assert row_w == pytest.approx(2 * column_w, abs=2) and column_h == pytest.approx(2 * row_h, abs=2)
    assert write_contact_sheet(tmp_path) is None  # no items, no sheet


def test_unmeasured_depths_keep_their_reason_in_the_csv_and_a_mark_on_the_chart(tmp_path):
    """Issue 12 #5: depths without a usable region vanished from the CSV and the chart."""
    import json

    from spectral_cam.records import write_json
    from spectral_cam.scene import scene_from_dict

    config = scene_from_dict({"scene": {"preset": "dof_targets"}, "lens": {"f_number": 2.0}})
    blur = [{"depth_m": 1.0, "predicted_coc_px": 3.0, "measured_coc_px": None, "pixels": 0,
             "note": "no pixels 9.1 px inside the plane"},
            {"depth_m": 2.0, "predicted_coc_px": 0.0, "measured_coc_px": 0.1, "pixels": 40, "note": None}]
    item = tmp_path / "items" / "000000"
    item.mkdir(parents=True)
    write_json({"config": config.to_dict(), "blur": blur}, item / "meta.json")
    (tmp_path / "manifest.jsonl").write_text(json.dumps({"id": "000000", "status": "done", "path": "items/000000",
                                                         "params": {"lens.f_number": 2.0}}) + "\n")
    write_json({"spec": {"sweeps": [{"key": "lens.f_number", "values": [2.0]}]}}, tmp_path / "dataset.json")
    png = write_blur_chart(tmp_path)
    assert png.is_file()
    with open(tmp_path / "blur_vs_depth.csv") as handle:
        table = list(csv.DictReader(handle))
    assert [(r["depth_m"], r["measured_coc_px"], r["note"]) for r in table] == [
        ("1.0", "", "no pixels 9.1 px inside the plane"), ("2.0", "0.1", "")]


def test_contact_sheet_labels_show_only_what_applies_to_each_item():
    """Issue 25 #20: a dead_leaves tile was labelled with the sun's hour, which does not light it."""
    from spectral_cam.apps.dataset.sheets import _label

    keys = ["scene.preset", "sky.hour", "scene.object_count", "lens.f_number"]
    params = {"scene.preset": "dead_leaves", "sky.hour": 9.7, "scene.object_count": 5, "lens.f_number": 2.0}
    assert _label(params, keys) == "preset=dead_leaves\nf_number=2"
    params["scene.preset"] = "tabletop"
    assert _label(params, keys) == "preset=tabletop\nhour=9.7\nobject_count=5\nf_number=2"
    params["scene.light"] = "illuminant"  # a lamp, not the sun
    assert "hour" not in _label(params, keys)
