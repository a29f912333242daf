"""The lens study's chart (issue 39 #20): cat's-eye vignetting panels on one scale from zero."""

from __future__ import annotations

import pytest

from spectral_cam.apps.stress import lenses
from spectral_cam.apps.stress.summary import summary_row


@pytest.fixture
def drawn(monkeypatch, tmp_path):
    """Figures plot_lenses would save, kept open for their axes."""
    figures = []

    def keep(fig, path, **_):
        figures.append(fig)
        return path

    monkeypatch.setattr(lenses, "save_png", keep)
    return figures


def test_vignetting_panels_start_at_zero_so_a_tenth_of_a_percent_looks_like_one(drawn, tmp_path):
    """A telephoto whose pupil changes by 0.3 % and a double Gauss that loses 77 %: each right panel
    spans 0 to at least 1.05 (auto-scaling drew 0.997–1.002 as the full panel height)."""
    data = {"telephoto": {"f_numbers": [5.6, 8.0], "fields_deg": [0.0, 4.9], "spot_px": [[3.6, 4.1], [2.5, 3.5]],
                          "pupil": [[1.0, 0.997], [1.0, 1.002]]},
            "dgauss": {"f_numbers": [2.0], "fields_deg": [0.0, 23.2], "spot_px": [[4.5, 15.0]], "pupil": [[1.0, 0.23]]}}
    result = {"data": data, "rows": [summary_row("lenses", "telephoto", "x", 1.0, "")]}
    lenses.plot_lenses(result, tmp_path)
    (fig,) = drawn
    right = [ax for ax in fig.axes if ax.get_ylabel() == "pupil area / axial"]
    assert len(right) == 2
    for ax in right:
        low, high = ax.get_ylim()
        assert low == 0.0 and 1.05 <= high < 1.2
