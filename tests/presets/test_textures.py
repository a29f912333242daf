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


def _overcast_render(look_up: bool):
    """A white (ρ = 1) horizontal plate under the overcast sky of 10 000 lx, seen from above,
    or the zenith seen from below it; the mean band radiance at 450–650 nm."""
    import mitsuba as mi

    import spectral_cam as sc
    from spectral_cam.presets import outdoor
    from spectral_cam.render.variants import choose_variant

    mi.set_variant(choose_variant("auto"))
    config = sc.scene_from_dict({"scene": {"preset": "vegetation", "light": "overcast"},
                                 "illuminant": {"illuminance_lux": 10000.0}})
    view = outdoor.GroundView(np.eye(3), np.zeros(3))  # the ground frame is the world: z up
    centres = np.arange(450.0, 700.0, 50.0)
    film = {"type": "specfilm", "width": 8, "height": 8, "rfilter": {"type": "box"}, "component_format": "float32"}
    for k, c in enumerate(centres):
        film[f"band_{k}"] = {"type": "spectrum", "value": [(c - 5.0, 1.0), (c + 5.0, 1.0)]}
    target = [0, 0, 2] if look_up else [0, 0, 0]
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": 2},
             "sensor": {"type": "perspective", "fov": 2.0, "film": film,
                        "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 1], target=target, up=[0, 1, 0])},
             "sky": outdoor.overcast_sky(config, view, mi)}
    if not look_up:
        scene["plate"] = {"type": "rectangle", "bsdf": {"type": "diffuse", "reflectance": {"type": "uniform",
                                                                                         "value": 1.0}}}
    radiance = np.asarray(mi.render(mi.load_dict(scene), spp=1024), dtype=np.float64).reshape(-1, len(centres))
    return centres, radiance.mean(axis=0)


def test_the_overcast_sky_gives_its_illuminance_as_the_cie_overcast_distribution():
    """Horizontal irradiance = ∫ L(θ)·cos θ dω: the plate's radiance × π equals the D65
    irradiance of 10 000 lx within 2 % (Mitsuba integrating the map), and the zenith radiance
    is 9E/(7π), the CIE overcast sky's (1 + 2 cos θ)/3 integrated by an independent quadrature."""
    from spectral_cam import spectra
    from spectral_cam.presets.outdoor import overcast_radiance

    wl, irradiance = spectra.absolute_irradiance("D65", 10000.0)
    fine = np.arange(-5.0, 5.01, 0.1)
    centres, plate = _overcast_render(look_up=False)
    band_e = np.array([np.trapezoid(np.interp(c + fine, wl, irradiance), fine) for c in centres])
    np.testing.assert_allclose(plate * np.pi, band_e, rtol=0.02)
    theta = np.linspace(0.0, np.pi / 2, 20001)
    factor = 2 * np.pi * np.trapezoid(overcast_radiance(np.degrees(theta)) * np.cos(theta) * np.sin(theta), theta)
    assert factor == pytest.approx(7 * np.pi / 9, rel=1e-6)
    _, zenith = _overcast_render(look_up=True)
    np.testing.assert_allclose(zenith, band_e / factor, rtol=0.02)


def test_a_colorchecker_stands_in_the_tabletop_as_the_camera_reads_a_chart():
    """``scene.chart = true``: the 24 patches face the camera at the look point, in the classic
    layout as the camera sees it (patch 0, dark skin, top left; patch 23, black, bottom right),
    and no object stands on it."""
    import spectral_cam as sc
    from spectral_cam.render import render_shape_map

    config = sc.load_scene("scenes/tabletop.toml", overrides={"scene.chart": True, "sensor.width_px": 240,
                                                             "sensor.height_px": 160})
    index, names = render_shape_map(config)
    centres = {}
    for k in range(24):
        name = f"chart_patch_{k:02d}"
        assert name in names, name
        rows, cols = np.nonzero(index == names.index(name))
        assert rows.size > 10, name  # every patch in view, unhidden
        centres[k] = (rows.mean(), cols.mean())
    assert centres[0][1] < centres[5][1] and centres[0][0] < centres[18][0]  # left to right, top to bottom
    assert centres[23][1] > centres[18][1] and centres[23][0] > centres[5][0]


def test_a_table_stands_before_a_wall_not_a_void():
    """``scene.ground = "table"``: wood under the objects and a stone wall behind them, so a view
    that reaches past the table ends on the wall: no ray of the upper frame escapes."""
    import spectral_cam as sc
    from spectral_cam.render import render_shape_map

    config = sc.load_scene("scenes/tabletop.toml", overrides={"scene.ground": "table", "scene.light": "illuminant",
                                                             "scene.view_pitch_deg": -15.0, "sensor.width_px": 96,
                                                             "sensor.height_px": 64, "sensor.pixel_pitch_um": 30.0})
    index, names = render_shape_map(config)
    assert np.all(index[:4] >= 0)  # the top rows see something
    assert "backdrop" in names and np.any(index[:4] == names.index("backdrop"))


def test_the_cornell_box_fills_its_frame():
    """Issue 25 #22: at 2.7 mm the view was wider than the box's opening (5963 pixels saw the
    void, a 3–4 px black border); the scene's lens frames the box, every pixel meets a wall."""
    import spectral_cam as sc
    from spectral_cam.render import render_shape_map

    index, _ = render_shape_map(sc.load_scene("scenes/cornell_box.toml"))
    assert (index >= 0).all()
