"""Issue 39 #29: under a rolling shutter the sub-frame count follows the readout. Each row's window T
holds K·T/S sub-frame widths of the span S = T + (H − 1)·t_row; "auto" gives at least 4 there, so
K ≥ ⌈4·S/T⌉ (analytic), rounded to a divisor of spp, or the capture is refused with that number (it was
capped at spp: 4 sub-frames over a 0.31 s span rendered the skew as 4 blocks while meta.json said "at
least 4 in each row's window"); the record states K·T/S as it is."""

from __future__ import annotations

import math
import re

import pytest

import spectral_cam as sc
from spectral_cam.errors import ConfigError
from spectral_cam.optics import ThinLens
from spectral_cam.render.motion import plan_subframes

pytestmark = pytest.mark.timeout(60)


def _plan(row_time_s, exposure_s, spp, *, rows=32, **motion):
    config = sc.scene_from_dict({"sensor": {"width_px": 48, "height_px": rows, "shutter": "rolling",
                                            "row_time_s": row_time_s},
                                 "exposure": {"time_s": exposure_s}, "render": {"spp": spp},
                                 "motion": {"camera_velocity_mps": [0.5, 0.0, 0.0], **motion}})
    return plan_subframes(config, ThinLens.from_config(config.lens, config.sensor), None, spp)


def _span(row_time_s, exposure_s, rows=32):
    return exposure_s + (rows - 1) * row_time_s


def test_a_readout_longer_than_spp_can_cover_is_refused_with_the_count_it_needs():
    """The issue's case, 10 ms a row and a 10 µs exposure over 32 rows at 4 spp: ⌈4·S/T⌉ = 124 004 sub-frames
    would be needed; refused, naming the span and the count (no render.spp can give it beyond 4096). 1 ms a
    row at 1 ms and 16 spp: 128 needed, refused with render.spp ≥ 128."""
    needed = math.ceil(4 * _span(0.01, 1e-5) / 1e-5)
    with pytest.raises(ConfigError, match=rf"need {needed} over the span.*render\.spp = 4") as refused:
        _plan(0.01, 1e-5, 4)
    assert "render.spp ≥" not in str(refused.value)
    needed = math.ceil(4 * _span(1e-3, 1e-3) / 1e-3)
    assert needed == 128
    with pytest.raises(ConfigError, match=rf"render\.spp ≥ {needed}"):
        _plan(1e-3, 1e-3, 16)


@pytest.mark.parametrize(("row_time_s", "exposure_s", "spp"), [(1e-3, 1e-3, 128), (1e-4, 1e-3, 256), (3e-4, 2e-3, 96)])
def test_auto_puts_at_least_four_sub_frames_in_each_rows_window_and_says_how_many(row_time_s, exposure_s, spp):
    """K divides spp, K·T/S ≥ 4 (the analytic span), and the record's number is K·T/S."""
    count, record = _plan(row_time_s, exposure_s, spp)
    in_window = count * exposure_s / _span(row_time_s, exposure_s)
    assert spp % count == 0 and in_window >= 4 - 1e-9
    assert record["subframes_per_row_window"] == pytest.approx(in_window)
    stated = float(re.search(r"([\d.]+) in each row's", record["reason"]).group(1))
    assert stated == pytest.approx(in_window, rel=5e-3)


def test_a_given_sub_frame_count_is_kept_and_recorded_as_it_is():
    """motion.subframes = 8 over a 32 ms span with a 1 ms window: 0.25 in each row's window, said so (no
    "at least")."""
    count, record = _plan(1e-3, 1e-3, 16, subframes=8)
    assert count == 8
    assert record["subframes_per_row_window"] == pytest.approx(8 * 1e-3 / _span(1e-3, 1e-3))
    assert "0.25 in each row's" in record["reason"] and "at least" not in record["reason"]
