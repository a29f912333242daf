"""Robustness of the scene loader, the EXR reader and the CLI: whatever a user types or
feeds in gives a clear error or a valid result, never a crash or a half-written output."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from spectral_cam import ConfigError, RawFormatError, load_scene, scene_from_dict
from spectral_cam.spectral_exr import read_depth_exr, read_spectral_exr

values = st.one_of(
    st.none(), st.booleans(), st.integers(-10**6, 10**6),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12),
    st.lists(st.floats(-10, 10), max_size=4),
)
keys = st.sampled_from([
    "lens.focal_length_mm", "lens.f_number", "lens.focus_distance_m", "lens.model",
    "sensor.width_px", "sensor.pixel_pitch_um", "sensor.model", "sensor.cfa", "sensor.bit_depth",
    "sensor.peak_qe", "sensor.full_well_e", "scene.preset", "scene.depths_m", "scene.reflectance",
    "illuminant.spd", "illuminant.illuminance_lux", "exposure.time_s", "render.spp", "render.bands",
])


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.dictionaries(keys, values, max_size=4))
def test_any_override_gives_a_config_or_a_config_error(overrides):
    overrides = {k: v for k, v in overrides.items() if v is not None}
    try:
        config = scene_from_dict({}, overrides=overrides)
    except ConfigError as exc:
        assert str(exc)  # a message, not an empty error
        return
    assert config.lens.f_number > 0 and config.sensor.width_px >= 1
    assert config.lens.focus_distance_m * 1000 > config.lens.focal_length_mm


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.binary(max_size=300))
def test_any_bytes_as_a_scene_file_give_a_config_or_a_config_error(tmp_path, payload):
    path = tmp_path / "fuzz.toml"
    path.write_bytes(payload)
    try:
        load_scene(path)
    except ConfigError:
        pass


def test_hostile_paths_are_clear_errors(tmp_path):
    with pytest.raises(ConfigError, match="does not exist or is not a file"):
        load_scene("bad\x00name.toml")
    with pytest.raises(ConfigError, match="not a file"):
        load_scene(tmp_path)  # a directory


@pytest.mark.parametrize("content", [b"", b"v/1\x01" + b"\x00" * 40, b"not an exr at all"])
def test_corrupt_exr_files_are_clear_errors(tmp_path, content):
    path = tmp_path / "bad.exr"
    path.write_bytes(content)
    with pytest.raises(RawFormatError, match="not a readable OpenEXR file"):
        read_spectral_exr(path)
    with pytest.raises(RawFormatError):
        read_depth_exr(path)


def test_truncated_exr_is_a_clear_error(tmp_path):
    import numpy as np

    from spectral_cam.image import SpectralImage
    from spectral_cam.spectral_exr import write_spectral_exr

    image = SpectralImage(np.random.default_rng(0).random((32, 32, 4), dtype=np.float32),
                          np.array([400.0, 410, 420, 430]), np.array([395.0, 405, 415, 425, 435]))
    path = tmp_path / "full.exr"
    write_spectral_exr(image, path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(RawFormatError):
        read_spectral_exr(path)


def _slow_render_under_way(tmp_path):
    """A ``spectral-cam render`` subprocess a second into writing its staging folder.

    On the scalar variant: its passes are :data:`~spectral_cam.render.SCALAR_LANES_PER_PASS`
    (2^20) samples, a fraction of a second, where the LLVM variant's first pass is 2^28 samples
    (11 s on a quiet 2-core machine), and a signal reaches Python's handler only when Mitsuba's call returns. The
    render still runs for minutes (5·10^8 samples), so the signal lands mid-render as before, and
    the staging folder and its cleanup are the CLI's, the same for every variant."""
    scene = tmp_path / "slow.toml"
    scene.write_text('[sensor]\nwidth_px = 64\nheight_px = 48\n[render]\nspp = 100000\nvariant = "scalar_spectral"\n')
    out = tmp_path / "result"
    # SIGINT as a terminal delivers it: a suite run in the background inherits it ignored
    proc = subprocess.Popen([sys.executable, "-m", "spectral_cam.cli", "render", str(scene), "-o", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.time() + 60
    while time.time() < deadline and not any(p.name.startswith(".result.partial-") for p in tmp_path.iterdir()):
        time.sleep(0.2)
    time.sleep(1.0)
    return proc, out


@pytest.mark.timeout(120)
def test_killed_render_leaves_no_complete_looking_output(tmp_path):
    proc, out = _slow_render_under_way(tmp_path)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not out.exists()  # only a hidden, clearly partial staging folder may remain
    leftovers = [p.name for p in tmp_path.iterdir() if p.name != "slow.toml"]
    assert all(name.startswith(".result.partial-") for name in leftovers)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_interrupted_render_keeps_no_partial_output(tmp_path, signum):
    """SIGTERM cleans up like Ctrl-C (issue 12 #12: it left a .partial folder)."""
    proc, _ = _slow_render_under_way(tmp_path)
    os.kill(proc.pid, signum)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err.decode()[-500:]
    assert "no partial output was kept" in err.decode()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["slow.toml"]


@pytest.mark.timeout(60)
@pytest.mark.parametrize("edges", ["[400, 500]", "[NaN, 1, 2]", "not json", "[" + ", ".join(["1"] * 32) + "]"])
def test_bad_band_edges_in_a_spectral_exr_are_refused(tmp_path, edges):
    """Issue 12 #13: a wrong-length or NaN edges attribute was broadcast into the data."""
    import numpy as np

    from spectral_cam.radiance_targets import narrow_band_flat
    from spectral_cam.exr import write_exr_channels
    from spectral_cam.spectral_exr import channel_name

    image = narrow_band_flat((4, 4), 0.05)
    channels = {channel_name(w): image.data[..., i] for i, w in enumerate(image.wavelengths_nm)}
    path = write_exr_channels(channels, tmp_path / "bad.exr", {"spectralLayoutVersion": "1.0",
                                                               "emissiveUnits": "W.m^-2.sr^-1",
                                                               "spectral_cam_band_edges_nm": edges})
    with pytest.raises(RawFormatError, match="spectral_cam_band_edges_nm"):
        read_spectral_exr(path)
    assert np.isfinite(image.data).all()


@pytest.mark.timeout(60)
def test_an_image_write_that_fails_is_an_error_not_an_empty_file(tmp_path, monkeypatch):
    """Issue 12 #13: cv2.imwrite reported success over a 0-byte PNG on a full disk."""
    import errno
    from pathlib import Path

    import numpy as np

    from spectral_cam.isp.encode import write_png

    def full_disk(self, data):
        raise OSError(errno.ENOSPC, "No space left on device", str(self))

    monkeypatch.setattr(Path, "write_bytes", full_disk)
    with pytest.raises(OSError, match="No space left"):
        write_png(np.full((4, 4, 3), 0.5), tmp_path / "image.png")
    assert not list(tmp_path.iterdir())


@pytest.mark.timeout(60)
def test_an_interrupt_discards_partial_output_before_it_unwinds(tmp_path):
    """The handler removes staging folders and temporary files itself, so output is gone even
    when the KeyboardInterrupt it raises is lost or converted on its way up."""
    from spectral_cam.cli import _interrupt
    from spectral_cam.io import atomic_path, staged_directory

    with pytest.raises(KeyboardInterrupt):
        with staged_directory(tmp_path / "result") as stage, atomic_path(tmp_path / "lone.txt") as tmp:
            (stage / "half.dng").write_bytes(b"partial")
            tmp.write_text("partial")
            try:
                _interrupt(signal.SIGINT, None)
            finally:  # what the interrupt left on disk at the moment it was raised
                left = sorted(p.name for p in tmp_path.iterdir())
                from spectral_cam import cli

                while cli._WATCHDOGS:
                    cli._WATCHDOGS.pop().cancel()
    assert left == []
