"""The validation report (spectral_cam.apps.validate.report) in a browser: headless Chromium
(DevTools protocol over --remote-debugging-pipe) loads it with every image decoded and no
console errors."""

from __future__ import annotations

import pytest


@pytest.mark.timeout(120)
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
