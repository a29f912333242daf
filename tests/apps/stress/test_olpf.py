"""Study (g): false colour against the optical low-pass filter's strength. On a neutral zone plate
every colour is false; the filter must take it off for every demosaic, and the modulation it keeps
must follow the analytic pixel-aperture × filter response."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.apps.stress.olpf import STUDY_SEPARATIONS, olpf_study, plot_olpf

pytestmark = pytest.mark.timeout(120)


def test_the_filter_takes_off_false_colour_for_every_demosaic_and_costs_what_the_optics_say(tiny, tmp_path):
    """A 1-pitch filter cuts false colour by more than half for every registered demosaic (measured
    bilinear 1.28 → 0.43 of the mean level, menon2007 0.21 → 0.04). The modulation a 1-pitch filter
    keeps at 0.25 cycle/px, relative to none, is the analytic cos(π f d) ratio within 0.05 for
    menon2007 (measured 0.712 vs 0.715): the demosaic's own loss divides out."""
    result = olpf_study(tiny, methods=None)
    data = result["data"]
    one, none = STUDY_SEPARATIONS.index(1.0), STUDY_SEPARATIONS.index(0.0)
    for name, entry in data["methods"].items():
        assert entry["false_colour"][one] < 0.5 * entry["false_colour"][none], name
    kept = data["methods"]["menon2007"]["modulation_kept"]
    analytic = data["analytic_modulation_kept"]
    assert kept[one] / kept[none] == pytest.approx(analytic[one] / analytic[none], abs=0.05)
    files = plot_olpf(result, tmp_path)
    assert all((tmp_path / name).stat().st_size > 10_000 for name in files)
    assert np.isfinite([row["value"] for row in result["rows"]]).all()
