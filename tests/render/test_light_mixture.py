"""Issue 27 #4: the per-pixel illuminant of a scene with several lights (LSMI's mixture map),
checked against the inverse-square law and NumPy integrals of the camera curves."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam import scene_from_dict
from spectral_cam.camera_record import intrinsics_matrix
from spectral_cam.errors import ConfigError
from spectral_cam.optics import ThinLens
from spectral_cam.render.light_mixture import render_light_mixture
from spectral_cam.sensor import film_curves

pytestmark = pytest.mark.timeout(240)

WL = np.arange(360.0, 831.0, 5.0)
SIZE = (64, 48)
DISTANCE_M = 3.0  # camera to the board
# Two point lights 1 m in front of the board: a 2700 K Planckian on the left, D65 up right.
WARM_AT, COOL_AT = (-1.0, 0.0, 1.0), (1.0, 0.5, 1.0)
WARM_SCALE, COOL_SCALE = 3.0, 2.0

BOARD = """<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="70"/>
    <transform name="to_world"><lookat origin="0, 0, {distance}" target="0, 0, 0" up="0, 1, 0"/></transform>
  </sensor>
  <shape type="rectangle" id="board"><transform name="to_world"><scale value="4"/></transform>
    <bsdf type="diffuse"><spectrum name="reflectance" value="0.5"/></bsdf></shape>
  {lights}
</scene>"""


def _planck(temperature_k: float) -> np.ndarray:
    """Planck's law on WL, max 1 (CODATA 2018 h, c, k)."""
    h, c, k = 6.62607015e-34, 299792458.0, 1.380649e-23
    wl = WL * 1e-9
    values = 1.0 / (wl ** 5 * np.expm1(h * c / (wl * k * temperature_k)))
    return values / values.max()


def _d65() -> np.ndarray:
    import colour

    values = colour.SDS_ILLUMINANTS["D65"].copy().align(colour.SpectralShape(360, 830, 5)).values
    return values / values.max()


def _point(name: str, at, spectrum, scale) -> str:
    table = ", ".join(f"{w:g}:{v * scale:.7g}" for w, v in zip(WL, spectrum))
    named = f' id="{name}"' if name else ""
    return (f'<emitter type="point"{named}><point name="position" value="{at[0]}, {at[1]}, {at[2]}"/>'
            f'<spectrum name="intensity" value="{table}"/></emitter>')


def _board(tmp_path, lights: str):
    path = tmp_path / "board.xml"
    path.write_text(BOARD.format(distance=DISTANCE_M, lights=lights))
    return scene_from_dict({"scene": {"mitsuba_xml": str(path)}, "sensor": {"width_px": SIZE[0], "height_px": SIZE[1]},
                            "render": {"spp": 16}})


def test_two_lamps_shares_follow_the_inverse_square_law_and_their_colours_the_camera_curves(tmp_path):
    """A grey board lit by a 2700 K and a D65 point light: each lamp's share of the green signal
    equals G_i ∝ I_i·cos θ_i / r_i² = I_i·h / r_i³ (h = 1 m, the lamps' height above the board) within
    0.02 at every pixel (measured 0.005 at 64 rays per pixel), each lamp's camera RGB equals a NumPy
    integral of the camera curves against its spectrum within 0.5 %, and each pixel's illuminant is
    the shares' mix of the two within 0.5 % on average and 1 % over any 5 × 5 px (measured 0.17 % and
    0.19 % at 64 rays per pixel and channel)."""
    from scipy.ndimage import uniform_filter

    warm, cool = _planck(2700.0), _d65()
    config = _board(tmp_path, _point("warm", WARM_AT, warm, WARM_SCALE) + _point("cool", COOL_AT, cool, COOL_SCALE))
    mixture = render_light_mixture(config, spp=64)
    assert mixture.names == ["warm", "cool"]

    curves = film_curves(config, WL)
    for k, spectrum in enumerate((warm, cool)):
        rgb = spectrum @ curves
        np.testing.assert_allclose(mixture.camera_rgb_g1[k], rgb / rgb[1], rtol=0.005)

    # Pixel → board point through K (x right is world +x, y down is world −y for this look-at).
    K = intrinsics_matrix(ThinLens.from_config(config.lens, config.sensor))
    v, u = np.mgrid[0:SIZE[1], 0:SIZE[0]]
    x, y = (u - K[0, 2]) / K[0, 0] * DISTANCE_M, -(v - K[1, 2]) / K[1, 1] * DISTANCE_M

    def green(at, spectrum, scale):
        r = np.sqrt((x - at[0]) ** 2 + (y - at[1]) ** 2 + at[2] ** 2)
        return scale * (spectrum @ curves[:, 1]) * at[2] / r ** 3

    g_warm, g_cool = green(WARM_AT, warm, WARM_SCALE), green(COOL_AT, cool, COOL_SCALE)
    expected = g_warm / (g_warm + g_cool)
    assert expected.min() < 0.2 and expected.max() > 0.8  # the board does hold both lights' regions
    assert np.abs(mixture.shares[..., 0] - expected).max() < 0.02
    np.testing.assert_allclose(mixture.shares.sum(axis=-1), 1.0, atol=1e-6)
    mixed = expected[..., None] * mixture.camera_rgb_g1[0] + (1 - expected[..., None]) * mixture.camera_rgb_g1[1]
    error = mixture.illuminant_rgb - mixed
    assert np.abs(error).mean() < 0.005 and np.abs(uniform_filter(error, (5, 5, 1))).max() < 0.01
    np.testing.assert_array_equal(mixture.illuminant_rgb[..., 1], 1.0)


