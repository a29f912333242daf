"""The validation report (spectral_cam.apps.validate.report) in a browser: headless Chromium
(DevTools protocol over --remote-debugging-pipe) loads it with every image decoded and no
console errors."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.apps.validate import plan_from_dict, run_plan
from tests.apps.validate.conftest import EXAMPLE_TIMEOUT_S


@pytest.mark.timeout(EXAMPLE_TIMEOUT_S)
def test_headless_chromium_loads_the_report_without_console_errors(example, chromium, tmp_path):
    # the probe sees errors where there are some...
    broken = tmp_path / "broken.html"
    broken.write_text("<!DOCTYPE html><title>x</title><img src='missing.png'><script>console.error('boom')</script>")
    _, errors = chromium(broken.as_uri())
    assert len(errors) >= 2, errors
    # ...and none in the report, whose every image decodes
    result, out, _ = example
    page, errors = chromium((out / "report.html").as_uri())
    assert errors == []
    assert page["title"].startswith("spectral_cam colour validation")
    heatmaps = len(result.plan.reflectance_sets) * len(result.plan.exposures)
    assert len(page["images"]) == 1 + heatmaps + len(result.cells)  # the ΔE CDF; swatches = "all"
    assert all(complete and width > 100 and height > 50 for complete, width, height in page["images"])
    html = (out / "report.html").read_text()
    assert "<script" not in html and 'src="http' not in html  # self-contained, nothing fetched


@pytest.fixture(scope="module")
def one_seed_report(tmp_path_factory):
    """A one-seed report of two pipelines on the ColorChecker (D65, D850): ours, and ours without
    its colour matrix, compared."""
    ours = {"name": "ours", "type": "ours", "isp": {"tone": "linear", "demosaic": "bilinear"}}
    no_matrix = {"name": "no-matrix", "type": "ours", "isp": {**ours["isp"], "colour_matrix": "none"}}
    plan = plan_from_dict({"validate": {"illuminants": ["D65"], "cameras": ["nikon_d850"], "patch_px": 8,
                                        "gap_px": 2, "reflectance_sets": ["colorchecker"], "swatches": "none",
                                        "seeds": 1, "compare": [["no-matrix", "ours"]]},
                           "pipeline": [ours, no_matrix]})
    out = tmp_path_factory.mktemp("one_seed") / "report"
    return run_plan(plan, out), out


@pytest.mark.timeout(120)
def test_patches_csv_splits_each_difference_into_lightness_chroma_and_hue(one_seed_report, read_csv):
    """Issue 39 #5: delta_l, delta_c and delta_h of every row are CIE 15's ΔL*, ΔC*ab and ΔH*ab
    recomputed from the row's two linear sRGB colours with colour-science (|ΔH| =
    √(ΔE*ab² − ΔL*² − ΔC*²), CIE 15:2004 §8.2.1)."""
    import colour

    _, out = one_seed_report
    rows = read_csv(out / "patches.csv")
    assert rows
    space = colour.RGB_COLOURSPACES["sRGB"]

    def lab(row, which):
        rgb = np.array([float(row[f"{which}_{c}"]) for c in "rgb"])
        return colour.XYZ_to_Lab(colour.RGB_to_XYZ(rgb, space, apply_cctf_decoding=False), space.whitepoint)

    for row in rows:
        reference, test = lab(row, "reference"), lab(row, "test")
        delta_l = test[0] - reference[0]
        delta_c = np.hypot(*test[1:]) - np.hypot(*reference[1:])
        delta_e = colour.delta_E(test, reference, method="CIE 1976")
        delta_h = np.sqrt(max(delta_e ** 2 - delta_l ** 2 - delta_c ** 2, 0.0))
        assert float(row["delta_l"]) == pytest.approx(delta_l, abs=1e-6)
        assert float(row["delta_c"]) == pytest.approx(delta_c, abs=1e-6), row
        assert abs(float(row["delta_h"])) == pytest.approx(delta_h, abs=1e-5), row


@pytest.mark.timeout(120)
def test_one_seed_calls_no_difference_significant_or_not(one_seed_report, read_csv):
    """Issue 39 #6: with one noise seed a Student's t interval has no degrees of freedom (SciPy's
    t quantile at 0 d.f. is NaN), so a difference (here several ΔE: no colour matrix against ours)
    is neither significant nor "n.s.": comparisons.csv and the report say there is no interval."""
    from scipy import stats

    assert np.isnan(stats.t.ppf(0.975, 0))  # one seed: no interval exists
    result, out = one_seed_report
    (row,) = read_csv(out / "comparisons.csv")
    assert float(row["difference"]) > 1.0 and row["ci95"] == "" and row["seeds"] == "1"
    assert row["significant"] == "no interval (1 seed)"
    page = (out / "report.html").read_text(encoding="utf-8")
    comparisons = page[page.index("<h2>Comparisons</h2>"):]
    comparisons = comparisons[:comparisons.index("</table>")]
    assert "n.s." not in comparisons.split("</p>", 1)[1] and "no interval (1 seed)" in comparisons


@pytest.mark.timeout(120)
def test_the_report_and_cells_csv_name_the_colorchecker_data_the_truth_is_computed_from(one_seed_report, read_csv):
    """Issue 39 #7: the scores depend on which measurement of the chart is the truth. cells.csv
    and the report name it (BabelColor average, from colour-science), and it is the data used:
    patches.csv's truth under D65 is colour-science's XYZ → sRGB of SDS_COLOURCHECKERS["BabelColor
    Average"] (1-nm CIE 1931 2°, Y of the perfect diffuser 1), not of ISO 17321-1's spectra of the
    same chart, which differ by several ΔE2000 on some patches."""
    import colour

    _, out = one_seed_report
    cells = read_csv(out / "cells.csv")
    assert all("BabelColor average" in row["reference_data"] and "SDS_COLOURCHECKERS['BabelColor Average']"
               in row["reference_data"] for row in cells)
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "Reference data" in page and "SDS_COLOURCHECKERS[&#x27;BabelColor Average&#x27;]" in page
    rows = [r for r in read_csv(out / "patches.csv") if r["pipeline"] == "ours"]
    measured = np.array([[float(r[f"reference_{c}"]) for c in "rgb"] for r in rows])

    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    d65 = colour.SDS_ILLUMINANTS["D65"]
    space = colour.RGB_COLOURSPACES["sRGB"]

    def truth(data):
        grid = colour.SpectralShape(380, 780, 1)  # the 10-nm data on a 1-nm grid, linearly (Sprague moves 0.17)
        xyz = np.array([colour.sd_to_XYZ(sd.copy().interpolate(grid, interpolator=colour.LinearInterpolator),
                                         cmfs, d65) / 100 for sd in colour.SDS_COLOURCHECKERS[data].values()])
        return colour.XYZ_to_RGB(xyz, space, apply_cctf_encoding=False)

    def worst_delta_e(a, b):
        lab = [colour.XYZ_to_Lab(colour.RGB_to_XYZ(x, space, apply_cctf_decoding=False), space.whitepoint)
               for x in (a, b)]
        return float(np.max(colour.delta_E(*lab, method="CIE 2000")))

    assert worst_delta_e(measured, truth("BabelColor Average")) < 0.03  # measured 0.013
    assert worst_delta_e(measured, truth("ISO 17321-1")) > 1.5  # measured 1.96


@pytest.mark.timeout(120)
def test_the_report_puts_the_pivot_first_and_the_long_per_cell_table_below(one_seed_report):
    """Issue 39 #21: the answer (pivot, comparisons) comes before the method and the per-cell table."""
    _, out = one_seed_report
    page = (out / "report.html").read_text(encoding="utf-8")
    order = [page.index(heading) for heading in ("<h2>Pivot", "<h2>Comparisons", "<h2>Method", "<h2>Summary")]
    assert order == sorted(order)
