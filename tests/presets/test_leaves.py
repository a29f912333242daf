"""Issue 24 #3: leaves from PROSPECT-D that reflect and transmit.

References: ``prosail``'s PROSPECT-D (Féret et al. 2017) for R and T; a Lambertian transmitter
lit from behind by irradiance E sends L = T·E/π to the camera (and a reflector lit from the
front R·E/π), integrated over each band of the film.
"""

from __future__ import annotations

import numpy as np
import prosail
import pytest

import spectral_cam as sc
from spectral_cam.leaves import HEALTH_STATES, LeafTraits, draw_traits, prospect_d
from spectral_cam.presets.common import leaf_bsdf
from spectral_cam.presets.vegetation import plant_health

pytestmark = pytest.mark.timeout(240)

TRAITS = [LeafTraits(), LeafTraits(n=1.8, cab=20.0, car=6.0, ant=2.0, brown=0.1, cw=0.008, cm=0.005),
          LeafTraits(n=2.2, cab=2.0, car=1.0, ant=0.2, brown=1.5, cw=0.001, cm=0.008)]


@pytest.mark.parametrize("traits", TRAITS, ids=["healthy", "stressed", "dry"])
def test_reflectance_and_transmittance_are_prospect_d(traits):
    """Over 400–1000 nm our leaf equals prosail's PROSPECT-D within 10⁻³, and the spectra a
    Mitsuba leaf carries (2-nm samples, interpolated linearly) do too over Mitsuba's 400–830 nm."""
    wl, r, t = prosail.run_prospect(traits.n, traits.cab, traits.car, traits.brown, traits.cw, traits.cm,
                                    ant=traits.ant, prospect_version="D")
    within = (wl >= 400) & (wl <= 1000)
    ours_r, ours_t = prospect_d(traits, wl[within])
    np.testing.assert_allclose(ours_r, r[within], atol=1e-3)
    np.testing.assert_allclose(ours_t, t[within], atol=1e-3)
    bsdf = leaf_bsdf(traits)
    visible = (wl >= 400) & (wl <= 830)
    for key, reference in (("reflectance", r), ("transmittance", t)):
        table = np.asarray(bsdf[key]["value"])
        np.testing.assert_allclose(np.interp(wl[visible], table[:, 0], table[:, 1]), reference[visible], atol=1e-3)


def test_a_healthy_leaf_transmits_as_leaves_do():
    """Real leaves transmit 40–50 % in the near infrared and 5–15 % in the green."""
    r, t = prospect_d(LeafTraits(), [550.0, 850.0])
    assert 0.05 <= t[0] <= 0.15 and 0.4 <= t[1] <= 0.55 and r[1] + t[1] < 1.0


def _band_radiance(traits, light_direction):
    """Radiance of a leaf plane facing the camera, lit by a directional light of 1 W·m⁻² per nm,
    in 10-nm bands (a rendered film, 64 spp, through our registered leaf BSDF)."""
    import mitsuba as mi

    from spectral_cam.render.leaf_bsdf import register
    from spectral_cam.render.variants import choose_variant

    mi.set_variant(choose_variant("auto"))
    register(mi)
    centres = np.arange(450.0, 800.0, 50.0)
    film = {"type": "specfilm", "width": 8, "height": 8, "rfilter": {"type": "box"}, "component_format": "float32"}
    for k, c in enumerate(centres):
        film[f"band_{k:02d}"] = {"type": "spectrum", "value": [(c - 5.0, 1.0), (c + 5.0, 1.0)]}
    scene = mi.load_dict({
        "type": "scene", "integrator": {"type": "path", "max_depth": 4},
        "sensor": {"type": "perspective", "fov": 5.0, "film": film,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 0], target=[0, 0, 1], up=[0, 1, 0])},
        "leaf": {"type": "rectangle", "to_world": mi.ScalarTransform4f().translate([0, 0, 1]), "bsdf": leaf_bsdf(traits)},
        "light": {"type": "directional", "direction": light_direction, "irradiance": {"type": "uniform", "value": 1.0}},
    })
    image = np.asarray(mi.render(scene, spp=64), dtype=np.float64)
    return centres, image.reshape(-1, len(centres)).mean(axis=0)


def _band_means(values_of, centres):
    fine = np.arange(-5.0, 5.01, 0.1)
    return np.array([np.trapezoid(values_of(c + fine), fine) for c in centres])


@pytest.mark.parametrize("traits", TRAITS[:2], ids=["healthy", "stressed"])
def test_a_leaf_lit_from_behind_sends_t_e_over_pi(traits):
    """The sun behind a leaf: the camera sees T·E/π (band integrals) within 2 %; lit from the
    camera's side, R·E/π."""
    centres, behind = _band_radiance(traits, [0, 0, -1])  # travelling towards the camera
    expected = _band_means(lambda w: prospect_d(traits, w)[1], centres) / np.pi
    np.testing.assert_allclose(behind, expected, rtol=0.02)
    centres, front = _band_radiance(traits, [0, 0, 1])
    expected = _band_means(lambda w: prospect_d(traits, w)[0], centres) / np.pi
    np.testing.assert_allclose(front, expected, rtol=0.02)


