"""Issue 29 #3: pixel angular response and shading. A flat field's corner-to-centre ratio per channel
follows the cos⁴ law times the stated acceptance 2^(−(θ/θ½)²) at the chief-ray angle (analytic,
from the geometry alone) within 1 %; a flat-field calibration makes it flat within 1 % in every
channel and takes the corners' tint off; bad settings are refused with what would be valid."""

from __future__ import annotations

import math

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.errors import ConfigError
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.isp.shading import calibrate_flat_field, load_shading_table
from spectral_cam.radiance_targets import lambertian_radiance, uniform_image

pytestmark = pytest.mark.timeout(120)

QUIET = {"shot_noise": False, "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0,
         "bit_depth": 16}
HALVES = (18.0, 22.0, 26.0)  # θ½ of R, G, B: red spreads most into the neighbours


def _flat(width=96, height=64, focal_mm=0.8, **sensor):
    """A noise-free RGGB flat field of a grey D65 reflector behind a wide thin lens (6-µm pixels:
    the corner's chief ray arrives at atan(r/v) ≈ 27°)."""
    scene = sc.scene_from_dict({"sensor": {"width_px": width, "height_px": height, "crop_margin_px": 0,
                                           **QUIET, **sensor},
                                "lens": {"focal_length_mm": focal_mm, "focus_distance_m": 1e6},
                                "exposure": {"time_s": 0.004}})
    radiance = uniform_image(lambertian_radiance("D65", [0.5])[0], (height, width))
    return scene, sc.expose(radiance, scene)


def _channel_at(raw, row, col):
    return float(raw.mosaic[row, col]) - float(np.mean(raw.black_level))


def test_corner_over_centre_is_cos4_times_the_stated_acceptance_per_channel():
    """Each channel's corner pixel over the same channel near the centre equals
    cos⁴θ·A_c(θ)/(cos⁴θ₀·A_c(θ₀)) with θ = atan(r/v) of both pixel centres, v the thin lens's
    image distance (1/v = 1/f − 1/s): within 1 %."""
    scene, raw = _flat(angular_response_deg=list(HALVES))
    h, w = raw.mosaic.shape
    f, s = 0.8e-3, 1e6
    v = 1.0 / (1.0 / f - 1.0 / s)
    pitch = scene.sensor.pixel_pitch_um * 1e-6

    def theta(row, col):
        return math.atan(math.hypot(col + 0.5 - w / 2, row + 0.5 - h / 2) * pitch / v)

    for (row, col), half in (((0, 0), HALVES[0]), ((0, 1), HALVES[1]), ((1, 1), HALVES[2])):  # RGGB: R, G, B
        centre = (h // 2 + row, w // 2 + col)
        measured = _channel_at(raw, row, col) / _channel_at(raw, *centre)
        t0, t1 = theta(row, col), theta(*centre)
        expected = (math.cos(t0) ** 4 * 2 ** -(math.degrees(t0) / half) ** 2) / (
            math.cos(t1) ** 4 * 2 ** -(math.degrees(t1) / half) ** 2)
        assert measured == pytest.approx(expected, rel=0.01), (half, measured, expected)
    assert math.degrees(theta(0, 0)) > 20  # a real corner angle, where the channels part


def test_a_flat_field_calibration_makes_the_flat_flat_and_neutral(tmp_path):
    """Calibrated on one flat field (a degree-8 surface per channel), a second flat field of another level develops flat
    within 1 % in every channel, and its corner's tint (R/G falling 30 % without correction) is gone;
    the table survives a round trip through its JSON file."""
    _, calibration = _flat(angular_response_deg=list(HALVES))
    table = calibrate_flat_field(calibration)
    path = table.save(tmp_path / "shading.json")
    scene, raw = _flat(angular_response_deg=list(HALVES), width=96, height=64)
    raw.mosaic[:] = np.clip((raw.mosaic.astype(float) - raw.black_level) * 0.6 + raw.black_level, 0, 65535)
    config = ISPConfig(demosaic="bilinear", tone="linear", colour_matrix="none", white_balance="as_shot")
    plain = develop(raw, config).linear.astype(float)
    corrected = develop(raw, config.replace(shading=str(path))).linear.astype(float)
    inner = corrected[2:-2, 2:-2]
    for c in range(3):
        assert inner[..., c].max() / inner[..., c].min() < 1.01
    tint = plain[2, 2, 0] / plain[2, 2, 1]
    assert tint < 0.8 * plain[32, 48, 0] / plain[32, 48, 1]  # colour shading before
    assert corrected[2, 2, 0] / corrected[2, 2, 1] == pytest.approx(corrected[32, 48, 0] / corrected[32, 48, 1],
                                                                    rel=0.01)
    assert np.allclose(load_shading_table(path).gains(), table.gains())


def test_the_acceptance_is_off_by_default_and_today_s_results_stand():
    """Without angular_response_deg the flat falls as cos⁴ alone (the default keeps today's results)."""
    _, on = _flat(angular_response_deg=40.0)
    _, off = _flat()
    assert _channel_at(off, 0, 1) / _channel_at(off, 32, 49) > _channel_at(on, 0, 1) / _channel_at(on, 32, 49)
    assert off.meta["angular_response_deg"] == "off"


@pytest.mark.parametrize("bad", [0, -5, 100, [10, 20], "wide", True])
def test_a_bad_angular_response_is_refused_with_what_would_be_valid(bad):
    with pytest.raises(ConfigError, match="angular_response_deg"):
        sc.scene_from_dict({"sensor": {"angular_response_deg": bad}})


def test_a_table_from_another_camera_is_refused(tmp_path):
    _, small = _flat(width=64, height=48)
    table = calibrate_flat_field(small)
    _, raw = _flat()
    with pytest.raises(ConfigError, match="calibrated on a 64 × 48"):
        develop(raw, ISPConfig(), shading_table=table)
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(ConfigError, match="not a lens shading table"):
        develop(raw, ISPConfig(shading=str(tmp_path / "bad.json")))


@pytest.mark.parametrize("field_deg", [3.0, 10.0, 20.0])
def test_a_prescriptions_chief_ray_angle_is_the_traced_chief_rays(field_deg):
    """Behind the double Gauss 50 mm, the chief-ray angle shading.chief_ray_angles_deg gives at an image
    height (interpolated from 64 traced fields) equals the angle of the real chief ray traced by the test
    to that height (through the entrance pupil's centre) within 0.05°; the paraxial exit pupil's
    atan(r/(d + z_xp)) would miss by 1.05° at 20°."""
    from types import SimpleNamespace

    from spectral_cam.optics.prescription import load_prescription
    from spectral_cam.sensor.shading import chief_ray_angles_deg

    lens = load_prescription("dgauss_50mm")
    back = lens.sensor_distance_m(1e6)
    pupil_z, _ = lens.entrance_pupil()
    tilt = np.radians(field_deg)
    direction = np.array([[0.0, np.sin(tilt), np.cos(tilt)]])
    origin = np.array([[0.0, 0.0, pupil_z]]) - direction * (pupil_z + 1.0)
    o, d, passed = lens.trace(origin, direction)
    assert passed[0]
    height = lens.image_height_m(field_deg, back)
    traced = np.degrees(np.arctan(abs(d[0, 1]) / d[0, 2]))
    # column 1's centre at the height, focused where the trace's sensor stands
    frame = SimpleNamespace(width_px=2, height_px=1, pixel_pitch_m=2 * height, focus_distance_m=1e6)
    ours = chief_ray_angles_deg(frame, prescription="dgauss_50mm")[0, 1]
    assert ours == pytest.approx(traced, abs=0.05), (ours, traced)