def test_under_a_uniform_sky_the_light_is_the_sky_everywhere(tmp_path):
    """The board under a constant environment of radiance L(λ) alone: the irradiance is πL on every
    point of an open plane, so every pixel's light is the camera RGB of L (a NumPy integral, green 1):
    within 0.2 % over the frame and 1.5 % over any 5 × 5 px (measured 0.02 % and 0.5 % at 64 rays per
    pixel and channel)."""
    from scipy.ndimage import uniform_filter

    sky = _d65() * np.linspace(1.3, 0.7, WL.size)  # bluish daylight
    table = ", ".join(f"{w:g}:{v:.7g}" for w, v in zip(WL, sky))
    config = _board(tmp_path, f'<emitter type="constant" id="sky"><spectrum name="radiance" value="{table}"/></emitter>')
    mixture = render_light_mixture(config, spp=64)
    rgb = sky @ film_curves(config, WL)
    np.testing.assert_allclose(mixture.camera_rgb_g1[0], rgb / rgb[1], rtol=0.005)
    np.testing.assert_allclose(mixture.illuminant_rgb.reshape(-1, 3).mean(axis=0), rgb / rgb[1], rtol=0.002)
    smooth = uniform_filter(mixture.illuminant_rgb, (5, 5, 1))[2:-2, 2:-2]
    np.testing.assert_allclose(smooth, np.broadcast_to(rgb / rgb[1], smooth.shape), rtol=0.015)
    assert mixture.names == ["sky"] and np.all(mixture.shares == 1.0)


def test_an_emissive_chart_has_its_illuminant_everywhere():
    """dead_leaves (leaves are emitters of ρ·E/π standing in for lit surfaces) under CIE A: every share
    is 1 and the illuminant is the camera's response to colour-science's A, green 1, within 0.5 %;
    nothing is rendered."""
    import colour

    config = scene_from_dict({"scene": {"preset": "dead_leaves"}, "illuminant": {"spd": "A"},
                              "sensor": {"width_px": 24, "height_px": 16}})
    mixture = render_light_mixture(config)
    assert mixture.spp == 0 and mixture.names == ["illuminant"] and np.all(mixture.shares == 1.0)
    a = colour.SDS_ILLUMINANTS["A"].copy().align(colour.SpectralShape(360, 830, 5)).values
    rgb = a @ film_curves(config, WL)
    np.testing.assert_allclose(mixture.illuminant_rgb[5, 7], rgb / rgb[1], rtol=0.005)


def test_emitters_without_ids_are_named_in_the_error(tmp_path):
    """Two lamps without ids cannot be dimmed one at a time: the error says to give each an id."""
    config = _board(tmp_path, _point("", WARM_AT, _planck(2700.0), 1.0) + _point("", COOL_AT, _d65(), 1.0))
    with pytest.raises(ConfigError, match="give each emitter .* an id"):
        render_light_mixture(config, spp=4)
