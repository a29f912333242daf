"""Study (h): rolling shutter and flicker. The band amplitudes measured through the sensor follow the
analytic mean of each waveform over a row's window; exposures of whole flicker periods show none;
the rendered skew follows v·t_row·H·m/p."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.apps.stress.rolling import plot_rolling, rolling_study

pytestmark = pytest.mark.timeout(240)


def test_bands_follow_the_analytic_window_mean_and_vanish_at_whole_periods(tiny, tmp_path):
    """Band amplitude within 0.02 (of the mean) of the analytic peak-to-peak of the window mean (an
    independent dense evaluation of the closed form over one period of phases) at every exposure time,
    for mains and PWM; below 0.005 at 10 and 20 ms (whole periods of both lights); the skew within 8 %
    of v·t_row·H·m/p at every speed (32-row renders, 128 spp: the edge's noise)."""
    result = rolling_study(tiny.replace(flicker_exposures=9, skew_px=32))
    data = result["data"]
    exposures = data["exposures_s"]
    for name, entry in data["flicker"].items():
        np.testing.assert_allclose(entry["banding"], entry["analytic"], atol=0.02, err_msg=name)
        for whole in (1e-2, 2e-2):
            assert entry["banding"][exposures.index(whole)] < 0.005, (name, whole)
    for speed, entry in data["skew"].items():
        assert entry["measured_px"] == pytest.approx(entry["predicted_px"], rel=0.08), speed
    files = plot_rolling(result, tmp_path)
    assert all((tmp_path / name).stat().st_size > 10_000 for name in files)
