"""Big frames kept within reason (issue 25 #8): radiance.exr in half precision, read back by
the OpenEXR library and judged against IEEE 754 binary16 and the sensor's shot noise; the
output size estimated before rendering and checked against the free disk; a warning where
the thin lens's view passes what rectilinear lenses reach (field of view from the sensor's
size, 2·atan(d/2v))."""

from __future__ import annotations

import math
import shutil
import warnings

import numpy as np
import OpenEXR
import pytest

import spectral_cam as sc
from spectral_cam.radiance_targets import narrow_band_flat
from spectral_cam.errors import ConfigError, SceneWarning
from spectral_cam.exr import HALF_MIN_NORMAL
from spectral_cam.image import SpectralImage
from spectral_cam.budget import estimate_result_bytes
from spectral_cam.job import run_render_job
from spectral_cam.optics import ThinLens
from spectral_cam.render.plan import WIDEST_RECTILINEAR_DEG, warn_wide_view
from spectral_cam.spectral_exr import read_spectral_exr, write_spectral_exr

pytestmark = pytest.mark.timeout(180)


def _daylight_cube(shape=(24, 32)):
    """Per-nm radiances of a sunlit scene (0.01–6 W·m⁻²·sr⁻¹·nm⁻¹, the bundled tabletop's range)
    as 31 band integrals of 10 nm."""
    rng = np.random.default_rng(3)
    per_nm = np.exp(rng.uniform(np.log(0.01), np.log(6.0), (*shape, 31))).astype(np.float32)
    image = narrow_band_flat(shape, 1.0)
    return SpectralImage(per_nm * 10.0, image.wavelengths_nm, image.band_edges_nm, None, {})


def test_half_radiance_is_binary16_as_openexr_reads_it(tmp_path):
    image = _daylight_cube()
    path = write_spectral_exr(image, tmp_path / "radiance.exr", precision="half")
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        channels = {name: np.array(c.pixels) for name, c in exr.channels().items()}
    assert {c.dtype for c in channels.values()} == {np.dtype(np.float16)}
    per_nm = image.data / 10.0
    back = read_spectral_exr(path).data / 10.0
    # IEEE 754 round-to-nearest: NumPy's float16 cast is the reference, and the error is at most
    # half a unit in the last of 11 significant bits (2⁻¹¹ relative) in the normal range
    assert np.array_equal(back.astype(np.float16), per_nm.astype(np.float16))
    relative = np.abs(back - per_nm) / per_nm
    assert relative.max() <= 2.0 ** -11
    # against the smallest shot noise the sensor makes: 1/√(full well) at saturation
    full_well = sc.scene_from_dict({}).sensor.full_well_e
    assert relative.max() < 0.1 / math.sqrt(full_well)
    # half the bytes of float (both uncompressed or both compressed by the same codec)
    floats = write_spectral_exr(image, tmp_path / "float.exr")
    assert path.stat().st_size < 0.6 * floats.stat().st_size


def test_half_refuses_what_it_cannot_hold_and_warns_on_a_dim_scene(tmp_path):
    bright = _daylight_cube()
    bright.data[0, 0, 5] = 7e4 * 10.0  # a specular glint of the sun: beyond the largest half
    with pytest.raises(ConfigError, match=r"radiance_precision = 'half'.*65504.*'float'"):
        write_spectral_exr(bright, tmp_path / "radiance.exr", precision="half")
    assert list(tmp_path.iterdir()) == []  # nothing left behind
    dim = _daylight_cube()
    dim.data[...] *= 1e-5  # a 1-lux scene's radiances sit below half's normal range
    assert (dim.data / 10.0).max() < HALF_MIN_NORMAL * 2
    with pytest.warns(SceneWarning, match=r"% of radiance.exr's values lie below"):
        write_spectral_exr(dim, tmp_path / "dim.exr", precision="half")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        write_spectral_exr(dim, tmp_path / "dim_float.exr")  # float keeps them: no warning
    with pytest.raises(ConfigError, match="render.radiance_precision.*valid: float, half"):
        sc.scene_from_dict({"render": {"radiance_precision": "double"}})


