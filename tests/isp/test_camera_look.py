"""Issue 23 #1–#2: exposure metered like a camera (ISO 12232 standard output sensitivity) and a
camera's tone curve (Adobe's default rendering), with display arrays in [0, 1].

References: ISO 12232:2019 (mid grey at H = 10/S renders at 118 of 255 in sRGB; S_sat = 78/H_sat),
colour-science's sRGB decoding, Adobe's DNG SDK (dng_render.cpp: the ACR3 curve, exposure ramp;
BaselineExposure read through dngpy), tifffile reading the ProfileToneCurve we write.
"""

from __future__ import annotations

import colour
import numpy as np
import pytest
import tifffile
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import CubicSpline

import spectral_cam as sc
from spectral_cam import spectra
from spectral_cam.radiance_targets import lambertian_radiance, uniform_image
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.isp.config import TONE_METHODS
from spectral_cam.isp.tone import adobe_exposure_ramp
from spectral_cam.metering import GREY_RAW
from spectral_cam.raw import RawImage, read_raw, write_dng

pytestmark = pytest.mark.timeout(240)

#: ISO 12232:2019 §6: the standard output sensitivity's mid grey, 118 of 255 in sRGB.
SOS_GREY = 118.0


def _grey_field(model: str, *, shape=(48, 64), illuminant="D65", lux=500.0, **exposure):
    """An 18 % grey Lambertian field (ρE/π, exact) through a camera at the defaults."""
    scene = sc.scene_from_dict({"illuminant": {"spd": illuminant, "illuminance_lux": lux},
                                "sensor": {"model": model, "width_px": shape[1], "height_px": shape[0]},
                                "exposure": {"time_s": "auto", **exposure}})
    image = uniform_image(lambertian_radiance(illuminant, [0.18], illuminance_lux=lux)[0], shape)
    return scene, sc.expose(image, scene)


@pytest.mark.parametrize("model", [m for m in spectra.camera_names()] + ["ideal"])
def test_an_18_percent_grey_field_develops_to_118_of_255_for_every_camera(model):
    """The defaults (average metering, SOS, Adobe's curve) show an 18 % grey card at 118 ± 6 of
    255 (ISO 12232 SOS), measured on the developed 8-bit values."""
    scene, raw = _grey_field(model)
    image = develop(raw, scene.isp).image
    assert np.round(image * 255).mean() == pytest.approx(SOS_GREY, abs=6)
    assert raw.meta["exposure_index"]["iso_definition"] == "sos"


@pytest.mark.parametrize("illuminant", ["A", "FL11", "LED-B1"])
def test_the_grey_card_develops_to_118_under_other_lights(illuminant):
    """The meter reads white-balanced luminance, so a tungsten, fluorescent or LED light meters
    the grey card as daylight does (the channel with gain 1 carries it)."""
    scene, raw = _grey_field("nikon_d850", illuminant=illuminant)
    assert np.round(develop(raw, scene.isp).image * 255).mean() == pytest.approx(SOS_GREY, abs=6)


def test_the_rendered_flat_field_scene_at_its_defaults_develops_to_118():
    """The bundled flat-field scene, path-traced (vignetting included), through the whole chain."""
    scene = sc.load_scene("scenes/flat_field.toml", overrides={"sensor.width_px": 64, "sensor.height_px": 48,
                                                               "render.spp": 4})
    raw = sc.expose(sc.render(scene), scene)
    assert np.round(develop(raw, scene.isp).image * 255).mean() == pytest.approx(SOS_GREY, abs=6)


