"""The report's ΔE-against-CCT chart (issue 39 #20): an errored pipeline is not in the legend, and
the CCT axis reads in plain kelvin."""

from __future__ import annotations

import math

from spectral_cam.apps.validate.report import cct_figure


def test_cct_chart_leaves_out_pipelines_without_a_score_and_ticks_in_plain_kelvin():
    ccts = [2856.0, 4230.0, 6504.0]  # A, F2-like, D65 (Robertson 1968)
    means = {"ours": [1.2, 1.0, 0.9], "rawpy": [2.0, 1.8, 1.5], "darktable": [math.nan] * 3}
    fig, missing = cct_figure(ccts, means)
    (ax,) = fig.axes
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["ours", "rawpy"]
    assert missing == ["darktable"]
    fig.canvas.draw()
    major = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
    assert major == ["2856", "4230", "6504"]
    assert not [t.get_text() for t in ax.get_xticklabels(minor=True) if t.get_text()]  # no "3×10³"
