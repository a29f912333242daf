"""Issue 37 #4: the ground. Soil darker where wet (Lekner & Dorf 1988), relief from the same fields
as the spectral texture, and a horizon of hills instead of the far ground's straight edge."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytestmark = pytest.mark.timeout(120)

N_WATER = 1.333


def _fresnel(theta_i: float, n1: float, n2: float) -> float:
    """Unpolarised Fresnel reflectance by Snell's law in angles (independent of the module's)."""
    s = n1 / n2 * math.sin(theta_i)
    if s >= 1.0:
        return 1.0
    theta_t = math.asin(s)
    if theta_i == 0.0:
        return ((n1 - n2) / (n1 + n2)) ** 2
    rs = (math.sin(theta_i - theta_t) / math.sin(theta_i + theta_t)) ** 2
    rp = (math.tan(theta_i - theta_t) / math.tan(theta_i + theta_t)) ** 2
    return 0.5 * (rs + rp)


def _diffuse(n1: float, n2: float) -> float:
    from scipy.integrate import quad

    critical = math.asin(n2 / n1) if n1 > n2 else math.pi / 2
    f = lambda t: _fresnel(t, n1, n2) * math.sin(2 * t)  # noqa: E731  (2 sin cos)
    return quad(f, 0.0, critical, limit=200)[0] + (quad(f, critical, math.pi / 2)[0] if n1 > n2 else 0.0)


def test_wet_reflectance_is_lekner_and_dorf():
    """r_e of water for diffuse light ≈ 0.066, its internal r_i by direct integration equals
    1 − (1 − r_e)/n², and R_wet = (1 − r_e)(1 − r_i)a/(1 − r_i a): 0 for a = 0, 1 − r_e for
    a = 1, 0.45–0.7 of a typical soil's dry reflectance (Lobell & Asner 2002: roughly half)."""
    from spectral_cam.soil_moisture import diffuse_fresnel_reflectance, wet_reflectance

    r_e = _diffuse(1.0, N_WATER)
    r_i = _diffuse(N_WATER, 1.0)
    assert r_e == pytest.approx(0.0664, abs=5e-4)
    assert r_i == pytest.approx(1 - (1 - r_e) / N_WATER ** 2, abs=1e-5)
    assert diffuse_fresnel_reflectance(N_WATER) == pytest.approx(r_e, abs=1e-6)
    a = np.linspace(0.0, 1.0, 41)
    np.testing.assert_allclose(wet_reflectance(a), (1 - r_e) * (1 - r_i) * a / (1 - r_i * a), atol=1e-6)
    assert wet_reflectance(0.0) == 0.0 and wet_reflectance(1.0) == pytest.approx(1 - r_e, abs=1e-6)
    soils = np.linspace(0.05, 0.5, 10)
    ratio = wet_reflectance(soils) / soils
    assert np.all((ratio > 0.45) & (ratio < 0.7)) and np.all(np.diff(ratio) > 0)  # brighter soils darken less


def test_wetting_the_dry_usgs_sand_gives_the_wet_one():
    """The bundled USGS sand DWO-3-DEL2 measured dry and wet: the model applied to the dry
    spectrum is within 20 % of the wet measurement over 420–700 nm."""
    from spectral_cam.reflectance_sets import reflectance_set
    from spectral_cam.soil_moisture import wet_spectrum
    from spectral_cam.spectra import sample

    soils = reflectance_set("usgs_soils")
    sds = dict(zip(soils.names, soils.sds))
    dry = next(sd for n, sd in sds.items() if "DEL2" in n and "dry" in n)
    wet = next(sd for n, sd in sds.items() if "DEL2" in n and "wet" in n)
    wl = np.arange(420.0, 701.0, 10.0)
    model = sample(wet_spectrum(dry), wl)
    np.testing.assert_allclose(model, sample(wet, wl), rtol=0.2)


def test_relief_and_moisture_follow_the_texture():
    """One set of fields: the ground is wet in its hollows (height and wetness anticorrelated),
    the wet share is the one asked, and clods are rough on bare soil, flat under litter."""
    import cv2

    from spectral_cam.textures import ground_maps

    size = 256
    abundances, wetness, height = ground_maps(size, [0.4, 0.4, 0.1, 0.1], period_px=64, seed=5, litter=(2, 3),
                                              moisture=0.25, relief_size=2 * size, clod_period_px=8.0)
    assert abundances.shape == (4, size, size) and wetness.shape == (size, size) and height.shape == (2 * size,) * 2
    assert wetness.mean() == pytest.approx(0.25, abs=0.01) and 0.0 <= wetness.min() and wetness.max() <= 1.0
    low = cv2.resize(height, (size, size), interpolation=cv2.INTER_AREA)
    assert np.corrcoef(low.ravel(), wetness.ravel())[0, 1] < -0.5
    gy, gx = np.gradient(height.astype(np.float64))
    rough = cv2.resize(np.hypot(gx, gy).astype(np.float32), (size, size), interpolation=cv2.INTER_AREA)
    litter = abundances[2:].sum(axis=0)
    bare = (litter < 0.1) & (wetness < 0.05)
    covered = litter > 0.8
    assert bare.sum() > 100 and covered.sum() > 100
    assert rough[covered].mean() < 0.4 * rough[bare].mean()


def test_the_horizon_is_a_line_of_hills_and_the_ground_fills_the_frame():
    """scenes/meadow.toml's shape map: the first row from the top that meets a surface varies
    across the columns by more than 4 px (hills, not the far ground's straight edge), below it
    every pixel meets a surface (no void), and the hills rise less than 5° over the look point's
    horizon, so a sun above 5° is never hidden by them."""
    import spectral_cam as sc
    from spectral_cam.presets.outdoor import GroundView, terrain_mesh
    from spectral_cam.render import render_shape_map

    config = sc.load_scene("scenes/meadow.toml", overrides={"scene.ground": "flat", "sensor.width_px": 192,
                                                           "sensor.height_px": 128, "sensor.pixel_pitch_um": 15.0})
    index, names = render_shape_map(config)
    hit = index >= 0
    first = hit.argmax(axis=0)
    assert hit.any(axis=0).all()
    assert first.max() - first.min() > 4, first
    below = np.arange(index.shape[0])[:, None] >= first[None, :]
    assert hit[below].all()
    terrain = names.index("terrain")
    assert (index == terrain).sum() > 100
    vertices, faces, _ = terrain_mesh(GroundView.from_config(config))
    r = np.hypot(vertices[:, 0], vertices[:, 1])
    elevation = np.degrees(np.arctan2(vertices[:, 2] + 1.0, r))
    assert elevation.max() < 5.0 and faces.shape[0] < 4000
    assert vertices[r == r.min(), 2].max() < 0.0  # the inner edge sinks under the far ground
