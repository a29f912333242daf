"""Issue 29 #1: the optical low-pass filter. The slanted-edge MTF (ISO 12233) of a noise-free
monochrome capture equals the pixel aperture's sinc times the filter's |cos(π f d)| up to Nyquist;
the camera table follows the makers' specifications; false colour on a Bayer capture of fine
detail drops with the filter; bad settings are refused with what would be valid.

Issue 39 #22: a fractional separation is a non-negative kernel (the displaced spot shared by area
between the two pixels it straddles), never a ringing Fourier shift: no light below black on any
sensor kind, the sum kept, its MTF within the area-weighting's own error of |cos(π f d)|; a separation
beyond the rendered crop margin is refused with the margin that would fit, and 29.99 µm and 30 µm
give nearly the same frame."""

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


def _two_tap_mtf(freqs, separation):
    """|½(1 + (1 − φ)e^(−2πifk) + φe^(−2πif(k+1)))|, d = k + φ: the two-spot split with the displaced
    spot's light shared by overlap area between the pixels it straddles (a pixel's light taken as
    even over the pixel)."""
    k = np.floor(separation)
    phi = separation - k
    shifted = (1 - phi) * np.exp(-2j * np.pi * freqs * k) + phi * np.exp(-2j * np.pi * freqs * (k + 1))
    return np.abs(0.5 * (1 + shifted))


@pytest.mark.parametrize("separation", [0.0, 1.0, 0.6, 1.5])
def test_the_slanted_edge_mtf_is_the_pixel_sinc_times_the_filters_transfer(separation):
    """MTF(f) = |sinc(f)|·|H(f)| within 0.02 up to the Nyquist frequency (0.5 cycle per pixel), the
    reference analytic (the box pixel aperture and the two plates): H = cos(π f d) for no filter and
    d = 1 pitch (whole-pixel shifts, exact: zero at Nyquist); for d = 0.6 and 1.5 pitch the area-shared
    split's transfer (its displaced spot between two pixels), which only a supersampled render could
    make |cos(π f d)| (docs/design.md)."""
    image = _capture(_slanted_edge(), separation)
    freqs, mtf = slanted_edge_mtf(image)
    upto = freqs <= 0.5 + 1e-9
    expected = np.abs(np.sinc(freqs[upto])) * _two_tap_mtf(freqs[upto], separation)
    if float(separation).is_integer():
        np.testing.assert_allclose(expected, np.abs(np.sinc(freqs[upto]) * np.cos(np.pi * freqs[upto] * separation)),
                                   atol=1e-12)
    np.testing.assert_allclose(mtf[upto], expected, atol=0.02)


@pytest.mark.parametrize("separation", [0.5, 1.0, 1.5, 2.0, 3.7])
def test_the_kernels_mtf_is_the_two_spot_cosine_within_the_area_sharing_error(separation):
    """A sinusoid of f cycles per pixel through the filter (one axis) keeps |H(f)| of its amplitude.
    Whole-pixel d: |cos(π f d)| to 1e-9, the two-spot split's analytic MTF. Fractional d: off it by no
    more than half the area-shared shift's error |(1 − φ)e^(−2πifk) + φe^(−2πif(k+1)) − e^(−2πifd)|
    (0.024 at f = 0.1 for d = 0.5), and never above 1 (no gain)."""
    n = 512
    x = np.arange(n)
    for f in np.arange(1, 33) / 64.0:  # whole cycles over the row: periodic; read away from the edge
        row = 1.0 + 0.5 * np.cos(2 * np.pi * f * x)
        out = apply_olpf(np.tile(row, (3, 1)), separation)[1]  # rows equal: the vertical plate keeps them
        inner = slice(16, n - 16)
        fit = np.linalg.lstsq(np.stack([np.ones(n), np.cos(2 * np.pi * f * x), np.sin(2 * np.pi * f * x)], 1)[inner],
                              out[inner], rcond=None)[0]
        measured = np.hypot(fit[1], fit[2]) / 0.5
        ideal = abs(np.cos(np.pi * f * separation))
        k, phi = np.floor(separation), separation - np.floor(separation)
        error = 0.5 * abs((1 - phi) * np.exp(-2j * np.pi * f * k) + phi * np.exp(-2j * np.pi * f * (k + 1))
                          - np.exp(-2j * np.pi * f * separation))
        assert measured <= 1 + 1e-9
        assert abs(measured - ideal) <= error + 1e-9, (f, measured, ideal)
        if phi == 0:
            assert measured == pytest.approx(ideal, abs=1e-9)


@pytest.mark.parametrize("separation", [0.5, 1.5, 3.7])
def test_a_point_becomes_four_non_negative_spots_holding_its_light(separation):
    """A point far from the edges: per axis ½ stays, ½ moves d = k + φ and is shared (1 − φ) at k and φ
    at k + 1 (the overlap of a pixel-wide beam displaced by d); the 2-D spot is their outer product,
    non-negative, summing to the point's power (1 to 1e-6)."""
    plane = np.zeros((24, 24), np.float32)
    plane[6, 6] = 1.0
    out = apply_olpf(plane, separation)
    k, phi = int(np.floor(separation)), separation - np.floor(separation)
    taps = np.zeros(6)
    taps[0] += 0.5
    taps[k] += 0.5 * (1 - phi)
    taps[k + 1] += 0.5 * phi
    expected = np.zeros_like(out)
    expected[6:12, 6:12] = np.outer(taps, taps)
    np.testing.assert_allclose(out, expected, atol=1e-7)
    assert out.min() >= 0 and out.sum() == pytest.approx(1.0, abs=1e-6)


