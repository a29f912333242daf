"""The depth-layered lens model (``lens.model = "layered"``, :mod:`spectral_cam.render.defocus`):
the disc kernel, the layer compositing and :func:`spectral_cam.render.render_layered`
against thin-lens path tracing of a small bright out-of-focus source.

The expected CoC is written out here (A·f·|z − z_f|/(z·(z_f − f))) rather than taken from
the code under test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from spectral_cam.errors import ConfigError
from spectral_cam.image import SpectralImage
from spectral_cam.optics import ThinLens
from spectral_cam.render import render, render_layered
from spectral_cam.render.defocus import aperture_fraction, defocus_layers, disc_kernel, nearest_depth
from spectral_cam.scene import scene_from_dict

WAVELENGTHS = np.arange(400.0, 701.0, 10.0)
EDGES = np.append(WAVELENGTHS - 5.0, WAVELENGTHS[-1] + 5.0)


def point_source_scene(*, width_px=48, pixel_pitch_um=6.0, focal_length_mm=8.0, f_number=1.4,
                       focus_distance_m=0.3, source_depth_m=3.0, source_radius_m=0.002, model="thin", spp=1,
                       seed=0):
    """One small emitting disc on the optical axis seen by a square sensor."""
    return scene_from_dict({
        "scene": {"preset": "point_sources", "depths_m": [source_depth_m], "source_radius_m": source_radius_m},
        "lens": {"focal_length_mm": focal_length_mm, "f_number": f_number, "focus_distance_m": focus_distance_m,
                 "model": model},
        "sensor": {"width_px": width_px, "height_px": width_px, "pixel_pitch_um": pixel_pitch_um},
        "render": {"spp": spp, "seed": seed, "diffraction": "off"},
    })


def lens_of(config):
    return ThinLens.from_config(config.lens, config.sensor)


def band_sum(image):
    return np.asarray(image.data, dtype=np.float64).sum(axis=-1)


def test_disc_kernel_is_a_normalised_uniform_disc():
    kernel = disc_kernel(9.0)
    assert kernel.shape == (9, 9) and kernel.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(kernel, kernel.T)
    np.testing.assert_allclose(kernel, kernel[::-1, ::-1])
    coverage = kernel / kernel.max()
    assert coverage.sum() == pytest.approx(math.pi * 4.5 ** 2, rel=0.01)  # area in pixels
    np.testing.assert_array_equal(disc_kernel(0.6), [[1.0]])
    with pytest.raises(ConfigError, match="diameter"):
        disc_kernel(float("nan"))


def test_defocus_layers_spread_a_point_into_its_coc_disc_in_every_band():
    lens = lens_of(point_source_scene())
    data = np.zeros((48, 48, 31), np.float32)
    spectrum = np.linspace(1.0, 2.0, 31, dtype=np.float32)
    data[24, 24] = spectrum
    depth = np.full((48, 48), np.inf, np.float32)
    depth[24, 24] = 3.0
    out = defocus_layers(SpectralImage(data, WAVELENGTHS, EDGES, depth), lens)
    f, zf, z = 8e-3, 0.3, 3.0
    coc_px = (f / 1.4) * f * abs(z - zf) / (z * (zf - f)) / 6e-6
    kernel = disc_kernel(coc_px)
    half = kernel.shape[0] // 2
    np.testing.assert_allclose(out.data[24 - half:25 + half, 24 - half:25 + half, 5], kernel * spectrum[5], atol=1e-6)
    np.testing.assert_allclose(out.data.sum(axis=(0, 1)), spectrum, rtol=1e-5)  # each band's energy kept
    assert out.meta["defocus_layers"]["layers"] == 1


def test_defocus_layers_composite_near_over_far():
    """An in-focus opaque square in front hides the far source's blur behind it."""
    lens = lens_of(point_source_scene())
    data = np.zeros((48, 48, 31), np.float32)
    depth = np.full((48, 48), np.inf, np.float32)
    data[24, 30] = 100.0
    depth[24, 30] = 3.0  # far, just right of the square: a 23-px disc over it
    data[20:28, 20:28] = 1.0
    depth[20:28, 20:28] = 0.3  # at the focus distance, in front
    out = defocus_layers(SpectralImage(data, WAVELENGTHS, EDGES, depth), lens).data
    np.testing.assert_allclose(out[20:28, 20:28], 1.0, atol=1e-6)  # the square, sharp and opaque
    assert out[24, 38, 0] > 0.1 and out[30, 24, 0] > 0.1  # the far blur around it
    with pytest.raises(ConfigError, match="depth map"):
        defocus_layers(SpectralImage(data, WAVELENGTHS, EDGES), lens)
    with pytest.raises(ConfigError, match="coc_ratio"):
        defocus_layers(SpectralImage(data, WAVELENGTHS, EDGES, depth), lens, coc_ratio=1.0)


BOKEH_TEST = dict(width_px=24, pixel_pitch_um=12.0, focal_length_mm=8.0, f_number=1.4, focus_distance_m=0.3,
                  source_depth_m=3.0, source_radius_m=0.002)


@pytest.fixture(scope="module")
def bokeh_renders():
    thin = {seed: render(point_source_scene(model="thin", spp=spp, seed=seed, **BOKEH_TEST), with_depth=False)
            for seed, spp in ((11, 8192), (12, 8192), (13, 1024))}
    remedy = render_layered(point_source_scene(model="pinhole", spp=128, seed=14, **BOKEH_TEST))
    return thin, remedy


@pytest.mark.timeout(120)
def test_bokeh_remedy_beats_thin_lens_rendering_at_equal_time(bokeh_renders):
    """A 0.9-px source blurred into a 12-px disc: the pinhole render + depth-layered disc
    PSF (128 spp, about 0.2 M camera samples with its margin and depth) is closer to a
    16384-spp thin-lens reference than thin-lens rendering with 1024 spp (0.6 M samples)."""
    thin, remedy = bokeh_renders
    config = point_source_scene(model="thin", **BOKEH_TEST)
    p = aperture_fraction(config)
    coc = lens_of(config).coc_diameter_px(3.0)
    y, x = np.mgrid[0:24, 0:24] + 0.5 - 12.0
    disc = np.hypot(x, y) < 0.5 * coc - 1.5  # the blur disc, 1.5 px in from its edge
    reference = 0.5 * (band_sum(thin[11]) + band_sum(thin[12]))
    plain = band_sum(thin[13])
    fixed = band_sum(remedy)
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
    assert remedy.meta["lens_model"] == "layered"
    decision = remedy.meta["model_decisions"]["defocus"]
    assert decision["choice"] == "depth_layered_disc_psf" and decision["margin_px"] >= 6
    assert {"pinhole_render", "depth", "defocus_layers"} <= set(remedy.meta["timings_s"])
    config = point_source_scene(model="pinhole", spp=1, **BOKEH_TEST)
    with pytest.raises(ConfigError, match="margin_px"):
        render_layered(config, margin_px=-1)
    with pytest.raises(ConfigError, match="supersample"):
        nearest_depth(config, supersample=0)