def test_plant_health_is_drawn_by_fraction_and_seed():
    config = sc.scene_from_dict({"scene": {"preset": "vegetation", "dry_fraction": 0.1, "stressed_fraction": 0.3}})
    plants = plant_health(config, 400)
    assert plants == plant_health(config, 400)
    shares = {state: np.mean([p["state"] == state for p in plants]) for state in HEALTH_STATES}
    assert shares["dry"] == pytest.approx(0.1, abs=0.04) and shares["stressed"] == pytest.approx(0.3, abs=0.06)
    for plant in plants:
        low, high = HEALTH_STATES[plant["state"]]["cab"]
        assert low <= plant["traits"]["cab"] <= high


def test_health_states_order_chlorophyll_and_refuse_unknown_states():
    rng = np.random.default_rng(0)
    cab = {state: np.mean([draw_traits(rng, state).cab for _ in range(50)]) for state in HEALTH_STATES}
    assert cab["healthy"] > cab["stressed"] > cab["dry"]
    with pytest.raises(sc.errors.ConfigError, match="valid: healthy, stressed, dry"):
        draw_traits(rng, "sick")
    with pytest.raises(sc.errors.ConfigError, match="stressed_fraction"):
        sc.scene_from_dict({"scene": {"preset": "vegetation", "dry_fraction": 0.6, "stressed_fraction": 0.6}})


def test_the_health_label_marks_each_plants_pixels_and_health_shows_in_the_image(tmp_path):
    """The dataset's health map: its plant pixels are the pixels nearer than the analytic ground
    plane (the depth label, independently), each plant's chlorophyll is its drawn trait, and the
    developed image shows it: healthy leaves greener (excess green 2g − r − b) than stressed ones."""
    import OpenEXR

    from spectral_cam.apps.dataset.labels import HEALTH_CODES, write_item
    from spectral_cam.apps.sequence.drift import plant_mask

    config = sc.load_scene("scenes/vegetation.toml", overrides={"sensor.width_px": 160, "sensor.height_px": 108,
                                                               "render.spp": 16, "scene.stressed_fraction": 0.4})
    meta = write_item(config, tmp_path / "item", outputs=["image", "depth", "health"])
    channels = OpenEXR.File(str(tmp_path / "item" / "health.exr")).channels()
    state, cab = channels["state"].pixels, channels["cab"].pixels
    depth = OpenEXR.File(str(tmp_path / "item" / "depth.exr")).channels()
    depth = next(iter(depth.values())).pixels
    plants = plant_mask(config, depth)
    assert np.mean((state > 0) == plants) > 0.95  # one sample per pixel each: edges may differ (97.7 % agree)
    for plant in meta["health"]["plants"]:
        if plant["pixels"]:
            assert np.any(np.isclose(cab, plant["traits"]["cab"]))
    import cv2

    image = cv2.imread(str(tmp_path / "item" / "image.png"))[..., ::-1].astype(float)
    chroma = image / np.maximum(image.sum(axis=-1, keepdims=True), 1)
    exg = 2 * chroma[..., 1] - chroma[..., 0] - chroma[..., 2]
    healthy, stressed = state == HEALTH_CODES["healthy"], state == HEALTH_CODES["stressed"]
    assert healthy.sum() > 50 and stressed.sum() > 50
    assert exg[healthy].mean() > exg[stressed].mean() + 0.03


def test_a_crop_field_has_rows_of_plants_and_weeds_between_them():
    """``scene.layout = "rows"``: crop plants 0.75 m apart across the rows (jittered by 3 cm) and
    0.3 m along them, weeds between the rows, all on the ground the frame sees; the health map
    tells weeds from crop."""
    from spectral_cam.presets.vegetation import PLANT_SPACING_M, ROW_SPACING_M, field_layout
    from spectral_cam.optics import ThinLens

    config = sc.load_scene("scenes/field.toml")
    lens = ThinLens.from_config(config.lens, config.sensor)
    items = field_layout(config, lens)
    crop = np.array([(e, n) for name, e, n, _ in items if name.startswith("plant_")])
    weeds = np.array([(e, n) for name, e, n, _ in items if name.startswith("weed_")])
    assert len(crop) > 50 and len(weeds) > 10
    offset = crop[:, 0] / ROW_SPACING_M - np.round(crop[:, 0] / ROW_SPACING_M)
    assert np.abs(offset).max() * ROW_SPACING_M < 0.15
    weed_offset = weeds[:, 0] / ROW_SPACING_M - np.floor(weeds[:, 0] / ROW_SPACING_M)
    assert np.all((weed_offset > 0.25) & (weed_offset < 0.75))  # between the rows
    row = crop[np.round(crop[:, 0] / ROW_SPACING_M) == np.round(crop[0, 0] / ROW_SPACING_M)]
    gaps = np.diff(np.sort(row[:, 1]))
    assert np.median(gaps) == pytest.approx(PLANT_SPACING_M, rel=0.15)
