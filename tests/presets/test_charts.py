"""The flat-field preset stays flat under any defocus (issue 12 #9): its target covers the
field plus the blur reach A·|z − z_f|/(2·z_f) of the thin lens (the object-space footprint of
a pixel's cone through the aperture, PBRT 4th ed. §5.2.3)."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam import render

pytestmark = pytest.mark.timeout(120)


def test_a_strongly_defocused_flat_field_is_flat(make_scene):
    # 50 mm f/4 focused at 2 m, the target at 1 m: a 70-px blur on a 48 × 32 frame
    config = make_scene(scene={"preset": "flat_field", "distance_m": 1.0},
                        lens={"focal_length_mm": 50.0, "f_number": 4.0, "focus_distance_m": 2.0, "model": "thin"},
                        sensor={"width_px": 48, "height_px": 32, "vignetting": False},
                        render={"spp": 256, "diffraction": "off"})
    image = render(config, with_depth=False).data.sum(axis=-1)
    centre, corners = image[12:20, 20:28].mean(), np.mean([image[:6, :6], image[-6:, -6:]])
    assert centre == pytest.approx(corners, rel=0.01)
    assert image.std() / image.mean() < 0.05  # only Monte-Carlo noise left