@pytest.mark.parametrize("tone", TONE_METHODS)
def test_sos_holds_for_every_tone_curve_through_the_baseline_exposure(tone):
    """Whatever curve the ISP applies, the RAW's grey sits at 10/78 of saturation (the exposure
    does not depend on the rendering) and the BaselineExposure written with it brings the grey
    to 118: sRGB-decoded by colour-science it is linear 0.18 (the sRGB curve) or 118/255."""
    scene, raw = _grey_field("nikon_d850", shape=(32, 32))
    scene = scene.replace(**{"isp.tone": tone})
    raw = sc.expose(uniform_image(lambertian_radiance("D65", [0.18], illuminance_lux=500.0)[0], (32, 32)), scene)
    normalised = (raw.mosaic.astype(float) - raw.black_level) / (raw.white_level - raw.black_level)
    # the channel with white-balance gain 1 carries the metered grey: 10/78 of saturation
    sites = [normalised[0::2, 0::2], normalised[0::2, 1::2], normalised[1::2, 1::2]]  # RGGB: R, G, B
    assert max(site.mean() for site in sites) == pytest.approx(GREY_RAW, rel=0.02)
    shown = develop(raw, scene.isp).image.mean()
    assert shown * 255 == pytest.approx(SOS_GREY, abs=3)
    if tone == "srgb":
        assert float(colour.cctf_decoding(shown, function="sRGB")) == pytest.approx(0.18, rel=0.03)


def test_saturation_based_iso_leaves_the_rendering_alone():
    """``iso_definition = "saturation"``: the RAW is the same, no BaselineExposure, so the grey
    shows where the curve puts 12.8 %: Adobe's curve lifts it above SOS's 118."""
    _, sos = _grey_field("nikon_d850", shape=(32, 32))
    scene, saturation = _grey_field("nikon_d850", shape=(32, 32), iso_definition="saturation")
    np.testing.assert_array_equal(sos.mosaic, saturation.mosaic)
    assert saturation.baseline_exposure == 0.0 and sos.baseline_exposure < 0
    assert develop(saturation, scene.isp).image.mean() * 255 > SOS_GREY + 15


def test_metering_modes_place_a_bright_window_as_a_camera_would():
    """An 18 % grey frame with a window (⅛ of it) of a 90 % white in 30× the light: average
    metering exposes for the mean and nearly clips the window, highlight metering keeps it at
    0.8 of saturation, as expose to the right does; compensation +1 EV doubles the average's
    exposure."""
    d65 = lambertian_radiance("D65", [0.18, 0.9], illuminance_lux=500.0)
    data = np.empty((32, 64, d65.shape[1]), np.float32)
    data[:], data[:, 56:] = d65[0], 30 * d65[1]
    image = uniform_image(d65[0], (32, 64))
    image = type(image)(data, image.wavelengths_nm, image.band_edges_nm)
    times = {}
    for metering, comp in (("average", 0), ("average", 1), ("highlight", 0), ("etr", 0)):
        scene = sc.scene_from_dict({"illuminant": {"spd": "D65"}, "sensor": {"width_px": 64, "height_px": 32,
                                                                              "vignetting": False},
                                    "exposure": {"time_s": "auto", "metering": metering, "compensation_ev": comp}})
        raw = sc.expose(image, scene)
        times[metering, comp] = raw.meta["exposure_s"]
        bright = (raw.mosaic[:, 56:].astype(float) - raw.black_level) / (raw.white_level - raw.black_level)
        peak = max(bright[a::2, b::2].mean() for a in (0, 1) for b in (0, 1))  # the brightest CFA site
        if metering != "average":
            assert peak <= 0.8 * 1.01
    assert times["average", 1] == pytest.approx(2 * times["average", 0], rel=1e-6)
    assert times["highlight", 0] < times["average", 0] and times["etr", 0] == pytest.approx(times["highlight", 0],
                                                                                            rel=0.02)


