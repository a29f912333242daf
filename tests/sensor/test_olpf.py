"""Issue 29 #1: the optical low-pass filter. The slanted-edge MTF (ISO 12233) of a noise-free
monochrome capture equals the pixel aperture's sinc times the filter's |cos(π f d)| up to Nyquist;
the camera table follows the makers' specifications; false colour on a Bayer capture of fine
detail drops with the filter; bad settings are refused with what would be valid."""

from __future__ import annotations

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.errors import ConfigError
from spectral_cam.image import SpectralImage
from spectral_cam.metrics.sharpness import slanted_edge_mtf
from spectral_cam.sensor.olpf import CAMERA_OLPF, apply_olpf, olpf_separation_px

pytestmark = pytest.mark.timeout(120)

QUIET = {"shot_noise": False, "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0,
         "vignetting": False}


def _slanted_edge(shape=(96, 96), angle_deg=5.0, supersample=32) -> np.ndarray:
    """Fraction of each pixel's area right of a line through the centre tilted ``angle_deg`` from
    vertical (the pixel aperture: a box, integrated on a 32 × 32 grid per pixel)."""
    h, w = shape
    offsets = (np.arange(supersample) + 0.5) / supersample
    yy = (np.arange(h)[:, None] + offsets[None, :]).ravel()
    xx = (np.arange(w)[:, None] + offsets[None, :]).ravel()
    x_edge = w / 2 + np.tan(np.radians(angle_deg)) * (yy - h / 2)
    right = (xx[None, :] > x_edge[:, None]).astype(float)
    return right.reshape(h, supersample, w, supersample).mean(axis=(1, 3))


def _capture(fraction: np.ndarray, olpf) -> np.ndarray:
    """A monochrome, noise-free 16-bit capture of radiance 0.01 + 0.04·fraction (one 550-nm band)."""
    h, w = fraction.shape
    data = (0.01 + 0.04 * fraction)[..., None].astype(np.float32)
    radiance = SpectralImage(data, (550.0,), (545.0, 555.0))
    scene = sc.scene_from_dict({"sensor": {"width_px": w, "height_px": h, "model": "ideal", "cfa": "none",
                                           "bit_depth": 16, "olpf": olpf, **QUIET},
                                "exposure": {"time_s": 0.02}})
    raw = sc.expose(radiance, scene)
    return raw.mosaic.astype(float) - raw.black_level


@pytest.mark.parametrize(("separation", "upto_cycles_per_px"), [(0.0, 0.5), (1.0, 0.5), (0.6, 0.4)])
def test_the_slanted_edge_mtf_is_the_pixel_sinc_times_the_filters_cosine(separation, upto_cycles_per_px):
    """MTF(f) = |sinc(f)|·|cos(π f d)| within 0.02, the reference analytic (the box pixel aperture
    and the four-spot filter): up to the Nyquist frequency (0.5 cycle per pixel) without a filter and
    for d = 1 pitch (whole-pixel shifts, exact: zero at Nyquist); for d = 0.6 pitch (a Fourier shift of
    the rendered pixels) up to 0.4 — at Nyquist it measures 0.28 against 0.38, the aliased part of the
    pixel-sampled image shifted as if it were band-limited (docs/design.md)."""
    image = _capture(_slanted_edge(), separation)
    freqs, mtf = slanted_edge_mtf(image)
    upto = freqs <= upto_cycles_per_px + 1e-9
    expected = np.abs(np.sinc(freqs[upto])) * np.abs(np.cos(np.pi * freqs[upto] * separation))
    np.testing.assert_allclose(mtf[upto], expected, atol=0.02)


def test_the_camera_table_follows_the_makers_specifications():
    """The D850, D810 and α7R III are built without a filter; the α7 III has one (1 pitch assumed:
    no maker publishes the separation); an unknown one is none, and says so."""
    assert olpf_separation_px("camera", model="nikon_d850", pixel_pitch_um=4.35)[0] == 0.0
    assert CAMERA_OLPF["nikon_d810"] is None and CAMERA_OLPF["sony_ilce_7rm3"] is None
    d, why = olpf_separation_px("camera", model="sony_ilce_7m3", pixel_pitch_um=5.9)
    assert d == 1.0 and "not published" in why
    d, why = olpf_separation_px("camera", model="hasselblad_l1d_20c", pixel_pitch_um=2.4)
    assert d == 0.0 and "not published" in why
    assert olpf_separation_px("4.35 um", model="nikon_d850", pixel_pitch_um=4.35)[0] == pytest.approx(1.0)
    from spectral_cam.spectra import camera_names

    assert set(CAMERA_OLPF) == set(camera_names()) - {"ideal"}  # every bundled camera is in the table


