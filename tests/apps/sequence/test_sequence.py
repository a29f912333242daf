"""Issue 17 #1–3: sequences through the camera's control loops — resumable renders, the auto
exposure following a brightness step frame by frame, and locked modes whose RAW scales exactly
with illuminance and changes colour only as the illuminant's spectrum through the camera's
curves (colour-science's SPDs) predicts."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.apps.sequence import bayer_stats, run_sequence, sequence_from_dict
from spectral_cam.errors import ConfigError

pytestmark = pytest.mark.timeout(300)


def _spec(vary, frames, camera=None, **scene):
    return sequence_from_dict({
        "scene": {"preset": "flat_field", "reflectance": 0.18, **scene},
        "sensor": {"width_px": 32, "height_px": 24, "read_noise_e": 0.0, "prnu": 0.0, "dsnu_e": 0.0},
        "render": {"spp": 4},
        "sequence": {"frames": frames, "vary": vary},
        "camera": camera or {}})


def _raw_means(output, mode, frames):
    from spectral_cam.raw import read_raw

    return np.array([bayer_stats(read_raw(output / mode / f"{k:04d}" / "raw.dng")).reshape(-1, 3).mean(axis=0)
                     for k in range(frames)])


def test_auto_exposure_follows_a_brightness_step_and_the_renders_resume(tmp_path):
    """Illuminance 1000 lx, then 4000 lx (2 EV brighter, still below clipping): frame 1 is taken
    at frame 0's exposure, then each frame removes half the remaining error (damping ½): 1, 0.5,
    0.25 EV, as the hand-computed loop says; re-running renders nothing."""
    spec = _spec({"illuminant.illuminance_lux": [1000.0, 4000.0, 4000.0, 4000.0, 4000.0]}, 5,
                 {"damping": 0.5, "dead_band_ev": 0.05, "max_shutter_s": 1.0})
    result = run_sequence(spec, tmp_path, modes=("auto",), scheduler="inline")
    times = np.array([row["exposure_s"] for row in result["cameras"]["auto"]])
    assert times[1] == pytest.approx(times[0], rel=1e-9)  # frame 1 still holds frame 0's decision
    steps = np.log2(times[1:-1] / times[2:])  # EV removed per frame after the step
    assert steps == pytest.approx([1.0, 0.5, 0.25], abs=0.03)
    again = run_sequence(spec, tmp_path, modes=("auto",), scheduler="inline")
    assert again["renders"] == {"rendered": 0, "resumed": 5}


def test_locked_raw_scales_with_illuminance_and_turns_with_the_illuminants_spectrum(tmp_path):
    """Locked camera, a grey (18 %) flat field under D65 at 500, 1000, 2000 lx, then illuminant A
    at 1000 lx: the RAW's channel means double with each doubling of illuminance (within 1 %),
    and under A their ratios are the camera's responses to an 18 % grey under A computed from
    colour-science's SPDs through the camera's curves (within 1 %)."""
    from spectral_cam.sensor.colour_calibration import camera_responses

    spec = _spec({"illuminant.illuminance_lux": [500.0, 1000.0, 2000.0, 1000.0],
                  "illuminant.spd": ["D65", "D65", "D65", "A"]}, 4, {"max_shutter_s": 1.0})
    run_sequence(spec, tmp_path, modes=("locked",), scheduler="inline", lock_frame=1)
    means = _raw_means(tmp_path, "locked", 4)
    assert means[1] / means[0] == pytest.approx([2.0] * 3, rel=0.01)
    assert means[2] / means[1] == pytest.approx([2.0] * 3, rel=0.01)
    predicted = camera_responses("nikon_d850", "A", [0.18])[0]
    assert (means[3] / means[3][1]) == pytest.approx(predicted / predicted[1], rel=0.01)


def test_a_bad_spec_is_refused_with_what_would_be_valid():
    with pytest.raises(ConfigError, match="one per frame"):
        _spec({"sky.hour": [9.0, 10.0]}, 3)
    with pytest.raises(ConfigError, match="unknown key.*shutter"):
        _spec({}, 2, {"shutter": 0.01})
    with pytest.raises(ConfigError, match="frames"):
        sequence_from_dict({"sequence": {"frames": 0}})


def test_a_monochrome_sensor_runs_a_sequence(tmp_path):
    """Issue 25 #11: the documented monochrome sensor (``model = "ideal"``, ``cfa = "none"``)
    raised TypeError in bayer_stats; its cells are now read as grey, and the auto exposure meters
    them as it meters colour (the flat 18 % field lands at the same grey level each frame)."""
    spec = sequence_from_dict({
        "scene": {"preset": "flat_field", "reflectance": 0.18},
        "sensor": {"width_px": 32, "height_px": 24, "model": "ideal", "cfa": "none"},
        "render": {"spp": 4}, "sequence": {"frames": 2, "vary": {}}, "camera": {}})
    run_sequence(spec, tmp_path, modes=("auto",), scheduler="inline")
    means = _raw_means(tmp_path, "auto", 2)
    assert np.allclose(means[:, 0], means[:, 1]) and np.allclose(means[:, 1], means[:, 2])
    assert means[0, 0] == pytest.approx(10 / 78, rel=0.1)


def test_drift_refuses_a_sequence_without_plants(tmp_path):
    """Issue 25 #6: --drift on a flat field reported 4.5–6.25 % of "plant pixels flagged"."""
    from spectral_cam.apps.sequence.drift import drift_metrics

    run_sequence(_spec({}, 2), tmp_path, modes=("auto",), scheduler="inline")
    with pytest.raises(ConfigError, match="no frame of this sequence shows one"):
        drift_metrics(tmp_path, ["auto"])


