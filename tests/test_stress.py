"""Where methods fail (issue 6): the stress studies on tiny configurations, and the
robustness of the sensor, the ISP and the DNG reader against hostile input.

References for the expected numbers are written out here (the thin-lens CoC, the Airy
diameter, the camera equation, Lambert's law) rather than taken from the code under test.
"""

from __future__ import annotations

import json
import logging
import math
import struct
import subprocess
import sys
import warnings

import numpy as np
import pytest
import scipy.constants as const
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from spectral_cam import stress
from spectral_cam import sensor as S
from spectral_cam.errors import ConfigError, RawFormatError, SensorError, SpectralCamError
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.isp.demosaic import DEMOSAIC
from spectral_cam.raw import RawImage, read_raw, write_dng
from spectral_cam.image import SpectralImage
from spectral_cam.render import render_layered
from spectral_cam.scene import scene_from_dict

WAVELENGTHS = np.arange(400.0, 701.0, 10.0)
EDGES = np.append(WAVELENGTHS - 5.0, WAVELENGTHS[-1] + 5.0)
TINY = stress.StressSettings.quick().replace(
    square_sizes_px=(1, 2, 4, 8), zone_plate_px=128, frequency_bins=16, exposure_levels=7, flat_px=48,
    highlight_factors=(1.0, 4.0), optics_px=40, optics_spp=512, patch_px=10)


def run_cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "spectral_cam.cli", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=120)


# ============================================================================= (a) demosaic
def test_checkerboard_and_zone_plate_are_what_they_claim():
    board = stress.checkerboard(2, (4, 6))
    np.testing.assert_array_equal(board, [[1, 1, 0, 0, 1, 1], [1, 1, 0, 0, 1, 1],
                                          [0, 0, 1, 1, 0, 0], [0, 0, 1, 1, 0, 0]])
    np.testing.assert_array_equal(stress.checkerboard(2, (4, 6), offset=(1, 1))[0], [1, 0, 0, 1, 1, 0])
    plate, frequency = stress.zone_plate(64)
    assert plate.min() >= 0 and plate.max() <= 1
    # local frequency k·r rises linearly to 0.5 cycles/px at the middle of each edge
    assert frequency[32, 63] == pytest.approx(0.5 * math.hypot(31.5, 0.5) / 32)
    assert frequency[32, 32] == pytest.approx(0.5 * math.hypot(0.5, 0.5) / 32)
    with pytest.raises(ConfigError, match="square size"):
        stress.checkerboard(0, (4, 4))


def test_bilinear_fails_on_1px_squares_and_recovers_on_8px():
    """A 1-px black-and-white checkerboard puts white on every R and B site and black on
    every G site (RGGB): the mosaic is indistinguishable from a flat magenta, so every
    channel is wrong by half the white level on average and the false colour is total."""
    errors = {}
    for size in (1, 2, 4, 8):
        runs = [stress.demosaic_errors(stress.checkerboard(size, (64, 64), offset=(dy, dx)), method="bilinear")
                for dy in (0, 1) for dx in (0, 1)]
        errors[size] = (np.mean([r["mae_all"] for r in runs]), np.mean([r["false_colour"] for r in runs]))
    assert errors[1][0] == pytest.approx(0.5, abs=1e-6) and errors[1][1] == pytest.approx(1.0, abs=1e-6)
    assert errors[8][0] < 0.12 and errors[8][1] < 0.25
    assert errors[1][0] > errors[2][0] > errors[4][0] > errors[8][0]


@pytest.mark.parametrize("method", list(DEMOSAIC))
def test_every_method_is_lossless_on_constant_fields(method):
    for level in (0.0, 0.37, 1.0):
        result = stress.demosaic_errors(np.full((32, 36), level, np.float32), method=method)
        assert result["mae"].max() < 2e-3 and result["false_colour"] < 2e-3, (level, result["mae"])


