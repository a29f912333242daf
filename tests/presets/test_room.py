"""The ``room`` preset (issue 37 #5): its ceiling panel gives the table ``illuminance_lux``
(a rendered white plate), the floor lamp sends its rated flux, every pixel of the frame meets a
surface, the furniture stands inside the walls and apart, and ``layout_seed`` draws the room."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

pytestmark = pytest.mark.timeout(240)

SCENE = "scenes/room.toml"


def _config(**overrides):
    import spectral_cam as sc

    return sc.load_scene(SCENE, overrides=overrides)


def test_the_ceiling_panel_gives_the_table_its_illuminance():
    """A white (ρ = 1) plate at the table's height under the panel alone, seen from above: its
    radiance × π equals the ``[illuminant]`` irradiance of ``illuminance_lux`` in every band
    within 2 % (Mitsuba integrating the panel against the closed form the preset inverts)."""
    import mitsuba as mi

    from spectral_cam import spectra
    from spectral_cam.presets.outdoor import GroundView
    from spectral_cam.presets.room import TABLE_HEIGHT_M, ceiling_lamp
    from spectral_cam.render.variants import choose_variant

    mi.set_variant(choose_variant("auto"))
    config = _config(**{"illuminant.illuminance_lux": 250.0})
    view = GroundView(np.eye(3), np.zeros(3))  # the room frame is the world: z up
    centres = np.arange(450.0, 700.0, 50.0)
    film = {"type": "specfilm", "width": 8, "height": 8, "rfilter": {"type": "box"}, "component_format": "float32"}
    for k, c in enumerate(centres):
        film[f"band_{k}"] = {"type": "spectrum", "value": [(c - 5.0, 1.0), (c + 5.0, 1.0)]}
    z = TABLE_HEIGHT_M
    scene = mi.load_dict({
        "type": "scene", "integrator": {"type": "path", "max_depth": 2},
        "sensor": {"type": "perspective", "fov": 2.0, "film": film,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, z + 0.3], target=[0, 0, z], up=[0, 1, 0])},
        "plate": {"type": "rectangle", "bsdf": {"type": "diffuse", "reflectance": {"type": "uniform", "value": 1.0}},
                  "to_world": mi.ScalarTransform4f().translate([0, 0, z]).scale(0.02)},
        "lamp": ceiling_lamp(config, view, mi)})
    radiance = np.asarray(mi.render(scene, spp=1024), dtype=np.float64).reshape(-1, len(centres)).mean(axis=0)
    wl, irradiance = spectra.absolute_irradiance(config.illuminant.spd, 250.0)
    fine = np.arange(-5.0, 5.01, 0.1)
    band_e = np.array([np.trapezoid(np.interp(c + fine, wl, irradiance), fine) for c in centres])
    np.testing.assert_allclose(radiance * np.pi, band_e, rtol=0.02)


def test_the_floor_lamp_sends_its_rated_flux():
    """Its two diffusers' luminous flux, K_m·Σ π·A·∫L(λ)ȳ(λ)dλ over each disc (a Lambertian
    emitter's exitance is π·L), is :data:`LAMP_FLUX_LM`."""
    import mitsuba as mi

    from spectral_cam import cie
    from spectral_cam.presets.outdoor import GroundView
    from spectral_cam.presets.room import LAMP_FLUX_LM, SHADE_RADII_M, lamp_diffusers
    from spectral_cam.render.variants import choose_variant
    from spectral_cam.spectra import sample

    mi.set_variant(choose_variant("auto"))
    lights = lamp_diffusers(_config(), GroundView(np.eye(3), np.zeros(3)), mi, (0.0, 0.0))
    flux = 0.0
    for entry, radius in zip((lights["lamp_light_down"], lights["lamp_light_up"]), SHADE_RADII_M):
        wl, values = np.array(entry["emitter"]["radiance"]["value"]).T
        ybar = sample(cie.cmfs_1931(), wl, outside=0.0)[:, 1]
        flux += 683.0 * np.pi * (np.pi * radius ** 2) * np.trapezoid(values * ybar, wl)
    assert flux == pytest.approx(LAMP_FLUX_LM, rel=0.01)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_every_pixel_of_the_frame_meets_a_surface(seed):
    """The camera stands inside a closed room: no ray escapes, and the furniture is in view."""
    from spectral_cam.render import render_shape_map

    config = _config(**{"scene.layout_seed": seed, "sensor.width_px": 96, "sensor.height_px": 64,
                        "sensor.pixel_pitch_um": 30.0})
    index, names = render_shape_map(config)
    assert (index >= 0).all()
    seen = {names[i] for i in np.unique(index)}
    for name in ("floor", "wall_back", "table_top", "rug", "sofa_back"):
        assert name in seen, (name, sorted(seen))
    assert any(n.startswith("book_") for n in seen)


def _groups(layout):
    """Axis-aligned bounds of each piece of furniture (its meshes together)."""
    prefixes = {"table": ("table_", "object_"), "sofa": ("sofa_", "cushion_"), "shelf": ("shelf_", "book_"),
                "lamp": ("lamp_",), "sideboard": ("sideboard",), "painting": ("painting",)}
    groups = {}
    for group, starts in prefixes.items():
        points = np.concatenate([p.vertices for p in layout.pieces if p.name.startswith(starts)])
        groups[group] = (points.min(axis=0), points.max(axis=0))
    return groups


@pytest.mark.parametrize("seed", range(6))
def test_the_furniture_stands_inside_the_walls_and_apart(seed):
    """Every mesh lies within the walls, floor and ceiling, the camera inside them, and no two
    pieces of furniture overlap (their bounding boxes, which contain them, are apart)."""
    from spectral_cam.presets.room import room_layout, room_view

    config = _config(**{"scene.layout_seed": seed})
    layout = room_layout(config)
    lo = np.array([layout.east_m[0], layout.north_m[0], 0.0]) - 1e-9
    hi = np.array([layout.east_m[1], layout.north_m[1], layout.height_m]) + 1e-9
    for piece in layout.pieces:
        assert np.all(piece.vertices >= lo) and np.all(piece.vertices <= hi), piece.name
    camera = room_view(config).camera_m
    assert np.all(camera > lo + 0.3) and np.all(camera < hi - 0.3)
    for (a, (alo, ahi)), (b, (blo, bhi)) in itertools.combinations(_groups(layout).items(), 2):
        overlap = np.minimum(ahi, bhi) - np.maximum(alo, blo)
        assert np.any(overlap <= 0), (a, b)


def test_the_layout_seed_draws_the_room():
    """The same seed gives the same room; another seed moves the furniture and repaints it."""
    from spectral_cam.presets.room import room_layout

    def summary(seed):
        layout = room_layout(_config(**{"scene.layout_seed": seed}))
        return layout.yaw_deg, {p.name: p.vertices.mean(axis=0).round(6).tolist() for p in layout.pieces}

    first, again, other = summary(0), summary(0), summary(1)
    assert first == again
    assert first != other
    moved = [n for n in first[1] if n in other[1] and first[1][n] != other[1][n]]
    assert "sofa_back" in moved and any(n.startswith("book_") for n in moved)


def test_too_many_things_for_the_table_are_refused():
    from spectral_cam.errors import ConfigError
    from spectral_cam.presets.room import room_layout

    with pytest.raises(ConfigError, match="object_count"):
        room_layout(_config(**{"scene.object_count": 150}))
