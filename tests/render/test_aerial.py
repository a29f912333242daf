"""Aerial perspective (``render/aerial.py``): the air's extinction against colour-science's
Rayleigh scattering and the pure-air visual range, the veil of the integrator against the closed
form L₀·T + L_h·(1 − T) on targets whose radiance is known, and where ``auto`` turns it on.

References: colour-science's ``colour.phenomena.rayleigh`` (Bodhaine et al. 1999); the visual
range of pure air, about 336 km at 550 nm (Middleton, W. E. K. (1952). Vision through the
Atmosphere. University of Toronto Press: 3.912 over Rayleigh's 1.16·10⁻⁵ m⁻¹); Preetham et al.
1999 for turbidity as the ratio of vertical optical depths.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.render.aerial import (HAZE_HEIGHT_M, RAYLEIGH_HEIGHT_M, decide_aerial, extinction_per_m,
                                        meteorological_range_m)

pytestmark = pytest.mark.timeout(300)
ROOT = Path(__file__).resolve().parents[2]


def test_clean_air_extinguishes_as_colour_science_scatters():
    """Turbidity 1 (molecules only) is colour-science's Rayleigh scattering coefficient σ(λ)·N at
    sea level within 1.5 % over 400–700 nm."""
    from colour.phenomena import rayleigh

    wavelengths = np.arange(400.0, 701.0, 25.0)
    reference = rayleigh.scattering_cross_section(wavelengths * 1e-7) * rayleigh.molecular_density(288.15) * 100.0
    np.testing.assert_allclose(extinction_per_m(wavelengths, 1.0), reference, rtol=0.015)


def test_turbidity_is_the_ratio_of_vertical_optical_depths_and_sets_the_visual_range():
    """Preetham's turbidity: (τ_molecules + τ_haze)/τ_molecules over the scale heights; pure air
    sees about 336 km (Middleton 1952), and the visual range falls as the haze thickens."""
    rayleigh = extinction_per_m(550.0, 1.0)
    for turbidity in (2.0, 3.0, 6.0):
        haze = extinction_per_m(550.0, turbidity) - rayleigh
        assert (rayleigh * RAYLEIGH_HEIGHT_M + haze * HAZE_HEIGHT_M) / (rayleigh * RAYLEIGH_HEIGHT_M) == \
            pytest.approx(turbidity, rel=1e-9)
    assert meteorological_range_m(1.0) == pytest.approx(336e3, rel=0.05)
    assert meteorological_range_m(2.0) > meteorological_range_m(3.0) > meteorological_range_m(6.0) > 5e3
    with pytest.raises(ValueError, match="turbidity"):
        extinction_per_m(550.0, 0.5)


def _render(mi, objects, distance_m, turbidity, bands, elevation_deg=0.0):
    """A camera at the origin looking along +z at ``objects``, through the aerial integrator (up
    +y): the radiance in each narrow band (2 nm wide, one film each, so no sample's wavelength
    falls in another band), W·m⁻²·sr⁻¹·nm⁻¹."""
    from spectral_cam.render.aerial import PLUGIN, register

    register(mi)
    haze = extinction_per_m(550.0, turbidity) - extinction_per_m(550.0, 1.0)
    out = []
    for c in bands:
        film = {"type": "specfilm", "width": 4, "height": 4, "rfilter": {"type": "box"}, "component_format": "float32",
                "band": {"type": "spectrum", "value": [(c - 1.0, 1.0), (c + 1.0, 1.0)]}}
        scene = mi.load_dict({
            "type": "scene",
            "integrator": {"type": PLUGIN, "integrator": {"type": "path", "max_depth": 2},
                           "rayleigh_550": float(extinction_per_m(550.0, 1.0)), "haze_550": float(haze),
                           "up_x": 0.0, "up_y": 1.0, "up_z": 0.0},
            "sensor": {"type": "perspective", "fov": 0.2, "film": film,
                       "to_world": mi.ScalarTransform4f().rotate([1, 0, 0], -elevation_deg)
                       .look_at([0, 0, 0], [0, 0, 1], [0, 1, 0])},
            **objects(distance_m, elevation_deg)})
        out.append(np.asarray(mi.render(scene, spp=16), dtype=np.float64).mean() / 2.0)
    return np.array(out)


def _facing(mi, distance_m, elevation_deg):
    """A large square ``distance_m`` along the view (tilted up ``elevation_deg``), facing back."""
    return (mi.ScalarTransform4f().rotate([1, 0, 0], -elevation_deg).translate([0, 0, distance_m])
            .rotate([0, 1, 0], 180).scale(1e3))


def _targets(mi):
    """Builders of the two targets of known radiance, ``(distance, elevation) -> scene entries``:
    one glowing with L₀ = 2 and no sky; one black under a uniform sky of radiance 3."""
    def glowing(d, elevation=0.0):
        return {"target": {"type": "rectangle", "to_world": _facing(mi, d, elevation),
                           "emitter": {"type": "area", "radiance": {"type": "uniform", "value": 2.0}}}}

    def black_under_sky(d, elevation=0.0):
        return {"target": {"type": "rectangle", "to_world": _facing(mi, d, elevation),
                           "bsdf": {"type": "diffuse", "reflectance": 0.0}},
                "sky": {"type": "constant", "radiance": {"type": "uniform", "value": 3.0}}}

    return glowing, black_under_sky


@pytest.mark.parametrize("turbidity", [1.0, 3.0])
def test_the_veil_is_the_closed_form_on_targets_of_known_radiance(variant, turbidity):
    """A glowing target (radiance L₀, no sky) 5 km away reaches the camera as L₀·T(λ); a black
    one under a uniform sky of radiance L_h (so L_h at the horizon too) as L_h·(1 − T(λ)), with
    T = exp(−β(λ)·s), within 1 % in every band."""
    import mitsuba as mi

    mi.set_variant(variant)
    bands = np.array([450.0, 550.0, 650.0])
    s = 5000.0
    transmittance = np.exp(-extinction_per_m(bands, turbidity) * s)

    glowing, black_under_sky = _targets(mi)
    np.testing.assert_allclose(_render(mi, glowing, s, turbidity, bands), 2.0 * transmittance, rtol=0.01)
    np.testing.assert_allclose(_render(mi, black_under_sky, s, turbidity, bands), 3.0 * (1 - transmittance), rtol=0.01)


def test_auto_veils_a_view_of_the_horizon_and_not_a_tabletop():
    from spectral_cam.errors import ConfigError
    from spectral_cam.optics import ThinLens

    meadow = sc.load_scene(ROOT / "scenes" / "meadow.toml")
    lens = ThinLens.from_config(meadow.lens, meadow.sensor)
    on, record = decide_aerial(meadow.replace(**{"scene.light": "sunsky"}), lens)
    assert on and record["farthest_ground_m"] == "horizon" and 15e3 < record["meteorological_range_km"] * 1e3 < 35e3
    off, _ = decide_aerial(meadow.replace(**{"scene.light": "sunsky", "sky.aerial_perspective": "off"}), lens)
    assert not off
    table = sc.load_scene(ROOT / "scenes" / "tabletop.toml").replace(**{"scene.light": "sunsky"})
    on, record = decide_aerial(table, ThinLens.from_config(table.lens, table.sensor))
    assert not on and record["farthest_ground_m"] < 20 and "veiled by" in record["reason"]
    room = sc.load_scene(ROOT / "scenes" / "room.toml")
    assert not decide_aerial(room, ThinLens.from_config(room.lens, room.sensor))[0]
    with pytest.raises(ConfigError, match="auto, on or off"):
        sc.load_scene(ROOT / "scenes" / "meadow.toml", overrides={"sky.aerial_perspective": "maybe"})


def test_the_meadows_far_hills_pale_towards_the_sky_and_its_near_ground_keeps_its_light():
    """The bundled meadow (small, pinhole): the plan records the veil; ground nearer than 50 m
    keeps its radiance within 1 % (T > 0.99), while ground beyond 2 km moves towards the sky's
    light (brighter and bluer: the blue band's share grows)."""
    small = {"sensor.width_px": 96, "sensor.height_px": 64, "sensor.pixel_pitch_um": 30.0, "lens.model": "pinhole",
             "render.spp": 16, "render.estimator": "mean", "render.bands": "400:700:50", "render.diffraction": "off"}
    meadow = sc.load_scene(ROOT / "scenes" / "meadow.toml", overrides=small)
    veiled = sc.render(meadow)
    clear = sc.render(meadow.replace(**{"sky.aerial_perspective": "off"}))
    assert veiled.meta["model_decisions"]["aerial_perspective"]["choice"] == "on"
    assert clear.meta["model_decisions"]["aerial_perspective"]["choice"] == "off"
    depth = np.asarray(veiled.depth_m)
    near, far = depth < 50.0, np.isfinite(depth) & (depth > 2000.0)
    assert near.sum() > 100 and far.sum() > 20
    a, b = np.asarray(veiled.data, np.float64), np.asarray(clear.data, np.float64)
    assert a[near].sum() == pytest.approx(b[near].sum(), rel=0.01)
    assert a[far].sum() > b[far].sum()
    blue = slice(0, 2)  # 400-500 nm
    assert a[far][:, blue].sum() / a[far].sum() > b[far][:, blue].sum() / b[far].sum()


def test_a_climbing_ray_crosses_thinner_air_and_the_skys_share_of_its_path(variant):
    """A ray climbing at 30° to a target 5 km away (2.5 km up: a cloud) crosses the optical depth
    Σ β_i·H_i·(1 − exp(−s·sin e/H_i))/sin e of air thinning with the molecules' and the haze's
    scale heights; under a uniform sky of radiance L a black target there shows L·(1 − T)/(1 − T∞),
    T∞ the whole path's to space — within 1 % per band."""
    import mitsuba as mi

    mi.set_variant(variant)
    bands = np.array([450.0, 550.0, 650.0])
    s, elevation, turbidity = 5000.0, 30.0, 3.0
    sine = math.sin(math.radians(elevation))
    rayleigh = extinction_per_m(bands, 1.0)
    haze = extinction_per_m(bands, turbidity) - rayleigh
    depth = sum(b * h * (1 - np.exp(-s * sine / h)) / sine
                for b, h in ((rayleigh, RAYLEIGH_HEIGHT_M), (haze, HAZE_HEIGHT_M)))
    transmittance = np.exp(-depth)
    endless = np.exp(-(rayleigh * RAYLEIGH_HEIGHT_M + haze * HAZE_HEIGHT_M) / sine)
    assert depth[1] < 0.6 * extinction_per_m(550.0, turbidity) * s  # thinner than the ground's air

    glowing, black_under_sky = _targets(mi)
    np.testing.assert_allclose(_render(mi, glowing, s, turbidity, bands, elevation), 2.0 * transmittance, rtol=0.01)
    np.testing.assert_allclose(_render(mi, black_under_sky, s, turbidity, bands, elevation),
                               3.0 * (1 - transmittance) / (1 - endless), rtol=0.01)
