"""The ISP benchmark end to end (issue 39 #1): it runs every demosaic method that takes the
bench's Bayer mosaic, and only those, and writes its CSV and charts."""

from __future__ import annotations

import csv

import pytest

from spectral_cam.apps.bench import run_benchmarks


@pytest.mark.timeout(300)
def test_quick_isp_benchmark_runs_the_methods_that_take_its_bayer_mosaic(tmp_path):
    rows = run_benchmarks(tmp_path, quick=True, only=["isp"], log=lambda _: None)["isp"]
    demosaic = {r["method"]: r for r in rows if r["stage"] == "demosaic"}
    # the bench's chart is an RGGB Bayer mosaic: the Quad Bayer and RGBW methods cannot read it
    assert not {"quad_remosaic", "quad_binning", "rgbw_fusion"} & set(demosaic)
    assert {"bilinear", "malvar2004", "menon2007", "rcd", "vng", "ea", "colour_difference"} <= set(demosaic)
    # on a noise-free chart every method recovers the flat patches well (ΔE2000 of a few units at most), and
    # the edge-directed interpolator keeps more detail than the bilinear mean (Menon et al. 2007, table I)
    assert all(r["delta_e2000"] < 5.0 for r in demosaic.values())
    assert demosaic["menon2007"]["psnr_db"] > demosaic["bilinear"]["psnr_db"]
    with open(tmp_path / "isp.csv") as handle:
        assert len(list(csv.DictReader(handle))) == len(rows)
    for chart in ("demosaic.png", "denoise.png"):
        assert (tmp_path / chart).stat().st_size > 10_000