# ----------------------------------------------------------------------------- tone curve, DNG
def test_the_profile_tone_curve_we_write_is_what_our_develop_applies(tmp_path):
    """A neutral ramp developed with Adobe's rendering equals, within 10⁻³, the DNG's
    ProfileToneCurve (read back by tifffile, a natural cubic spline through its points as
    Adobe's reader fits one) after Adobe's exposure ramp; dngpy (Adobe's SDK) reads the same
    BaselineExposure our develop applied."""
    scene, raw = _grey_field("nikon_d850", shape=(24, 32))
    path = write_dng(raw, tmp_path / "grey.dng")
    with tifffile.TiffFile(path) as tif:
        tags = tif.pages[0].tags
        pairs = np.asarray(tags[50940].value, float).reshape(-1, 2)
        black_render = tags[51110].value
    assert black_render == 0  # Adobe's curve: the reader's own default shadows, as our develop
    curve = CubicSpline(pairs[:, 0], pairs[:, 1], bc_type="natural")
    ramp = np.linspace(0.0, 1.0, 1001)
    rgb = np.repeat(ramp[None, :, None], 3, axis=-1).astype(np.float32)
    ours = develop_linear_neutral(rgb)
    expected = curve(adobe_exposure_ramp(ramp, ev=0.0))
    np.testing.assert_allclose(colour.cctf_decoding(ours, function="sRGB")[0, :, 1], expected, atol=1e-3)
    back = read_raw(path)
    assert back.baseline_exposure == pytest.approx(raw.baseline_exposure, abs=1e-6)
    import dngpy  # Adobe's DNG SDK: the test extra installs it
    # the SDK reports it to the hundredth of a stop
    assert dngpy.Dng(str(path)).get_baseline_exposure() == pytest.approx(raw.baseline_exposure, abs=0.006)


def develop_linear_neutral(rgb: np.ndarray) -> np.ndarray:
    """The tone stage alone on a linear image (what develop applies after the colour matrix)."""
    from spectral_cam.isp.tone import tone_map

    return tone_map(rgb, method="adobe", ev=0.0)


def test_the_default_rendering_rolls_off_highlights_instead_of_clipping():
    """Adobe's curve: a white 1 EV above the SOS grey's white is still below display white
    (the bare sRGB curve clips it), and display values fall monotonically with exposure."""
    from spectral_cam.isp.tone import tone_map

    ramp = np.repeat(np.geomspace(1e-3, 1.0, 200)[None, :, None], 3, axis=-1).astype(np.float32)
    adobe, srgb = tone_map(ramp, method="adobe")[0, :, 1], tone_map(ramp, method="srgb", ev=1.0)[0, :, 1]
    assert np.all(np.diff(adobe) >= 0)
    assert adobe[-1] == pytest.approx(1.0, abs=1e-6) and adobe[-20] < 0.99  # a shoulder, not a clip
    assert np.sum(srgb >= 1.0) >= 19  # the sRGB curve at +1 EV clips the top stop (10 % of 3 decades)


# ----------------------------------------------------------------------------- display range
@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), tone=st.sampled_from(TONE_METHODS), ev=st.floats(-8, 8),
       sharpen=st.sampled_from([0.0, 3.0]), black=st.integers(0, 600), demosaic=st.sampled_from(["menon2007",
                                                                                                 "bilinear"]))
def test_developed_images_are_display_values_in_zero_one_for_any_input(seed, tone, ev, sharpen, black, demosaic):
    """Any mosaic (noise, hard edges, clipped and black pixels), any tone, exposure and
    sharpening: ``DevelopedImage.image`` lies in [0, 1] and is finite (demosaic undershoot used
    to leave −1.45); ``.linear`` stays scene-referred (unclipped)."""
    rng = np.random.default_rng(seed)
    mosaic = rng.integers(0, 4096, (24, 32)).astype(np.uint16)
    mosaic[:, ::7] = 4095
    mosaic[::5] = 0
    raw = RawImage(mosaic, "RGGB", float(black), 4095, as_shot_neutral=np.array([0.5, 1.0, 0.7]),
                   color_matrix=np.array([[0.9, 0.2, -0.1], [-0.3, 1.2, 0.1], [0.05, -0.2, 0.9]]))
    out = develop(raw, ISPConfig(tone=tone, exposure_ev=ev, sharpen=sharpen, demosaic=demosaic))
    assert np.all(np.isfinite(out.image)) and out.image.min() >= 0.0 and out.image.max() <= 1.0
    if ev > 4:  # scene-referred: .linear keeps what the display clips
        assert out.linear.max() > 1.0