def _dark_surround_radiance(h: int = 48, w: int = 48, bands=(550.0,), edges=(545.0, 555.0)) -> SpectralImage:
    """Bright bars and a point on black (``scene.surround = 0``): where a Fourier shift rings."""
    data = np.zeros((h, w, len(bands)), np.float32)
    data[10:30, 12:20] = 0.05
    data[35, 35] = 0.08  # below the 16-bit range's clip, so the sum can be compared
    data[20:22, 30:44] = 0.02
    return SpectralImage(data, tuple(bands), tuple(edges))


@pytest.mark.parametrize("separation", [0.5, 1.5, 3.7])
def test_a_fractional_filter_never_makes_light_below_black(separation):
    """Noise-free (shot noise off), a dark field with bright bars: no pixel below the black level
    (the Fourier shift put 35-38 % more than 5 DN below it), and the frame's light is the unfiltered
    frame's within the edges' share."""
    radiance = _dark_surround_radiance()
    raws = {}
    for olpf in (0.0, separation):
        scene = sc.scene_from_dict({"sensor": {"width_px": 48, "height_px": 48, "model": "ideal", "cfa": "none",
                                               "bit_depth": 16, "olpf": olpf, **QUIET},
                                    "exposure": {"time_s": 0.02}})
        raw = sc.expose(radiance, scene)
        raws[olpf] = raw.mosaic.astype(float) - raw.black_level
    assert raws[separation].min() >= 0
    assert raws[separation].sum() == pytest.approx(raws[0.0].sum(), rel=2e-3)


def test_single_photon_and_event_sensors_take_a_fractional_filter():
    """A QIS (binomial jots need rates >= 0: the Fourier shift raised "lam < 0") and an event sensor
    (log intensity: NaN below zero) expose a dark-surround scene through a 1.5-pitch filter."""
    from spectral_cam.sensor.events import log_intensity

    radiance = _dark_surround_radiance(bands=(450.0, 550.0, 650.0), edges=(400.0, 500.0, 600.0, 700.0))
    qis = sc.scene_from_dict({"sensor": {"width_px": 48, "height_px": 48, "olpf": 1.5, "kind": "qis",
                                         "jot_frames": 4}, "exposure": {"time_s": 0.02}})
    capture = sc.expose_photon_counting(radiance, qis)
    assert capture is not None
    event = sc.scene_from_dict({"sensor": {"width_px": 48, "height_px": 48, "olpf": 1.5, "kind": "event",
                                           "dark_current_e_per_s": 0.0}})
    assert np.all(np.isfinite(log_intensity(radiance, event)))


def test_a_separation_beyond_the_crop_margin_is_refused_with_the_margin_that_fits():
    """30 µm at 1 µm pitch reads 30 px beyond the frame: with the 8-px margin it is refused, naming
    crop_margin_px = 30 and the 8 µm that would fit; an odd need rounds to the even margin above."""
    sensor = {"pixel_pitch_um": 1.0, "olpf": "30 um"}
    with pytest.raises(ConfigError, match=r"crop_margin_px = 30.*at most 8 px \(8 µm"):
        sc.scene_from_dict({"sensor": sensor})
    with pytest.raises(ConfigError, match="crop_margin_px = 4"):  # 2.5 px reads 3 px out: the even 4
        sc.scene_from_dict({"sensor": {"olpf": 2.5, "crop_margin_px": 2}})
    with pytest.raises(ConfigError, match="crop_margin_px = 2"):
        sc.scene_from_dict({"sensor": {"olpf": "camera", "model": "sony_ilce_7m3", "crop_margin_px": 0}})
    sc.scene_from_dict({"sensor": {**sensor, "crop_margin_px": 30}})
    sc.scene_from_dict({"sensor": {"olpf": "camera", "model": "nikon_d850", "crop_margin_px": 0}})  # none: fits


def test_29_99_and_30_um_give_nearly_the_same_frame():
    """At 1 µm pitch with a 30-px crop margin of real pixels (a textured surround, as a render gives),
    29.99 µm and 30 µm move the frame's mean by < 0.1 % and no pixel by more than 1 % of the signal
    (the Fourier shift's padding moved the frame 11-19 %); the filtered frame holds the unfiltered
    frame's light within 3 % (what the margin moves in and the edges move out)."""
    margin, size = 30, 32
    full = size + 2 * margin
    yy, xx = np.indices((full, full))
    texture = 0.02 + 0.015 * np.sin(xx / 3.1) * np.cos(yy / 4.3) + 0.01 * ((xx // 5 + yy // 7) % 2)
    radiance = SpectralImage(texture[..., None].astype(np.float32), (550.0,), (545.0, 555.0),
                             frame=(margin, margin, size, size))
    frames = {}
    for olpf in ("off", "29.99 um", "30 um"):
        scene = sc.scene_from_dict({"sensor": {"width_px": size, "height_px": size, "model": "ideal", "cfa": "none",
                                               "bit_depth": 16, "pixel_pitch_um": 1.0, "crop_margin_px": margin,
                                               "olpf": olpf, **QUIET}, "exposure": {"time_s": 0.02}})
        raw = sc.expose(radiance, scene)
        top, left, h, w = raw.crop
        frames[olpf] = raw.mosaic[top:top + h, left:left + w].astype(float) - raw.black_level
    a, b = frames["29.99 um"], frames["30 um"]
    assert abs(a.mean() / b.mean() - 1) < 1e-3
    assert np.abs(a - b).max() < 0.01 * b.mean()
    assert b.mean() == pytest.approx(frames["off"].mean(), rel=0.03)


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
