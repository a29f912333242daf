"""Issue 39 #10: a smaller frame kept the pitch and shrank the sensor (a 128 × 96 dataset frame saw
5.5° with |CoC| ≤ 1.7 px, unsaid). ``sensor.keep_field_of_view = true`` spreads the pixels over the
named camera's published sensor (the widest frame of their aspect ratio on it): the field of view
is then the analytic 2·atan(size/2v) of that size; the dry run says the view and the circle of
confusion in pixels over the depth probe's depths."""

from __future__ import annotations

import math
import re

import pytest

from spectral_cam import spectra
from spectral_cam.optics import ThinLens
from spectral_cam.scene import scene_from_dict

D850_W, D850_H = 35.9, 23.9  # mm, Nikon's specification (the camera table's source)


def _lens(width, height, *, keep=True, focus_m=1e6, focal_mm=50.0):
    config = scene_from_dict({"sensor": {"model": "nikon_d850", "keep_field_of_view": keep, "width_px": width,
                                         "height_px": height},
                              "lens": {"focal_length_mm": focal_mm, "focus_distance_m": focus_m}})
    return config, ThinLens.from_config(config.lens, config.sensor)


def _fov_deg(size_mm, focal_mm):
    return math.degrees(2.0 * math.atan(size_mm / (2.0 * focal_mm)))


@pytest.mark.parametrize("width, height", [(128, 96), (96, 64), (64, 64), (8256, 5504)])
def test_the_field_of_view_is_the_cameras_at_any_frame_size(width, height):
    """Focused far, the D850's 35.9 × 23.9 mm behind 50 mm sees 2·atan(35.9/100) = 39.3° across:
    a 3:2 frame of any size sees it within 0.1° (the sensor is 1.502:1, so its height binds:
    35.85 mm, 39.45°); a 4:3 or square frame is the widest of its shape
    on the sensor (its full height, 26.9° tall) and as wide as its pixels at that pitch."""
    _, lens = _lens(width, height)
    pitch_mm = min(D850_W / width, D850_H / height)
    assert lens.fov_x_deg == pytest.approx(_fov_deg(width * pitch_mm, 50.0), abs=0.01)
    assert lens.fov_y_deg == pytest.approx(_fov_deg(height * pitch_mm, 50.0), abs=0.01)
    if width * 2 == height * 3 or (width, height) == (8256, 5504):
        assert lens.fov_x_deg == pytest.approx(_fov_deg(D850_W, 50.0), abs=0.1)
    else:
        assert lens.fov_y_deg == pytest.approx(_fov_deg(D850_H, 50.0), abs=0.01)


def test_without_the_key_a_named_camera_keeps_its_pitch_and_the_frame_is_a_crop():
    """The camera's 4.348 µm pixels: 128 px are 0.557 mm, a 0.64° view behind 50 mm (what the
    dataset got, now said in the dry run); with the key the record names the derived pitch."""
    config, lens = _lens(128, 96, keep=False)
    assert config.sensor.pixel_pitch_um == spectra.camera_figures("nikon_d850")["pixel_pitch_um"].value
    assert lens.fov_x_deg == pytest.approx(_fov_deg(128 * 4.348e-3, 50.0), abs=0.01)
    kept, _ = _lens(128, 96)
    assert spectra.figure_record(kept.sensor)["pixel_pitch_um"]["from"].startswith("keep_field_of_view")
    # a copy with another frame size derives the pitch again (it is not the first frame's)
    smaller = kept.replace(**{"sensor.width_px": 64, "sensor.height_px": 48})
    assert smaller.sensor.pixel_pitch_um == pytest.approx(D850_H / 48 * 1e3)


@pytest.mark.timeout(200)
def test_the_dry_run_says_the_view_and_the_circle_of_confusion_in_pixels():
    """dof_targets at 1, 2, 4 m through 50 mm f/2.8 focused at 2 m on the whole D850 at 48 × 32 px:
    the dry run prints the view and the CoC range, the largest at 1 m: A·f·|z − z_f|/(z·(z_f − f))
    over the pitch (Ray, Applied Photographic Optics ch. 10) = 0.613 px, the smallest 0 (in focus)."""
    from spectral_cam.render.plan import make_plan

    config = scene_from_dict({"scene": {"preset": "dof_targets", "depths_m": [1.0, 2.0, 4.0]},
                              "sensor": {"model": "nikon_d850", "keep_field_of_view": True, "width_px": 48,
                                         "height_px": 32},
                              "lens": {"focal_length_mm": 50.0, "f_number": 2.8, "focus_distance_m": 2.0},
                              "render": {"spp": 4}})
    text = make_plan(config, measure=False).summary()
    line = next(line for line in text.splitlines() if line.startswith("view:"))
    fov = re.search(r"view: ([\d.]+)° × ([\d.]+)°", line)
    assert float(fov.group(1)) == pytest.approx(_fov_deg(D850_W, 50.0 * 2.0 / 1.95), abs=0.1)
    low, high = map(float, re.search(r"circle of confusion ([\d.e-]+)–([\d.e-]+) px", line).groups())
    f, n, zf, z = 50e-3, 2.8, 2.0, 1.0
    analytic = (f / n) * f * abs(z - zf) / (z * (zf - f)) / (D850_W / 48 * 1e-3)
    assert high == pytest.approx(analytic, rel=0.01) and low < 0.01