def test_a_sequence_never_replaces_another_run_without_force(tmp_path):
    """Issue 25 #1: a 2-frame spec run into a 4-frame run's folder deleted auto/0002–0003 without
    --force and left stale renders (then --drift raised TypeError). Now: the same spec resumes,
    another is refused, and --force replaces the run whole."""
    run_sequence(_spec({"illuminant.illuminance_lux": [100, 200, 300, 400]}, 4), tmp_path, scheduler="inline")
    before = sorted(p.name for p in (tmp_path / "auto").iterdir())
    run_sequence(_spec({"illuminant.illuminance_lux": [100, 200, 300, 400]}, 4), tmp_path, scheduler="inline")
    shorter = _spec({"illuminant.illuminance_lux": [100, 200]}, 2)
    with pytest.raises(ConfigError, match="holds another run .* give --force"):
        run_sequence(shorter, tmp_path, scheduler="inline")
    assert sorted(p.name for p in (tmp_path / "auto").iterdir()) == before  # untouched
    run_sequence(shorter, tmp_path, scheduler="inline", force=True)
    assert sorted(p.name for p in (tmp_path / "render").iterdir()) == ["0000", "0001"]
    assert sorted(p.name for p in (tmp_path / "auto").iterdir()) == ["0000", "0001", "frames.csv"]


def test_a_sequence_that_cannot_fit_on_the_disk_is_refused_before_rendering(tmp_path, monkeypatch):
    """Issue 25 #8: frames × (radiance + depth + a RAW and image per mode), uncompressed, against
    the free disk, before any frame renders or the folder is claimed."""
    import shutil

    usage = shutil.disk_usage(tmp_path)
    monkeypatch.setattr(shutil, "disk_usage", lambda path: usage._replace(free=50_000))  # 50 kB
    spec = _spec({"illuminant.illuminance_lux": [1000.0, 2000.0, 4000.0]}, 3)
    with pytest.raises(ConfigError, match=r"3 frames of about .* MB each needs about .* GB but .* free"):
        run_sequence(spec, tmp_path / "seq", modes=("auto", "locked"), scheduler="inline")
    assert not (tmp_path / "seq").exists()


def test_each_frame_has_its_camera_json_with_the_exposure_used(tmp_path):
    """Issue 27 #1: a sequence writes camera.json per frame; its exposure is the one the frame's
    RAW carries (EXIF ExposureTime via the RAW's meta) and K is v/p of the frame."""
    import json

    from spectral_cam.optics import ThinLens

    spec = _spec({"illuminant.illuminance_lux": [1000.0, 4000.0]}, 2)
    result = run_sequence(spec, tmp_path, modes=("auto",), scheduler="inline")
    for row in result["cameras"]["auto"]:
        camera = json.loads((tmp_path / "auto" / f"{row['frame']:04d}" / "camera.json").read_text())
        assert camera["exposure_s"] == pytest.approx(row["exposure_s"], rel=1e-12)
        config = spec.frame_config(row["frame"])
        lens = ThinLens.from_config(config.lens, config.sensor)
        assert camera["K"][0][0] == pytest.approx(lens.image_distance_m / lens.pixel_pitch_m, rel=1e-12)
        assert camera["image_size"] == [32, 24]


