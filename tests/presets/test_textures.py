"""Issue 24 #1: spectral textures. A textured surface reflects the abundance-weighted mixture of
its measured spectra (the linear mixing model; Keshava & Mustard 2002), rendered face-on under a
light of known irradiance (radiance ρE/π, Lambert)."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.reflectance_sets import reflectance_set
from spectral_cam.textures import abundance_maps, fbm, height_field

pytestmark = pytest.mark.timeout(240)


def test_abundances_are_a_partition_of_unity_with_the_asked_covers():
    maps = abundance_maps(256, [0.6, 0.3, 0.1], period_px=64, seed=3)
    assert maps.shape == (3, 256, 256) and maps.min() >= 0
    np.testing.assert_allclose(maps.sum(axis=0), 1.0, atol=1e-5)
    shares = maps.mean(axis=(1, 2))
    assert shares[0] > shares[1] > shares[2]  # the biases order the covers
    assert np.all((maps.max(axis=0) > 0.8).mean() > 0.3)  # patches where one endmember dominates


def test_fbm_is_a_power_law_field():
    """Summed octaves of halving period and 0.55 amplitude: the radially averaged power falls with
    frequency over the octaves (a fractal field, as natural textures)."""
    field = fbm(256, period_px=64.0, seed=2)
    power = np.abs(np.fft.fft2(field)) ** 2
    f = np.hypot(*np.meshgrid(np.fft.fftfreq(256), np.fft.fftfreq(256), indexing="ij"))
    low, mid, high = (power[(f > a) & (f < b)].mean() for a, b in ((1 / 64, 1 / 32), (1 / 16, 1 / 8), (1 / 4, 1 / 2)))
    assert low > 10 * mid > 100 * high
    h = height_field(128, period_px=16.0, seed=1)
    assert h.min() == 0.0 and h.max() == 1.0


def test_a_textured_surface_reflects_the_abundance_weighted_mean_of_its_spectra():
    """Five measured spectra (three USGS soils, dry grass, a dry oak leaf) mixed by fractal
    abundances over a plate that fills the view, lit face-on by 1 W·m⁻²·nm⁻¹: the mean band
    radiance equals E/π·Σ_k ā_k·S̄_k within 1 %, ā_k the abundances' means and S̄_k each
    spectrum's band mean."""
    import mitsuba as mi

    from spectral_cam.presets.common import mixed_bsdf
    from spectral_cam.render.variants import choose_variant
    from spectral_cam.spectra import sample

    mi.set_variant(choose_variant("auto"))
    soils, plants = reflectance_set("usgs_soils"), reflectance_set("usgs_vegetation")
    endmembers = list(soils.sds) + [sd for n, sd in zip(plants.names, plants.sds) if n.startswith("dry")]
    maps = abundance_maps(128, [0.3, 0.2, 0.2, 0.2, 0.1], period_px=32, seed=5)
    centres = np.arange(450.0, 700.0, 50.0)
    film = {"type": "specfilm", "width": 64, "height": 64, "rfilter": {"type": "box"}, "component_format": "float32"}
    for k, c in enumerate(centres):
        film[f"band_{k}"] = {"type": "spectrum", "value": [(c - 5.0, 1.0), (c + 5.0, 1.0)]}
    # a plate exactly filling a 10° view at 1 m, facing the camera; its uv run over the texture once
    half = np.tan(np.radians(5.0))
    scene = mi.load_dict({
        "type": "scene", "integrator": {"type": "path", "max_depth": 2},
        "sensor": {"type": "perspective", "fov": 10.0, "film": film,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 0], target=[0, 0, 1], up=[0, 1, 0])},
        "plate": {"type": "rectangle", "bsdf": mixed_bsdf(mi, endmembers, maps),
                  "to_world": mi.ScalarTransform4f().translate([0, 0, 1]).rotate([0, 1, 0], 180).scale([float(half), float(half), 1.0])},
        "light": {"type": "directional", "direction": [0, 0, 1], "irradiance": {"type": "uniform", "value": 1.0}},
    })
    radiance = np.asarray(mi.render(scene, spp=64), dtype=np.float64).reshape(-1, len(centres)).mean(axis=0)
    fine = np.arange(-5.0, 5.01, 0.1)
    band_means = np.array([[np.trapezoid(sample(sd, c + fine), fine) for c in centres] for sd in endmembers])
    expected = maps.mean(axis=(1, 2)) @ band_means / np.pi
    np.testing.assert_allclose(radiance, expected, rtol=0.01)