def test_the_filter_keeps_the_light_and_spreads_a_point_into_four_spots():
    """A point on a dark field becomes four spots of a quarter each at (0, 0), (d, 0), (0, d), (d, d)."""
    plane = np.zeros((9, 9), np.float32)
    plane[4, 4] = 1.0
    out = apply_olpf(plane, 1.0)
    assert out.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(out[4:6, 4:6], 0.25)


@pytest.mark.parametrize("bad", [-1, 5, "blurry", "x um", float("nan")])
def test_a_bad_filter_setting_is_refused_with_what_would_be_valid(bad):
    with pytest.raises(ConfigError, match="valid|0..4"):
        sc.scene_from_dict({"sensor": {"olpf": bad}})


def _false_colour(olpf) -> float:
    """Mean chroma (|R − G| + |B − G|, relative to the mean) of a bilinear develop of a neutral
    zone plate of frequencies up to 0.45 cycle per pixel: a grey scene, so every colour is false."""
    from spectral_cam.isp import ISPConfig, develop

    h = w = 128
    yy, xx = np.indices((h, w)) + 0.5
    r2 = ((xx - w / 2) ** 2 + (yy - h / 2) ** 2)
    pattern = 0.5 + 0.5 * np.cos(np.pi * 0.45 * r2 / (w / 2))  # local frequency 0.45·r/(w/2) cycles/px
    from spectral_cam.radiance_targets import lambertian_radiance, uniform_image

    grey = uniform_image(lambertian_radiance("D65", [0.5])[0], (h, w))
    data = grey.data * (0.1 + 0.9 * pattern[..., None]).astype(np.float32)
    radiance = SpectralImage(data, grey.wavelengths_nm, grey.band_edges_nm)
    scene = sc.scene_from_dict({"sensor": {"width_px": w, "height_px": h, "olpf": olpf, **QUIET},
                                "exposure": {"time_s": "auto"}, "illuminant": {"spd": "D65"}})
    raw = sc.expose(radiance, scene)
    rgb = develop(raw, ISPConfig(demosaic="bilinear", tone="linear")).linear.astype(float)
    chroma = np.abs(rgb[..., 0] - rgb[..., 1]) + np.abs(rgb[..., 2] - rgb[..., 1])
    return float(chroma[8:-8, 8:-8].mean() / rgb[8:-8, 8:-8].mean())


def test_false_colour_on_fine_neutral_detail_drops_with_the_filter():
    """A neutral zone plate through an RGGB mosaic: a 1-pitch filter cuts the false colour of a
    bilinear develop by more than half."""
    assert _false_colour(1.0) < 0.5 * _false_colour("off")


def test_false_colour_on_the_dof_scenes_in_focus_checkers_drops(make_scene):
    """The bundled dof scene's planes are neutral checkers (reflectance 0.1 / 0.8 under a D65 sun), so
    every colour in the develop is false: with a 1-pitch filter the pixels of chroma above 0.1 of the
    frame's mean level (the saturated dots at the in-focus corners) drop by more than half (measured
    1 051 → 187 of 12 288 at 256 spp; at 16 spp the render's own noise makes chroma too), and the mean
    chroma with them (0.051 → 0.013)."""
    from spectral_cam import render
    from spectral_cam.isp import ISPConfig, develop

    config = make_scene(scene={"preset": "dof_targets", "depths_m": [1.0, 2.0, 4.0], "checker_px": 16},
                        lens={"focal_length_mm": 25.0, "f_number": 1.4, "focus_distance_m": 2.0},
                        sensor={"width_px": 128, "height_px": 96, **{k: v for k, v in QUIET.items()
                                                                      if k != "vignetting"}},
                        illuminant={"spd": "D65"}, render={"spp": 256, "bands": "camera", "spectral_output": False,
                                                           "diffraction": "off"})
    radiance = render(config, with_depth=False)
    chroma = {}
    for olpf in ("off", 1.0):
        raw = sc.expose(radiance, config.replace(**{"sensor.olpf": olpf}))
        rgb = develop(raw, ISPConfig(tone="linear")).linear.astype(float)
        c = (rgb.max(axis=-1) - rgb.min(axis=-1)) / rgb.mean()  # relative to the frame's mean level
        chroma[olpf] = (int(np.sum(c > 0.1)), float(c.mean()))
    assert chroma[1.0][0] < 0.5 * chroma["off"][0] and chroma[1.0][1] < chroma["off"][1]