def test_output_size_estimate_bounds_the_files_written(tmp_path):
    config = sc.load_scene("scenes/colorchecker.toml", overrides={
        "sensor.width_px": 96, "sensor.height_px": 64, "render.spp": 2, "isp.outputs": ["png", "tiff"]})
    run_render_job(config, tmp_path / "out")
    estimate = estimate_result_bytes(config, ["radiance", "depth", "raw", "image"])
    actual = {"radiance": (tmp_path / "out/radiance.exr").stat().st_size,
              "raw": (tmp_path / "out/raw.dng").stat().st_size,
              "depth": (tmp_path / "out/depth.exr").stat().st_size,
              "image": sum((tmp_path / f"out/image.{s}").stat().st_size for s in ("png", "tif"))}
    for name, size in actual.items():
        assert size <= estimate[name], name
    # the uncompressed cube: the estimate is W·H·31·4 bytes plus a header, within a few percent
    assert estimate["radiance"] / actual["radiance"] < 1.03
    half = config.replace(**{"render.radiance_precision": "half"})
    assert estimate_result_bytes(half, ["radiance"])["radiance"] == pytest.approx(16e3 + 96 * 64 * 31 * 2)


def test_a_result_that_cannot_fit_is_refused_before_rendering(tmp_path, monkeypatch):
    usage = shutil.disk_usage(tmp_path)
    monkeypatch.setattr(shutil, "disk_usage", lambda path: usage._replace(free=10_000_000))  # 10 MB free
    config = sc.scene_from_dict({"sensor": {"width_px": 480, "height_px": 320}, "render": {"spp": 1}})
    import spectral_cam.job as job

    monkeypatch.setattr(job, "simulate", lambda *a, **k: pytest.fail("rendered before the disk check"))
    with pytest.raises(ConfigError, match=r"needs about 0\.0[0-9]+ GB but .* has 0\.01 GB free;.*'half'"):
        run_render_job(config, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_a_view_wider_than_rectilinear_lenses_is_warned(recwarn):
    # 8000 × 6000 px at the default 6 µm pitch behind the default 8 mm lens (issue 25 #8):
    # 48 × 36 mm, so 2·atan(24 / v) ≈ 143° across with v = f·z/(z − f)
    big = sc.scene_from_dict({"sensor": {"width_px": 8000, "height_px": 6000}})
    lens = ThinLens.from_config(big.lens, big.sensor)
    v = 8e-3 * big.lens.focus_distance_m / (big.lens.focus_distance_m - 8e-3)
    assert lens.fov_x_deg == pytest.approx(math.degrees(2 * math.atan(24e-3 / v)))
    assert lens.fov_diagonal_deg == pytest.approx(math.degrees(2 * math.atan(30e-3 / v)))
    corner = math.radians(lens.fov_diagonal_deg / 2)
    with pytest.warns(SceneWarning, match=rf"143° across.*get {100 * math.cos(corner) ** 4:.2g} % of the centre"):
        warn_wide_view(lens)
    # the bundled default (2.88 mm behind 8 mm, 20° across) and a 12 mm on full frame pass quietly
    default = sc.scene_from_dict({})
    full_frame = sc.scene_from_dict({"sensor": {"width_px": 6000, "height_px": 4000}, "lens": {"focal_length_mm": 12.5}})
    for config in (default, full_frame):
        lens = ThinLens.from_config(config.lens, config.sensor)
        assert lens.fov_diagonal_deg <= WIDEST_RECTILINEAR_DEG
        warn_wide_view(lens)
    assert not [w for w in recwarn if issubclass(w.category, SceneWarning)]


def test_render_warns_of_the_wide_view_before_tracing():
    # a small frame of huge pixels: 64 × 400 µm = 25.6 mm behind 8 mm, 127° diagonally
    config = sc.scene_from_dict({"sensor": {"width_px": 64, "height_px": 48, "pixel_pitch_um": 400.0},
                                 "render": {"spp": 1}})
    with pytest.warns(SceneWarning, match="wider than rectilinear lenses reach"):
        sc.render(config, with_depth=False)
