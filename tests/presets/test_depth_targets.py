"""The depth-of-field preset's layout depends on the depths alone (issue 12 #1): the planes
read 2 / 1 / 4 m left to right whatever the focus, lens or sensor, measured on the rendered
camera-space depth map."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam import render

pytestmark = pytest.mark.timeout(120)


@pytest.mark.parametrize("focus_m", [0.5, 2.0, 3.3, 4.0])
@pytest.mark.parametrize("focal_mm", [8.0, 25.0])
def test_dof_planes_keep_their_places_when_only_the_focus_changes(make_scene, focus_m, focal_mm):
    config = make_scene(scene={"preset": "dof_targets", "depths_m": [1.0, 2.0, 4.0]},
                        lens={"focal_length_mm": focal_mm, "focus_distance_m": focus_m, "model": "pinhole"},
                        sensor={"width_px": 48, "height_px": 16}, render={"spp": 1})
    depth = render(config, with_depth=True).depth_m
    row = depth[8]
    thirds = [np.median(row[k * 16:(k + 1) * 16][4:12]) for k in range(3)]
    assert thirds == pytest.approx([2.0, 1.0, 4.0], rel=1e-3)
