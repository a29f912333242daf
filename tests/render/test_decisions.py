"""Issue 5's "model no more than a scene needs" policies, checked against independent
references: sensor noise from the EMVA 1288 model, the band-integral camera response, and
the diffraction-limited MTF (Goodman §6.3) times the pixel aperture."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam import render, scene_from_dict
from spectral_cam.metrics import slanted_edge_mtf
from spectral_cam.optics import ThinLens, diffraction_mtf
from spectral_cam.sensor import expected_electrons, signal_model
from spectral_cam.spectra import absolute_irradiance, band_integrals, parse_bands


def flat_scene(lux, **render_keys):
    return scene_from_dict({
        "scene": {"preset": "flat_field", "distance_m": 1.0},
        "illuminant": {"spd": "D65", "illuminance_lux": lux},
        "lens": {"model": "pinhole"},
        "sensor": {"width_px": 128, "height_px": 96, "vignetting": False},
        "exposure": {"time_s": 0.002},
        "render": {"spp": "auto", "max_spp": 4096, "diffraction": "off", **render_keys},
    })


@pytest.mark.timeout(300)
def test_auto_spp_stops_earlier_when_dim_and_meets_the_noise_target():
    dim = render(flat_scene(100.0), with_depth=False)
    bright_scene = flat_scene(1000.0)
    bright = render(bright_scene, with_depth=False)
    assert dim.meta["spp"] < bright.meta["spp"] < 4096
    assert "converged" in bright.meta["model_decisions"]["spp"]["reason"]

    # pooled over all 12 288 pixels, from two independent renders at the spp reached:
    # var(A − B)/2 is the Monte-Carlo variance of one render
    again = render(bright_scene.replace(**{"render.seed": 99}), with_depth=False)
    assert again.meta["spp"] == pytest.approx(bright.meta["spp"], rel=0.5)
    a, t = expected_electrons(bright, bright_scene)
    b, _ = expected_electrons(again, bright_scene)
    sensor = bright_scene.sensor
    sigma_d2 = sensor.read_noise_e ** 2 + sensor.dark_current_e_per_s * t  # EMVA 1288 dark noise
    mc_variance = np.mean((a.astype(float) - b) ** 2) / 2
    sensor_variance = np.mean((a.astype(float) + b) / 2) + sigma_d2
    assert a.size >= 10_000
    assert np.sqrt(mc_variance / sensor_variance) <= 0.36


@pytest.mark.timeout(300)
def test_camera_film_and_31_bands_agree_within_1_percent_on_a_d65_colorchecker():
    base = {
        "scene": {"preset": "colorchecker", "fill": 1.0, "gap": 0.0},
        "lens": {"model": "pinhole"},
        "sensor": {"width_px": 6, "height_px": 4, "pixel_pitch_um": 500.0, "vignetting": False},
        "exposure": {"time_s": 1e-6},
        "render": {"spp": 1 << 19, "max_depth": 2, "diffraction": "off"},
    }
    electrons = {}
    for bands, spectral in (("camera", False), ("400:700:10", True)):
        config = scene_from_dict(base, overrides={"render.bands": bands, "render.spectral_output": spectral})
        image = render(config, with_depth=False)
        assert (image.channels is not None) == (bands == "camera")
        electrons[bands], _ = expected_electrons(image, config)
    ratio = electrons["camera"] / electrons["400:700:10"]
    assert np.all(np.abs(ratio - 1) < 0.01), np.round((ratio - 1) * 100, 2)


def test_bands_auto_picks_the_camera_film_only_when_nothing_needs_the_spectrum():
    from spectral_cam.render.decisions import decide_bands

    def decide(**render_keys):
        return decide_bands(scene_from_dict({"render": render_keys}), False)

    assert decide(spectral_output=False) [0] is True
    assert decide(spectral_output=True)[0] is False
    assert decide_bands(scene_from_dict({"render": {"spectral_output": False}}), True)[0] is False  # diffraction
    assert decide(bands="400:700:20", spectral_output=False)[0] is False


@pytest.mark.timeout(300)
def test_partial_diffraction_mtf_per_channel_matches_the_weighted_airy_mtf():
    config = scene_from_dict({
        "scene": {"preset": "slanted_edge", "distance_m": 2.0, "edge_angle_deg": 5.0},
        "illuminant": {"spd": "D65"},
        "lens": {"focal_length_mm": 25.0, "f_number": 4.0, "focus_distance_m": 2.0, "model": "pinhole"},
        "sensor": {"width_px": 96, "height_px": 128, "pixel_pitch_um": 4.0, "vignetting": False},
        "render": {"spp": 2048, "diffraction": "auto"},
    })
    image = render(config, with_depth=False)
    decision = image.meta["model_decisions"]["diffraction"]
    assert decision["choice"] == "airy_psf_per_band" and 0.03 < decision["mtf_cost_at_nyquist"] < 0.9

    weights = signal_model(image, config).weights  # (B, 3) electrons per band radiance
    channels = image.data.astype(np.float64) @ weights  # full-resolution channel images, before the CFA
    lens = ThinLens.from_config(config.lens, config.sensor)
    bands = parse_bands(config.render.bands if config.render.bands != "auto" else "400:700:10")
    wl, irradiance = absolute_irradiance("D65", 1.0)
    # the edge's contrast per band is (ρ_bright − ρ_dark)·E_b/π: weight each band's Airy MTF
    # by the electrons it gives each channel
    contrast = band_integrals(irradiance, wl, bands)[:, None] * weights
    pitch = config.sensor.pixel_pitch_um * 1e-6
    for c in range(3):
        freqs, measured = slanted_edge_mtf(channels[8:-8, 8:-8, c])
        nyquist = freqs <= 0.5
        per_band = np.stack([diffraction_mtf(freqs / pitch, w, lens.working_f_number) for w in bands.centres_nm])
        expected = (contrast[:, c] @ per_band) / contrast[:, c].sum() * np.abs(np.sinc(freqs))
        error = np.abs(measured[nyquist] - expected[nyquist])
        print(f"channel {c}: max |MTF error| up to Nyquist {error.max():.3f}")
        assert error.max() < 0.05, f"channel {c}"


def _small_source(**lens):
    # one 6.5-mm emitter at 3 m (a disc of ~3 px radius through a pinhole), focus 0.3 m, f/1.4:
    # a 23-px blur disc, seen through ~7 % of the aperture
    return scene_from_dict({
        "scene": {"preset": "point_sources", "depths_m": [3.0], "source_radius_m": 0.0065},
        "lens": {"focal_length_mm": 8.0, "f_number": 1.4, "focus_distance_m": 0.3, **lens},
        "sensor": {"width_px": 40, "height_px": 40, "pixel_pitch_um": 6.0},
        "render": {"spp": 64, "diffraction": "off"},
    })


@pytest.mark.timeout(120)
def test_auto_lens_model_picks_the_layered_model_for_a_small_source_far_out_of_focus():
    from spectral_cam.render.layered import aperture_fraction

    config = _small_source()
    image = render(config, with_depth=True)
    decision = image.meta["model_decisions"]["lens_model"]
    assert decision["choice"] == "layered" and image.meta["lens_model"] == "layered"
    assert "defocus" in image.meta["model_decisions"]
    # the thin-lens noise estimate against the aperture fraction p = (r·z_f/(|z − z_f|·R))²
    # of the thin-lens ray geometry (PBRT 4th ed. §5.2.3): relative noise √((1 − p)/(p·spp))
    p = aperture_fraction(config)
    assert decision["thin_lens_noise"] == pytest.approx(np.sqrt((1 - p) / (p * 64)), rel=0.15)
    assert decision["thin_lens_noise"] > 0.01


@pytest.mark.timeout(120)
def test_auto_lens_model_keeps_the_thin_lens_where_layers_would_occlude():
    # three checker planes at 1, 2 and 4 m: blurred edges overlap other depths
    config = scene_from_dict({
        "scene": {"preset": "dof_targets", "depths_m": [1.0, 2.0, 4.0]},
        "lens": {"focal_length_mm": 50.0, "f_number": 2.0, "focus_distance_m": 2.0},
        "sensor": {"width_px": 48, "height_px": 32},
        "render": {"spp": 4, "diffraction": "off"},
    })
    image = render(config, with_depth=True)
    assert image.meta["model_decisions"]["lens_model"]["choice"] == "thin"
    assert image.meta["lens_model"] == "thin"


@pytest.mark.timeout(120)
def test_the_sensor_uses_the_lens_the_render_used():
    config = scene_from_dict({
        "scene": {"preset": "flat_field", "distance_m": 1.0},
        "lens": {"focal_length_mm": 50.0, "f_number": 2.8, "focus_distance_m": 1.0, "model": "pinhole"},
        "sensor": {"width_px": 24, "height_px": 16, "vignetting": False},
        "exposure": {"time_s": 0.001},
        "render": {"spp": 4, "diffraction": "off"},
    })
    image = render(config, with_depth=False)
    assert image.lens == ThinLens.from_config(config.lens, config.sensor)
    other = config.replace(**{"lens.f_number": 5.6})
    carried, _ = expected_electrons(image, other)
    same, _ = expected_electrons(image, config)
    np.testing.assert_array_equal(carried, same)  # the render's f/2.8, not the config's f/5.6
    image.lens = None  # a synthetic image: the configured lens applies
    stripped, _ = expected_electrons(image, other)
    # the camera equation E = πL/(1 + 4N_w²) (Ray 2002, ch. 17), N_w = N(1 + m)
    m = ThinLens.from_config(config.lens, config.sensor).magnification
    ratio = (1 + 4 * (2.8 * (1 + m)) ** 2) / (1 + 4 * (5.6 * (1 + m)) ** 2)
    assert float(stripped.mean() / same.mean()) == pytest.approx(ratio, rel=1e-5)