def test_demosaic_study_charts_error_against_size_and_frequency(tmp_path):
    result = stress.demosaic_study(TINY, methods=["bilinear", "malvar2004"])
    data = result["data"]["methods"]
    for method, entry in data.items():
        assert entry["checker_mae"][0] == pytest.approx(0.5, abs=1e-6)  # 1-px squares
        rings = entry["zone_mae"]
        assert rings[0] < 0.01 < rings[-1]  # flat centre fine, near-Nyquist ring broken
        assert entry["zone_lossless_frequency"] > 0
        assert entry["zone_lossless_feature_px"] == pytest.approx(0.5 / entry["zone_lossless_frequency"])
    # gradient correction keeps detail lossless to a higher frequency than bilinear
    assert data["malvar2004"]["zone_lossless_frequency"] >= data["bilinear"]["zone_lossless_frequency"]
    metrics = {(r["case"], r["metric"]) for r in result["rows"]}
    assert ("bilinear", "lossless zone-plate half period") in metrics
    files = stress.plot_demosaic(result, tmp_path)
    assert all((tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for name in files)


# ============================================================================= (b) exposure
def test_electrons_per_band_radiance_is_the_camera_equation():
    """π·L/(1 + 4N_w²)·A·λ/(h·c)·η by hand (EMVA 1288 §2.1), f = 8 mm, N = 2.8, z = 2 m."""
    config = stress._mono_config(16, {}, 100.0, 0.01)
    f, n, z = 8e-3, 2.8, 2.0
    n_w = n * (1 + f / (z - f))
    expected = math.pi / (1 + 4 * n_w ** 2) * (6e-6) ** 2 * 550e-9 / (const.h * const.c) * 0.6
    assert stress.electrons_per_band_radiance(config, 550.0) == pytest.approx(expected, rel=1e-9)


def _pair_mean_electrons(config, level_e, seed, size):
    rate = stress.electrons_per_band_radiance(config, 550.0) * 0.01
    frames = [S.expose(stress._narrow_band_flat(size, level_e / rate), config, frame_seed=seed + k) for k in (0, 1)]
    darks = [S.expose(stress._narrow_band_flat(size, 0.0), config, frame_seed=seed + 10 + k) for k in (0, 1)]
    gain = frames[0].meta["K_dn_per_e"]
    signal = np.concatenate([f.mosaic.ravel() for f in frames]).astype(float)
    dark = np.concatenate([d.mosaic.ravel() for d in darks]).astype(float)
    mean = (signal.mean() - dark.mean()) / gain
    # temporal variance from each pair's difference removes the fixed patterns
    var_s = np.var(frames[0].mosaic.astype(float) - frames[1].mosaic) / 2
    var_d = np.var(darks[0].mosaic.astype(float) - darks[1].mosaic) / 2
    return mean, math.sqrt((var_s + var_d) / signal.size) / gain, frames


@pytest.mark.parametrize("level_e", [0.01, 0.1, 1.0])
def test_mean_is_unbiased_from_0_01_to_1_electron(level_e):
    """The default chain (read noise 2.5 e⁻, dark current, DSNU, PRNU, black level 256,
    K = 0.19 DN/e⁻): the read noise dithers the ADC, so the dark-subtracted mean stays
    unbiased far below one DN."""
    config = stress._mono_config(160, {}, 100.0, 0.01)
    mean, standard_error, _ = _pair_mean_electrons(config, level_e, 7, 160)
    assert abs(mean - level_e) < 4 * standard_error
    assert standard_error < 0.02


def test_without_dither_the_adc_swallows_sub_lsb_signal():
    """Documented failure: with no noise before the ADC, K = 0.19 DN/e⁻ rounds single
    electrons away (the exposure study charts it)."""
    config = stress._mono_config(64, {"read_noise_e": 0.0, "dsnu_e": 0.0, "dark_current_e_per_s": 0.0,
                                      "prnu": 0.0}, 100.0, 0.01)
    mean, _, _ = _pair_mean_electrons(config, 1.0, 3, 64)
    assert mean < 0.6


@pytest.mark.parametrize("iso, overrides, saturation_e", [
    (100.0, {"read_noise_e": 0.0, "dsnu_e": 0.0, "dark_current_e_per_s": 0.0, "prnu": 0.0}, 20000.0),
    (100.0, {}, 20000.0),
    (800.0, {}, (4095 - 256) / ((4095 - 256) / 20000.0 * 8)),  # ADC-limited: (W − B)/K
])
def test_clipping_at_saturation_is_exact(iso, overrides, saturation_e):
    config = stress._mono_config(48, overrides, iso, 0.01)
    rate = stress.electrons_per_band_radiance(config, 550.0) * 0.01
    raw = S.expose(stress._narrow_band_flat(48, 5 * saturation_e / rate), config, frame_seed=1)
    assert raw.meta["saturation_e"] == pytest.approx(saturation_e)
    assert raw.mosaic.max() == raw.white_level  # clipped, never wrapped past 16 bits
    electrons = (raw.mosaic.astype(float) - raw.black_level) / raw.meta["K_dn_per_e"]
    if overrides or iso > 100:  # no noise after the clip, or the ADC clips: every pixel at white
        assert np.all(raw.mosaic == raw.white_level)
    else:  # read noise after the full-well clip spreads ±0.5 DN below white
        assert raw.mosaic.min() >= raw.white_level - 3
        assert electrons.mean() == pytest.approx(saturation_e, rel=1e-3)


@pytest.mark.parametrize("illuminant", ["A", "D65"])
def test_no_colour_cast_in_clipped_highlights(illuminant):
    """A white reflector 4× past saturation: with highlight handling it develops neutral
    (CIELAB chroma < 1); without, the white-balance gains turn the clipped white coloured."""
    base = {"illuminant": {"spd": illuminant}, "sensor": {"width_px": 24, "height_px": 24, "vignetting": False}}
    image = stress._reflector_radiance(illuminant, 0.9, 24)
    probe = S.expose(image, scene_from_dict({**base, "exposure": {"time_s": "auto", "auto_fraction": 1.0}}))
    raw = S.expose(image, scene_from_dict({**base, "exposure": {"time_s": 4 * probe.meta["exposure_s"]}}),
                   frame_seed=2)
    chroma = {}
    for method in ("clip", "desaturate", "none"):
        linear = develop(raw, ISPConfig(highlights=method, tone="linear")).linear
        chroma[method] = stress._neutral_chroma(linear[4:-4, 4:-4].reshape(-1, 3).mean(axis=0))
    assert chroma["clip"] < 1.0 and chroma["desaturate"] < 1.0
    assert chroma["none"] > 20.0


def test_exposure_study_snr_follows_the_emva_model(tmp_path):
    result = stress.exposure_study(TINY)
    data = result["data"]
    default = data["sensors"][stress.EXPOSURE_SENSORS[0][0]]
    levels = np.asarray(data["levels_e"])
    usable = (levels >= 10) & (levels <= 0.7 * default["saturation_e"])
    ratio = np.asarray(default["snr"])[usable] / np.asarray(default["snr_model"])[usable]
    assert usable.sum() >= 2 and np.all(np.abs(ratio - 1) < 0.1)
    clipped = levels > 2 * default["saturation_e"]
    assert np.allclose(np.asarray(default["measured_e"])[clipped], default["saturation_e"], rtol=1e-3)
    assert max(data["highlights"]["A"]["chroma"]["clip"]) < 1.0
    files = stress.plot_exposure(result, tmp_path)
    assert len(files) == 3 and all((tmp_path / name).stat().st_size > 1000 for name in files)


# ============================================================================= (c) optics
def test_coc_and_diffraction_regime_numbers_against_the_formulas():
    result = stress.optics_study(TINY.replace(optics_spp=16))
    rows = {(r["case"], r["metric"]): r["value"] for r in result["rows"]}
    f, zf, pitch = 50e-3, 2.0, 6e-6
    for n in (0.95, 64.0):
        aperture = f / n
        coc_inf = aperture * f / (zf - f)  # c = A·f·|z − z_f|/(z·(z_f − f)) → A·f/(z_f − f) at z = ∞
        n_w = n * (1 + f / (zf - f))
        case = f"50 mm f/{n:g} focused at 2 m"
        assert rows[(case, "CoC diameter of a point at infinity")] == pytest.approx(coc_inf / pitch, rel=1e-9)
        assert rows[(case, "Airy diameter 2.44·λ·N_w at 550 nm")] == pytest.approx(2.44 * 550e-9 * n_w / pitch,
                                                                                    rel=1e-9)
    # small-s expansion of the diffraction MTF: 1 − MTF ≈ (4/π)·λ·N·ν_Nyquist
    limit = rows[("6-um pixels", "f-number where diffraction costs 0.03 MTF at Nyquist (700 nm)")]
    assert limit == pytest.approx(0.03 * math.pi / 4 / (700e-9 * 0.5 / pitch), rel=0.03)
    regime = np.asarray(result["data"]["regime_map"]["regime"])
    n_grid = np.asarray(result["data"]["regime_map"]["f_numbers"])
    z_grid = np.asarray(result["data"]["regime_map"]["distances_m"])
    assert n_grid[0] == pytest.approx(0.95) and n_grid[-1] == pytest.approx(64.0)
    # the map is for the default 8-mm lens focused at 2 m with 6-µm pixels
    at_focus = int(np.argmin(abs(z_grid - 2.0)))
    assert regime[at_focus, -1] == 2  # f/64 in focus: the Airy disc (87 µm) dominates
    assert regime[0, 0] == 1  # f/0.95 at 0.1 m: defocus
    assert regime[-1, 0] == 1  # f/0.95 at 1000 m: CoC A·f/(z_f − f) = 34 µm > 6 µm
    assert regime[at_focus, 0] == 0  # f/0.95 in focus: the pixel


@pytest.mark.timeout(120)
def test_rendered_blur_matches_the_thin_lens_coc():
    """Tiny Mitsuba renders of one source: the blur diameter from second moments equals
    A·f·|z − z_f|/(z·(z_f − f)) at f/0.95, at 1:2 macro focus and at 10⁶-m focus."""
    result = stress.optics_study(TINY)
    renders = {r["label"]: r for r in result["data"]["renders"]}
    for label in ("f/0.95", "focus 24 mm (1:2), f/8", "focus 1e6 m ('infinity'), f/1.4"):
        entry = renders[label]
        kwargs = dict(stress.OPTICS_RENDERS)[label]
        f = 8e-3
        aperture = f / kwargs["f_number"]
        z, zf = kwargs["source_depth_m"], kwargs["focus_distance_m"]
        expected_px = aperture * f * abs(z - zf) / (z * (zf - f)) / 6e-6
        assert entry["predicted_coc_px"] == pytest.approx(expected_px, rel=1e-9)
        assert entry["measured_coc_px"] == pytest.approx(expected_px, rel=0.03), label
    assert renders["f/64 + diffraction"]["peak_ratio_diffraction"] < 0.5


# ============================================================================= (d) bokeh
def test_disc_kernel_is_a_normalised_uniform_disc():
    kernel = stress.disc_kernel(9.0)
    assert kernel.shape == (9, 9) and kernel.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(kernel, kernel.T)
    np.testing.assert_allclose(kernel, kernel[::-1, ::-1])
    coverage = kernel / kernel.max()
    assert coverage.sum() == pytest.approx(math.pi * 4.5 ** 2, rel=0.01)  # area in pixels
    np.testing.assert_array_equal(stress.disc_kernel(0.6), [[1.0]])
    with pytest.raises(ConfigError, match="diameter"):
        stress.disc_kernel(float("nan"))


def _lens(f_mm=8.0, n=1.4, focus=0.3, width=48, pitch_um=6.0):
    from spectral_cam.optics import ThinLens

    return ThinLens(focal_length_m=f_mm * 1e-3, f_number=n, focus_distance_m=focus,
                    sensor_width_m=width * pitch_um * 1e-6, sensor_height_m=width * pitch_um * 1e-6,
                    width_px=width, height_px=width)


def test_defocus_layers_spread_a_point_into_its_coc_disc_in_every_band():
    lens = _lens()
    data = np.zeros((48, 48, 31), np.float32)
    spectrum = np.linspace(1.0, 2.0, 31, dtype=np.float32)
    data[24, 24] = spectrum
    depth = np.full((48, 48), np.inf, np.float32)
    depth[24, 24] = 3.0
    out = stress.defocus_layers(SpectralImage(data, WAVELENGTHS, EDGES, depth), lens)
    f, zf, z = 8e-3, 0.3, 3.0
    coc_px = (f / 1.4) * f * abs(z - zf) / (z * (zf - f)) / 6e-6
    kernel = stress.disc_kernel(coc_px)
    half = kernel.shape[0] // 2
    np.testing.assert_allclose(out.data[24 - half:25 + half, 24 - half:25 + half, 5], kernel * spectrum[5], atol=1e-6)
    np.testing.assert_allclose(out.data.sum(axis=(0, 1)), spectrum, rtol=1e-5)  # each band's energy kept
    assert out.meta["defocus_layers"]["layers"] == 1


def test_defocus_layers_composite_near_over_far():
    """An in-focus opaque square in front hides the far source's blur behind it."""
    lens = _lens()
    data = np.zeros((48, 48, 31), np.float32)
    depth = np.full((48, 48), np.inf, np.float32)
    data[24, 30] = 100.0
    depth[24, 30] = 3.0  # far, just right of the square: a 23-px disc over it
    data[20:28, 20:28] = 1.0
    depth[20:28, 20:28] = 0.3  # at the focus distance, in front
    out = stress.defocus_layers(SpectralImage(data, WAVELENGTHS, EDGES, depth), lens).data
    np.testing.assert_allclose(out[20:28, 20:28], 1.0, atol=1e-6)  # the square, sharp and opaque
    assert out[24, 38, 0] > 0.1 and out[30, 24, 0] > 0.1  # the far blur around it
    with pytest.raises(ConfigError, match="depth map"):
        stress.defocus_layers(SpectralImage(data, WAVELENGTHS, EDGES), lens)
    with pytest.raises(ConfigError, match="coc_ratio"):
        stress.defocus_layers(SpectralImage(data, WAVELENGTHS, EDGES, depth), lens, coc_ratio=1.0)


BOKEH_TEST = dict(width_px=24, pixel_pitch_um=12.0, focal_length_mm=8.0, f_number=1.4, focus_distance_m=0.3,
                  source_depth_m=3.0, source_radius_m=0.002)


@pytest.fixture(scope="module")
def bokeh_renders():
    from spectral_cam.render import render

    thin = {seed: render(stress.bokeh_scene(model="thin", spp=spp, seed=seed, **BOKEH_TEST), with_depth=False)
            for seed, spp in ((11, 8192), (12, 8192), (13, 1024))}
    remedy = render_layered(stress.bokeh_scene(model="pinhole", spp=128, seed=14, **BOKEH_TEST))
    return thin, remedy


@pytest.mark.timeout(120)
def test_bokeh_remedy_beats_thin_lens_rendering_at_equal_time(bokeh_renders):
    """A 0.9-px source blurred into a 12-px disc: the pinhole render + depth-layered disc
    PSF (128 spp, about 0.2 M camera samples with its margin and depth) is closer to a
    16384-spp thin-lens reference than thin-lens rendering with 1024 spp (0.6 M samples)."""
    thin, remedy = bokeh_renders
    config = stress.bokeh_scene(model="thin", **BOKEH_TEST)
    p = stress.aperture_fraction(config)
    coc = _lens(width=24, pitch_um=12.0).coc_diameter_px(3.0)
    disc = stress._disc_mask(24, coc)
    reference = 0.5 * (stress._band_sum(thin[11]) + stress._band_sum(thin[12]))
    plain = stress._band_sum(thin[13])
    fixed = stress._band_sum(remedy)
    # the thin-lens per-pixel noise is the binomial one of seeing the source through p of the aperture
    noise = plain[disc].std() / plain[disc].mean()
    assert noise == pytest.approx(math.sqrt((1 - p) / (p * 1024)), rel=0.25)
    error_plain = math.sqrt(np.mean((plain[disc] - reference[disc]) ** 2)) / reference[disc].mean()
    error_fixed = math.sqrt(np.mean((fixed[disc] - reference[disc]) ** 2)) / reference[disc].mean()
    assert error_fixed < 0.5 * error_plain
    assert fixed[disc].mean() == pytest.approx(reference[disc].mean(), rel=0.15)
    assert fixed.sum() == pytest.approx(reference.sum(), rel=0.15)  # the source's flux, all bands
    assert remedy.data.shape == (24, 24, 31) and np.all(np.isfinite(remedy.data)) and remedy.data.min() >= 0


def test_remedy_records_its_decision_and_refuses_bad_options(bokeh_renders):
    _, remedy = bokeh_renders
    decision = remedy.meta["model_decisions"]["defocus"]
    assert decision["choice"] == "depth_layered_disc_psf" and decision["margin_px"] >= 6
    assert {"pinhole_render", "depth", "defocus_layers"} <= set(remedy.meta["timings_s"])
    config = stress.bokeh_scene(model="pinhole", spp=1, **BOKEH_TEST)
    with pytest.raises(ConfigError, match="margin_px"):
        render_layered(config, margin_px=-1)
    with pytest.raises(ConfigError, match="supersample"):
        stress.nearest_depth(config, supersample=0)


# ============================================================================= (e) illuminants
def test_chart_radiance_is_lambertian():
    from spectral_cam import spectra

    image, interiors = stress.chart_radiance("A", patch_px=8)
    assert image.data.shape == (32, 48, 31) and len(interiors) == 24
    wl, irradiance = spectra.absolute_irradiance("A", 1000.0)
    white = spectra.colorchecker_reflectances()["white 9.5 (.05 D)"]
    rho = np.interp(wl, np.asarray(white.wavelengths), np.asarray(white.values))
    expected = spectra.band_integrals(rho * irradiance / np.pi, wl, spectra.parse_bands("400:700:10"))
    np.testing.assert_allclose(image.data[interiors[stress.WHITE_INDEX]][0, 0], expected, rtol=1e-5)


def test_narrow_band_led_csv(tmp_path):
    from spectral_cam import spectra

    path = stress.write_narrow_band_led(tmp_path / "led.csv")
    sd = spectra.illuminant(str(path))
    wl, values = np.asarray(sd.wavelengths), np.asarray(sd.values)
    for peak in stress.NARROW_LED_PEAKS_NM:
        window = np.abs(wl - peak) < 20
        above = wl[window][values[window] >= 0.5 * values[window].max()]
        assert above.max() - above.min() == pytest.approx(stress.NARROW_LED_FWHM_NM, abs=1.5)


def test_delta_e_of_the_white_balance_choices_far_from_d65(tmp_path):
    result = stress.illuminant_study(TINY, illuminants=["D65", "A", str(stress.write_narrow_band_led(
        tmp_path / "led.csv"))])
    data = result["data"]["illuminants"]
    d65, tungsten = data["D65"]["results"], data["A"]["results"]
    assert d65["fitted/as_shot"]["mean"] < 2.0 and d65["dng/as_shot"]["mean"] < 2.0
    for results in data.values():  # a ColorChecker does not average to grey
        assert results["results"]["fitted/grey_world"]["mean"] > 2 * results["results"]["fitted/as_shot"]["mean"]
    # the D65-calibrated DNG matrix alone degrades under tungsten; the matrix fitted under A,
    # or ColorMatrix2 (A) interpolated by the white's colour temperature, does not
    assert tungsten["dng_d65/as_shot"]["mean"] > 1.5 * tungsten["fitted/as_shot"]["mean"]
    assert tungsten["dng/as_shot"]["mean"] < 1.2 * tungsten["fitted/as_shot"]["mean"]
    assert len(result["rows"]) == 3 * len(stress.STUDY_COLOUR_MATRICES) * len(stress.STUDY_WHITE_BALANCE)


# ============================================================================= command line
@pytest.mark.timeout(120)
def test_stress_cli_writes_charts_and_summary_and_never_overwrites(tmp_path):
    out = tmp_path / "stress"
    result = run_cli("stress", "-o", str(out), "--quick", "--only", "illuminants")
    assert result.returncode == 0, result.stderr
    names = {p.name for p in out.iterdir()}
    assert {"illuminants_delta_e.png", "summary.csv", "summary.png", "results.json"} <= names
    summary = (out / "summary.csv").read_text().splitlines()
    assert summary[0] == "study,case,metric,value,unit,note" and len(summary) > 30
    results = json.loads((out / "results.json").read_text())
    assert set(results["studies"]) == {"illuminants"} and results["timings_s"]["illuminants"] > 0
    again = run_cli("stress", "-o", str(out), "--quick", "--only", "illuminants")
    assert again.returncode == 2 and "--force" in again.stderr and "Traceback" not in again.stderr
    blocked = run_cli("stress", "-o", str(out / "summary.csv" / "x"), "--quick", "--only", "illuminants")
    assert blocked.returncode == 2 and "cannot write" in blocked.stderr and "Traceback" not in blocked.stderr
    assert not [p for p in tmp_path.rglob(".*partial*")]


# ============================================================================= robustness: sensor
def _image(data, wavelengths=WAVELENGTHS, edges=EDGES):
    return SpectralImage(data, wavelengths, edges)


def _sensor_config(size=16, **exposure):
    return scene_from_dict({"sensor": {"width_px": size, "height_px": size},
                            "exposure": {"time_s": 0.01, **exposure}})


GOOD = np.full((16, 16, 31), 0.01, np.float32)


@pytest.mark.parametrize("data, message", [
    (GOOD.astype(np.int32), "float32 or float64, not int32"),
    ((GOOD * 1000).astype(np.uint16), "float32 or float64, not uint16"),
    (GOOD.astype(np.complex128), "float32 or float64, not complex128"),
    (GOOD > 0, "float32 or float64, not bool"),
    (GOOD.astype(object), "float32 or float64, not object"),
    (GOOD.tolist(), r"\(H, W, B\)"),
    (GOOD[None], r"\(H, W, B\)"),
    (np.zeros((0, 0, 31), np.float32), "0×0 pixels but the sensor is 16×16"),
], ids=["int32", "uint16", "complex", "bool", "object", "list", "4-D", "zero-size"])
def test_expose_rejects_wrong_dtypes_and_shapes(data, message):
    with pytest.raises(SensorError, match=message):
        S.expose(_image(data), _sensor_config())


def test_expose_rejects_bad_wavelength_grids():
    with pytest.raises(SensorError, match="no bands"):
        S.expose(_image(np.zeros((16, 16, 0), np.float32), np.array([]), np.array([400.0])), _sensor_config())
    with pytest.raises(SensorError, match="finite, positive band centres"):
        S.expose(_image(GOOD, np.where(WAVELENGTHS == 500, np.nan, WAVELENGTHS)), _sensor_config())
    with pytest.raises(SensorError, match="increasing band edges"):
        S.expose(_image(GOOD, WAVELENGTHS, EDGES[::-1]), _sensor_config())


@pytest.mark.parametrize("value", [-np.inf, np.nan])
def test_expose_finds_bad_values_in_any_chunk_and_with_auto_exposure(value):
    data = np.full((600, 200, 31), 0.01, np.float32)  # several row chunks
    data[517, 123, 29] = value
    for exposure in ({}, {"time_s": "auto"}):
        with pytest.raises(SensorError, match=r"row 517, column 123\), band 29"):
            S.expose(_image(data), scene_from_dict({"sensor": {"width_px": 200, "height_px": 600},
                                                    "exposure": {"time_s": 0.01, **exposure}}))


@pytest.mark.parametrize("method", S.SHOT_NOISE_METHODS)
@pytest.mark.parametrize("radiance", [1e25, 1e33])
def test_absurdly_bright_finite_radiance_saturates_or_is_a_clear_error(method, radiance):
    """Finite, non-negative radiance is valid input however bright: the frame saturates
    (or a SensorError explains the overflow) — never an IndexError or a NumPy ValueError."""
    try:
        raw = S.expose(_image(np.full((16, 16, 31), radiance, np.float32)), _sensor_config(),
                       shot_noise_method=method)
    except SensorError as exc:
        assert "radiance" in str(exc)
        return
    assert raw.mosaic.min() >= raw.white_level - 3 and raw.mosaic.max() == raw.white_level


@settings(max_examples=60, deadline=None)
@given(st.floats(allow_nan=True, allow_infinity=True, width=32), st.integers(0, 7), st.integers(0, 7),
       st.integers(0, 30), st.sampled_from(S.SHOT_NOISE_METHODS))
def test_any_single_radiance_value_gives_a_frame_or_a_sensor_error(value, row, col, band, method):
    data = np.full((8, 8, 31), 0.02, np.float32)
    data[row, col, band] = value
    try:
        raw = S.expose(_image(data), _sensor_config(8), shot_noise_method=method)
    except SensorError as exc:
        assert not (math.isfinite(value) and value >= 0) or "radiance" in str(exc)
        if not math.isfinite(value) or value < 0:
            assert f"row {row}, column {col}" in str(exc)
        return
    assert math.isfinite(value) and value >= 0
    assert raw.mosaic.dtype == np.uint16 and raw.mosaic.shape == (8, 8) and raw.mosaic.max() <= raw.white_level


# ============================================================================= robustness: ISP
def _raw(mosaic, cfa="RGGB"):
    return RawImage(mosaic, cfa, 256, 4095, as_shot_neutral=np.array([0.5, 1.0, 0.7]))


@pytest.mark.parametrize("shape", [(0, 0), (0, 8), (1, 8), (8, 1)])
def test_develop_refuses_mosaics_too_small_for_a_bayer_tile(shape):
    for balance in ("as_shot", "grey_world"):
        with pytest.raises(ConfigError):
            develop(_raw(np.full(shape, 1000, np.uint16)), ISPConfig(white_balance=balance))


@pytest.mark.parametrize("shape", [(2, 2), (3, 5), (7, 9), (31, 45)])
@pytest.mark.parametrize("method", list(DEMOSAIC))
def test_develop_odd_sizes_give_finite_images_of_that_size(shape, method):
    rng = np.random.default_rng(sum(shape))
    out = develop(_raw(rng.integers(300, 4000, shape).astype(np.uint16)), ISPConfig(demosaic=method))
    assert out.image.shape == shape + (3,) and np.all(np.isfinite(out.image))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_develop_never_returns_a_silent_nan_image(bad):
    """A float mosaic holding a NaN or an infinity: a clear error (or a documented, warned
    sanitisation) — not a NaN image."""
    mosaic = np.full((16, 16), 1000.0)
    mosaic[5, 7] = bad
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            out = develop(_raw(mosaic), ISPConfig())
        except SpectralCamError as exc:
            assert "finite" in str(exc) or "NaN" in str(exc)
            return
    assert any(issubclass(w.category, UserWarning) for w in caught), "sanitised without a warning"
    assert np.all(np.isfinite(out.image)) and np.all(np.isfinite(out.linear))


@pytest.mark.parametrize("mosaic", [
    np.full((8, 8), 1000 + 5j),
    np.array([[None] * 8] * 8),
    np.array([["1000"] * 8] * 8),
], ids=["complex", "object", "str"])
def test_develop_rejects_non_numeric_mosaics(mosaic):
    with pytest.raises(SpectralCamError, match="dtype|number"):
        develop(_raw(mosaic), ISPConfig())


# ============================================================================= robustness: DNG
@pytest.fixture(scope="module")
def good_dng(tmp_path_factory):
    rng = np.random.default_rng(0)
    raw = RawImage(rng.integers(300, 4000, (32, 40)).astype(np.uint16), "RGGB", 256, 4095,
                   color_matrix=np.array([[0.9, 0.2, -0.1], [-0.3, 1.2, 0.1], [0.05, -0.2, 0.9]]),
                   as_shot_neutral=np.array([0.5, 1.0, 0.7]), noise_profile=(1e-4, 1e-7), camera_model="fuzz")
    return write_dng(raw, tmp_path_factory.mktemp("dng") / "good.dng").read_bytes()


def _tag_entry_offset(data: bytes, code: int) -> int:
    """Byte offset of a tag's 12-byte entry in the first IFD of a little-endian TIFF."""
    assert data[:2] == b"II"
    ifd = struct.unpack_from("<I", data, 4)[0]
    for index in range(struct.unpack_from("<H", data, ifd)[0]):
        offset = ifd + 2 + 12 * index
        if struct.unpack_from("<H", data, offset)[0] == code:
            return offset
    raise KeyError(code)


def _without_cfa_pattern(data: bytes) -> bytes:
    out = bytearray(data)
    struct.pack_into("<H", out, _tag_entry_offset(data, 33422), 33423)  # CFAPattern → an unknown tag
    return bytes(out)


def _black_above_white(data: bytes) -> bytes:
    out = bytearray(data)
    struct.pack_into("<I", out, _tag_entry_offset(data, 50714) + 8, 5000)  # BlackLevel 5000 > WhiteLevel 4095
    return bytes(out)


def test_dng_without_its_cfa_pattern_is_a_raw_format_error(tmp_path, good_dng):
    path = tmp_path / "nocfa.dng"
    path.write_bytes(_without_cfa_pattern(good_dng))
    with pytest.raises(RawFormatError):
        read_raw(path)


@pytest.mark.parametrize("shape", [(16, 16), (21, 23), (22, 22), (23, 25)])
def test_small_and_odd_dngs_round_trip_or_say_why_not(tmp_path, shape):
    """LibRaw refuses raws narrower than 22 pixels; a DNG that write_dng accepted must read
    back, or fail with a message that says so."""
    mosaic = np.random.default_rng(1).integers(300, 4000, shape).astype(np.uint16)
    path = write_dng(_raw(mosaic), tmp_path / "small.dng")
    try:
        back = read_raw(path)
    except RawFormatError as exc:
        assert "22" in str(exc), str(exc)
        return
    np.testing.assert_array_equal(back.mosaic, mosaic)


@pytest.mark.parametrize("case", ["text", "empty", "truncated", "no_cfa_pattern", "black_above_white"])
def test_develop_cli_on_bad_dngs_exits_2_without_output(tmp_path, good_dng, case, capsys):
    from spectral_cam.cli import main

    payload = {
        "text": b"this is not a raw file",
        "empty": b"",
        "truncated": good_dng[: len(good_dng) // 2],
        "no_cfa_pattern": _without_cfa_pattern(good_dng),
        "black_above_white": _black_above_white(good_dng),
    }[case]
    bad = tmp_path / "bad.dng"
    bad.write_bytes(payload)
    out = tmp_path / "x.png"
    logging.disable(logging.CRITICAL)  # tifffile logs the tags it cannot parse
    try:
        status = main(["develop", str(bad), "-o", str(out)])
    finally:
        logging.disable(logging.NOTSET)
    assert status == 2
    assert capsys.readouterr().err.startswith("spectral-cam: error: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.dng"]


def test_develop_cli_truncated_dng_has_no_traceback(tmp_path, good_dng):
    bad = tmp_path / "bad.dng"
    bad.write_bytes(good_dng[: len(good_dng) // 3])
    result = run_cli("develop", str(bad), "-o", str(tmp_path / "x.png"))
    assert result.returncode == 2
    assert "spectral-cam: error:" in result.stderr and "not a readable raw file" in result.stderr
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "x.png").exists()


def test_develop_cli_unwritable_output_is_a_clear_error(tmp_path, good_dng):
    good = tmp_path / "good.dng"
    good.write_bytes(good_dng)
    result = run_cli("develop", str(good), "-o", str(good / "x.png"))  # a file's child
    assert result.returncode == 2 and "Traceback" not in result.stderr


def _mutations():
    flips = st.lists(st.tuples(st.integers(0, 599), st.integers(0, 255)), min_size=1, max_size=6)
    return st.one_of(st.tuples(st.just("flip"), flips), st.tuples(st.just("cut"), st.floats(0.0, 0.999)))


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(_mutations())
def test_mutated_dngs_read_or_raise_raw_format_error_and_never_develop_to_nan(tmp_path, good_dng, mutation):
    kind, detail = mutation
    data = bytearray(good_dng)
    if kind == "cut":
        data = data[: int(detail * len(data))]
    else:
        for position, value in detail:
            data[position % len(data)] = value
    path = tmp_path / "fuzz.dng"
    path.write_bytes(bytes(data))
    logging.disable(logging.CRITICAL)
    try:
        try:
            raw = read_raw(path)
        except RawFormatError as exc:
            assert str(exc)
            return
        assert raw.mosaic.ndim == 2 and raw.mosaic.size > 0 and raw.mosaic.dtype == np.uint16
        assert raw.cfa in ("RGGB", "BGGR", "GRBG", "GBRG", "none")
        balance = "as_shot" if raw.as_shot_neutral is not None else "grey_world"
        try:
            out = develop(raw, ISPConfig(white_balance=balance))
        except SpectralCamError as exc:
            assert str(exc)
            return
        assert np.all(np.isfinite(out.image))
    finally:
        logging.disable(logging.NOTSET)
