"""Frames too large for memory are refused with an estimate before Mitsuba starts."""

from __future__ import annotations

import pytest

from spectral_cam import render, scene_from_dict


@pytest.mark.timeout(60)
def test_a_frame_too_large_for_memory_is_refused_before_mitsuba_starts():
    """Issue 12 #12: 20000 × 20000 px passed validation and segfaulted in Mitsuba."""
    from spectral_cam.errors import ConfigError
    from spectral_cam.render.memory import available_bytes, estimate_render_bytes

    config = scene_from_dict({"sensor": {"width_px": 20000, "height_px": 20000}})
    assert estimate_render_bytes(20000, 20000) > available_bytes()  # 600 GB on any machine here
    with pytest.raises(ConfigError, match=r"needs about \d+\.\d GB of memory .* lower sensor.width_px"):
        render(config)
