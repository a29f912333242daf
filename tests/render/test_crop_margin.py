"""Rendering the sensor's crop margin (issue 13 #3): the frame sees the same scene, laid out for
the frame, with a ring of real pixels around it; the job's RAW carries the ring, every other
output is the frame."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam import render
from spectral_cam.job import simulate

from .test_radiometry import LUX, patch_band_errors

pytestmark = pytest.mark.timeout(300)


def test_the_frame_inside_a_margin_still_obeys_lamberts_law(make_scene):
    """The pinhole ColorChecker that fills the frame exactly (as in test_radiometry), rendered
    with a 2-pixel margin: the frame's patches keep their radiance ρ·E/π (the preset is laid
    out for the frame, not for the larger capture area), and the margin sees past the chart.
    2^18 spp per pixel: σ ≈ 0.5 % per band, so 3 % is ~6σ."""
    config = make_scene(
        scene={"preset": "colorchecker", "fill": 1.0, "gap": 0.0, "distance_m": 2.0},
        illuminant={"spd": "D65", "illuminance_lux": LUX},
        lens={"model": "pinhole"},
        sensor={"width_px": 6, "height_px": 4, "pixel_pitch_um": 500.0, "crop_margin_px": 2},
        render={"spp": 1 << 18, "max_depth": 2},
    )
    captured = render(config, with_depth=False, with_margin=True)
    assert captured.data.shape[:2] == (8, 10) and captured.frame_window == (2, 2, 4, 6)
    image = captured.framed()
    assert image.data.shape[:2] == (4, 6) and image.frame_window is None
    for name, relative in patch_band_errors(image, config):
        assert np.all(np.abs(relative) < 0.03), f"{name}: band errors {np.round(relative * 100, 2)} %"
    ring = np.ones(captured.data.shape[:2], bool)
    ring[2:-2, 2:-2] = False
    assert not np.allclose(captured.data[ring].mean(axis=0), image.data.mean(axis=(0, 1)), rtol=0.05)


@pytest.mark.parametrize("lens_model", ["thin", "layered"])
def test_the_job_raw_carries_the_margin_and_every_other_output_is_the_frame(make_scene, lens_model):
    config = make_scene(scene={"preset": "colorchecker"}, lens={"model": lens_model, "f_number": 4.0},
                        sensor={"crop_margin_px": 6})
    sim = simulate(config)
    height, width = config.sensor.height_px, config.sensor.width_px
    assert sim.raw.mosaic.shape == (height + 12, width + 12) and sim.raw.crop == (6, 6, height, width)
    assert sim.radiance.data.shape[:2] == (height, width) and sim.radiance.depth_m.shape == (height, width)
    assert sim.developed.image.shape == (height, width, 3)
    assert sim.lens.width_px == width  # the frame's lens, as every label and metric expects


def test_meta_optics_describe_the_frame_and_the_margin_apart():
    """Issue 25 #5: with a crop margin, ``meta.optics.fov_x_deg`` read the widened film's field
    (112 px for a 96 px frame: 16.7 % too wide); it is the frame's, 2·atan(w·p/(2v))."""
    import math

    import spectral_cam as sc

    config = sc.scene_from_dict({"sensor": {"width_px": 96, "height_px": 64}, "render": {"spp": 1}})
    optics = sc.render(config, with_margin=True, with_depth=False).meta["optics"]
    lens = sc.optics.ThinLens.from_config(config.lens, config.sensor)
    expected = math.degrees(2 * math.atan(96 * 6e-6 / (2 * lens.image_distance_m)))
    assert optics["fov_x_deg"] == pytest.approx(expected, rel=1e-9)
    assert optics["rendered_margin_px"] == config.sensor.crop_margin_px
    assert optics["rendered_size_px"] == [96 + 2 * config.sensor.crop_margin_px, 64 + 2 * config.sensor.crop_margin_px]
