"""The sampling benchmarks: a quick ``bands`` run writing its CSV and charts."""

from __future__ import annotations

import csv

import pytest

from spectral_cam.apps.bench import run_benchmarks


@pytest.mark.timeout(300)
def test_quick_bands_benchmark_writes_csv_and_charts(tmp_path):
    rows = run_benchmarks(tmp_path, quick=True, only=["bands"], log=lambda _: None)["bands"]
    assert (tmp_path / "bands.png").stat().st_size > 10_000
    assert (tmp_path / "bands_bias.png").exists()
    with open(tmp_path / "bands.csv") as handle:
        assert len(list(csv.DictReader(handle))) == len(rows) == 8
    by = {(r["illuminant"], r["bands"]): r for r in rows}
    # against the 1-nm integration the camera film has no discretisation bias beyond noise,
    # while 8 bands of 40 nm miss the camera curves' shape by several per cent
    assert by[("D65", "camera")]["bias_max_abs_pct"] < 1.0
    assert by[("D65", "8 bands")]["bias_max_abs_pct"] > 3 * by[("D65", "31 bands")]["bias_max_abs_pct"]
    assert by[("D65", "31 bands")]["time_ratio"] == 1.0
    # a second run into the same folder is refused without force (issue 12 #8), kept files stay
    (tmp_path / "notes.txt").write_text("mine")
    from spectral_cam.errors import ConfigError

    with pytest.raises(ConfigError, match=r"earlier run \(bands.csv\); pass --force"):
        run_benchmarks(tmp_path, quick=True, only=["bands"], log=lambda _: None)
    assert (tmp_path / "notes.txt").read_text() == "mine"