WALL = """<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 0, 0" target="0, 0, 1" up="0, 1, 0"/></transform></sensor>
  <shape type="rectangle" id="wall"><transform name="to_world"><scale value="5"/><rotate y="1" angle="180"/>
    <translate value="0, 0, {distance}"/></transform>
    <bsdf type="diffuse"><spectrum name="reflectance" value="0.5"/></bsdf></shape>
  <emitter type="constant" id="sky"><spectrum name="radiance" value="1.0"/></emitter>
</scene>"""


def test_flow_between_frames_is_the_cameras_move_between_them(tmp_path):
    """Issue 27 #5: flow_to_next.exr of a camera stepping across a wall 3 m away equals the known
    per-frame displacement f·Δ/z (Δ = 5 cm left and 2 cm up: the wall moves right and down) within
    2 %, a pure 2° yaw to the left moves the frame's centre f·tan 2° to the right, and the last
    frame has none (OpenEXR reads the files)."""
    import json
    import math

    import OpenEXR

    distance = 3.0
    (tmp_path / "wall.xml").write_text(WALL.format(distance=distance))
    spec = sequence_from_dict({
        "scene": {"mitsuba_xml": str(tmp_path / "wall.xml")},
        "sensor": {"width_px": 40, "height_px": 30}, "render": {"spp": 2},
        "sequence": {"frames": 3, "vary": {"scene.camera_offset_m": [[0.0, 0.0, 0.0], [0.05, 0.02, 0.0],
                                                                     [0.05, 0.02, 0.0]],
                                           "scene.camera_rotation_deg": [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0],
                                                                         [2.0, 0.0, 0.0]]}}})
    run_sequence(spec, tmp_path / "out", modes=("auto",), scheduler="inline")

    def flow(k):
        with OpenEXR.File(str(tmp_path / "out" / "auto" / f"{k:04d}" / "flow_to_next.exr")) as exr:
            channels = exr.channels()
            return np.stack([np.array(channels[c].pixels) for c in ("dx", "dy")], axis=-1)

    focal = json.loads((tmp_path / "out" / "auto" / "0000" / "camera.json").read_text())["K"][0][0]
    step = flow(0)
    np.testing.assert_allclose(step[..., 0], focal * 0.05 / distance, rtol=0.02)
    np.testing.assert_allclose(step[..., 1], focal * 0.02 / distance, rtol=0.02)
    turn = flow(1)
    centre = turn[14:16, 19:21].mean(axis=(0, 1))  # the four pixels about the centre (19.5, 14.5)
    assert centre[0] == pytest.approx(focal * math.tan(math.radians(2.0)), rel=0.02)
    assert abs(centre[1]) < 0.02
    assert not (tmp_path / "out" / "auto" / "0002" / "flow_to_next.exr").exists()


def test_a_qis_sequence_runs_the_camera_loop_on_its_reconstructions_and_events_are_refused(tmp_path):
    """sensor.kind = "qis" in a sequence: each frame's RAW is the reconstruction of its single-photon
    frames, which the auto loop meters: the illuminance quadrupling at frame 1 takes the exposure down
    (by 1 EV, not 2: at 4× the light a one-bit jot's frames nearly all fire and the reconstruction
    saturates near ln 2F, so the meter reads less than 4×); an event sensor is refused with what to do
    instead."""
    from spectral_cam.errors import ConfigError

    spec = sequence_from_dict({
        "scene": {"preset": "flat_field", "reflectance": 0.18},
        "sensor": {"width_px": 32, "height_px": 24, "kind": "qis", "jot_frames": 64},
        "render": {"spp": 4},
        "sequence": {"frames": 3, "vary": {"illuminant.illuminance_lux": [500.0, 2000.0, 2000.0]}},
        "camera": {"damping": 1.0, "dead_band_ev": 0.05}})
    result = run_sequence(spec, tmp_path, modes=("auto",), scheduler="inline")
    times = [row["exposure_s"] for row in result["cameras"]["auto"]]
    assert times[2] < 0.7 * times[0]
    assert (tmp_path / "auto" / "0002" / "raw.dng").exists()
    events = sequence_from_dict({"scene": {"preset": "flat_field"}, "sensor": {"width_px": 16, "height_px": 16,
                                                                               "kind": "event"},
                                 "render": {"spp": 4}, "sequence": {"frames": 2, "vary": {}}})
    with pytest.raises(ConfigError, match="time-lapse"):
        run_sequence(events, tmp_path / "events", modes=("auto",), scheduler="inline")
