"""Issue 37 #4: cloud cover over the sun and sky (``sky.cloud_cover``, presets/clouds.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.timeout(300)


def _meadow(**overrides):
    import spectral_cam as sc

    return sc.load_scene(ROOT / "scenes" / "meadow.toml", overrides=overrides)


@pytest.mark.parametrize("cover", [0.2, 0.5, 0.8])
def test_the_sun_is_hidden_where_the_cloud_field_covers_the_sky(cover):
    """``cloud_cover`` of the layer's cells are cloud, and a ray from the ground towards the sun
    is blocked exactly where it crosses the cloud base (1.5 km up) in a covered cell: traced with
    Mitsuba against the layer alone, over a grid of ground points ±15 km around the look point,
    compared with the cell its straight line meets (rays within a metre of a cell's edge
    skipped); the shade falls on ``cloud_cover`` of the ground within 0.03 over the whole area."""
    import mitsuba as mi

    from spectral_cam.presets.clouds import CLOUD_BASE_M, CLOUD_GRID, CLOUD_LAYER_M, cloud_field, cloud_layer, cloud_mask
    from spectral_cam.presets.outdoor import GroundView
    from spectral_cam.render.leaf_bsdf import register
    from spectral_cam.solar import sun_position

    mi.set_variant("llvm_ad_spectral" if "llvm_ad_spectral" in mi.variants() else "scalar_spectral")
    register(mi)
    config = _meadow(**{"sky.cloud_cover": cover})
    mask, _ = cloud_mask(cloud_field(config.scene.layout_seed), cover)
    assert mask.mean() == pytest.approx(cover, abs=1.0 / mask.size)
    view = GroundView.from_config(config)
    scene = mi.load_dict({"type": "scene", **cloud_layer(config, view, mi)})
    sky = config.sky
    sun = sun_position(sky.date, sky.hour, utc_offset_h=sky.utc_offset_h, latitude_deg=sky.latitude_deg,
                       longitude_deg=sky.longitude_deg).direction_enu()
    east, north = np.meshgrid(np.linspace(-15000, 15000, 150), np.linspace(-15000, 15000, 150))
    ground = np.stack([east.ravel(), north.ravel(), np.zeros(east.size)], axis=1)
    origins = view.to_camera(ground)
    direction = view.rotation @ sun
    rays = mi.Ray3f(mi.Point3f(*[origins[:, i].astype(np.float32) for i in range(3)]),
                    mi.Vector3f(*[np.full(len(origins), float(d), np.float32) for d in direction]))
    blocked = np.asarray(scene.ray_test(rays), dtype=bool)
    crossing = ground[:, :2] + CLOUD_BASE_M / sun[2] * sun[:2]
    cell = (crossing + CLOUD_LAYER_M / 2) / CLOUD_LAYER_M * CLOUD_GRID
    inside = np.all((cell >= 0) & (cell < CLOUD_GRID), axis=1)
    clear_of_edges = inside & np.all(np.abs(cell - np.round(cell)) * CLOUD_LAYER_M / CLOUD_GRID > 1.0, axis=1)
    rows, cols = cell[clear_of_edges, 1].astype(int), cell[clear_of_edges, 0].astype(int)
    np.testing.assert_array_equal(blocked[clear_of_edges], mask[rows, cols])
    assert blocked[inside].mean() == pytest.approx(cover, abs=0.03)
    assert not blocked[~inside].any()


def test_clouds_scatter_without_making_light_and_a_clear_sky_has_none():
    """Each cloud BSDF reflects plus transmits at most all it receives (an absorbing grey
    scatterer, Stephens 1978), and ``cloud_cover = 0`` adds no shape."""
    import mitsuba as mi

    from spectral_cam.presets.clouds import THICK_CLOUD, THIN_CLOUD, cloud_layer
    from spectral_cam.presets.outdoor import GroundView

    for reflectance, transmittance in (THICK_CLOUD, THIN_CLOUD):
        assert 0 < reflectance and 0 < transmittance and reflectance + transmittance <= 1.0
    config = _meadow()
    assert config.sky.cloud_cover == 0.0
    assert cloud_layer(config, GroundView.from_config(config), mi) == {}


def test_a_cloud_cover_outside_zero_to_one_is_refused_before_rendering():
    from spectral_cam.errors import ConfigError

    for bad in (-0.1, 1.5, float("nan")):
        with pytest.raises(ConfigError, match="sky.cloud_cover"):
            _meadow(**{"sky.cloud_cover": bad})


@pytest.mark.timeout(600)
def test_the_camera_sees_clouds_to_the_horizon_and_the_light_stays_the_sun_and_skys():
    """At 60 % cover the meadow's sky (the top of its frame) shows clouds (Mitsuba's default
    far clip of 10 km hid every cloud beyond it), and the white balance reads the sun and sky's
    light, as with a clear sky: clouds pass the sun's light on in its spectrum."""
    from spectral_cam.render import render_shape_map
    from spectral_cam.render.lights import resolve_light

    small = {"sensor.width_px": 96, "sensor.height_px": 64, "sensor.pixel_pitch_um": 30.0, "scene.ground": "flat"}
    cloudy = _meadow(**small, **{"sky.cloud_cover": 0.6})
    index, names = render_shape_map(cloudy)
    assert "clouds" in names
    top = index[: index.shape[0] // 4]
    assert 0.1 < np.mean(top == names.index("clouds")) < 0.95
    clear_light, _ = resolve_light(_meadow(**small))
    cloudy_light, record = resolve_light(cloudy)
    assert cloudy_light.illuminant.spd == clear_light.illuminant.spd  # the same CSV: the same spectrum
