"""The command line: outputs as docs/design.md specifies, and user errors without tracebacks."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from spectral_cam.spectral_exr import read_depth_exr, read_spectral_exr


def run_cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "spectral_cam.cli", *args],
                          capture_output=True, text=True, cwd=cwd, timeout=240)


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(
        '[scene]\npreset = "colorchecker"\n[sensor]\nwidth_px = 36\nheight_px = 24\n'
        '[render]\nspp = 8\n'
    )
    return path


@pytest.mark.timeout(240)
def test_render_writes_radiance_depth_and_meta(tmp_path, scene_file):
    out = tmp_path / "out"
    result = run_cli("render", str(scene_file), "-o", str(out), "--set", "lens.f_number=4")
    assert result.returncode == 0, result.stderr
    radiance = read_spectral_exr(out / "radiance.exr")
    assert radiance.data.shape == (24, 36, 31)
    assert radiance.wavelengths_nm[0] == 400 and radiance.wavelengths_nm[-1] == 700
    import OpenEXR

    exr = OpenEXR.File(str(out / "radiance.exr"))
    header, names = exr.header(), list(exr.channels())
    assert "S0.550,000000nm" in names
    assert header["spectralLayoutVersion"] == "1.0" and header["emissiveUnits"] == "W.m^-2.sr^-1"
    depth = read_depth_exr(out / "depth.exr")
    assert depth.shape == (24, 36) and np.nanmin(depth) >= 2.0 - 1e-3
    meta = json.loads((out / "meta.json").read_text())
    assert meta["config"]["lens"]["f_number"] == 4.0
    optics = meta["optics"]
    f, z = 8e-3, 2.0
    assert optics["image_distance_m"] == pytest.approx(f * z / (z - f))
    assert optics["aperture_radius_m"] == pytest.approx(f / 8)
    assert meta["render"]["variant"].endswith("spectral")
    assert set(meta["timings_s"]) >= {"render_radiance", "render_depth", "sensor", "isp", "total"}
    assert meta["sensor"]["K_dn_per_e"] == pytest.approx((2 ** 12 - 1 - 256) / 20000)
    assert meta["sensor"]["saturation_e"] == pytest.approx(20000)
    assert {"raw.dng", "image.png", "radiance.exr", "depth.exr", "meta.json", "scene.toml"} <= set(
        p.name for p in out.iterdir())
    from spectral_cam import load_scene, scene_from_dict

    assert load_scene(out / "scene.toml") == scene_from_dict(meta["config"])  # reproducible as a scene file
    import rawpy

    with rawpy.imread(str(out / "raw.dng")) as raw:  # the frame and the 8-px crop margin around it
        assert raw.raw_image_visible.shape == (24 + 16, 36 + 16)
        sizes = raw.sizes
        assert (sizes.crop_top_margin, sizes.crop_left_margin, sizes.crop_height, sizes.crop_width) == (8, 8, 24, 36)
    assert "mitsuba" in meta["versions"]
    # an existing result is never overwritten without --force
    again = run_cli("render", str(scene_file), "-o", str(out))
    assert again.returncode == 2 and "--force" in again.stderr
    forced = run_cli("render", str(scene_file), "-o", str(out), "--force", "-q")
    assert forced.returncode == 0, forced.stderr


@pytest.mark.parametrize(
    "override, message",
    [
        ("illuminant.spd=D66", "unknown illuminant 'D66'"),
        ("sensor.model=nokia", "unknown camera 'nokia'"),
        ("lens.focus_distance_m=0.005", "focuses only beyond its focal length"),
        ("lens.f_number=0", "lens.f_number"),
        ("sensor.width_px=-3", "sensor.width_px"),
        ("nonsense", "use section.key=value"),
    ],
)
def test_user_errors_exit_nonzero_without_traceback_or_output(tmp_path, scene_file, override, message):
    out = tmp_path / "never"
    result = run_cli("render", str(scene_file), "-o", str(out), "--set", override)
    assert result.returncode == 2
    assert message in result.stderr
    assert "Traceback" not in result.stderr
    assert not out.exists()
    assert not any(p.name.startswith(".never") for p in tmp_path.iterdir())


def test_cameras_lists_the_measured_sensors():
    result = run_cli("cameras")
    assert result.returncode == 0
    names = result.stdout.split()
    assert "nikon_d850" in names and "sony_ilce_7m3" in names and "nikon_5100_npl" in names


@pytest.mark.parametrize(("kind", "extra", "files"), [
    ("qis", ["--set", "sensor.jot_frames=32"], {"photon_counts.npz", "raw.dng", "image.png"}),
    ("event", ["--set", "exposure.time_s=0.01", "--set", "motion.camera_angular_velocity_dps=[30,0,0]",
               "--set", "sensor.event_frames=4"], {"events.npz", "events.png", "raw.dng"})])
def test_a_user_xml_scene_renders_through_single_photon_and_event_sensors(tmp_path, kind, extra, files):
    """Issue 30 acceptance: the bundled user XML scene (scenes/glass_sphere.toml, a Mitsuba XML file)
    through the CLI with sensor.kind = qis and = event writes each kind's files."""
    from pathlib import Path

    scene = Path(__file__).resolve().parents[2] / "scenes" / "glass_sphere.toml"
    result = run_cli("render", str(scene), "-o", str(tmp_path / "out"), "--set", f"sensor.kind={kind}",
                     "--set", "sensor.width_px=48", "--set", "sensor.height_px=32", "--set", "render.spp=8", *extra)
    assert result.returncode == 0, result.stderr
    assert files <= {p.name for p in (tmp_path / "out").iterdir()}


@pytest.mark.timeout(120)
def test_a_reader_that_stops_early_gets_no_error_message():
    """``spectral-cam keys | head -1``: the pipe closing is the reader's choice, not an error to print
    (it printed 'spectral-cam: error: Broken pipe')."""
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-m", "spectral_cam.cli", "keys"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.close()  # as head does after its lines, here before the command has written any
    err = proc.stderr.read().decode()
    proc.wait(timeout=60)
    assert "Broken pipe" not in err and "Traceback" not in err, err
