"""Issue 41 #5: every tone curve's registry entry carries the DNG ProfileToneCurve its RAWs get.

References: the DNG specification 1.7.1.0 (ProfileToneCurve, tag 50940: linear input → output
pairs, applied before the reader's output encoding), Adobe's DNG SDK 1.7 (``dng_render.cpp``,
``dng_tone_curve_acr3_default``: the published table), Narkowicz (2016) for the filmic fit,
colour-science's sRGB encoding; tifffile reads the tag back from the file.
"""

from __future__ import annotations

import colour
import numpy as np
import pytest
import tifffile

import spectral_cam as sc
from spectral_cam.errors import ConfigError
from spectral_cam.isp.tone import TONE, profile_tone_curve, srgb_oetf
from spectral_cam.radiance_targets import lambertian_radiance, uniform_image
from spectral_cam.raw import write_dng

pytestmark = pytest.mark.timeout(180)

#: Adobe DNG SDK 1.7, source/dng_render.cpp, dng_tone_curve_acr3_default::Evaluate's kTable at
#: inputs k/8 (its entries 0, 128, …, 1024 of 1025), copied from the SDK source (commit 021f4f7 of
#: the AOSP mirror), not from spectral_cam/data.
ACR3_PUBLISHED = {0.0: 0.00000, 0.125: 0.25961, 0.25: 0.52069, 0.375: 0.69035, 0.5: 0.80486,
                  0.625: 0.88453, 0.75: 0.93986, 0.875: 0.97702, 1.0: 1.00000}


def _narkowicz(x):
    """Narkowicz (2016), ACES filmic tone mapping curve, as published."""
    a, b, c, d, e = 2.51, 0.03, 2.43, 0.59, 0.14
    return (x * (a * x + b)) / (x * (c * x + d) + e)


#: What each bundled curve's DNG must carry, from the sources above (never from spectral_cam).
REFERENCE = {"adobe": None,  # checked at the SDK's published nodes
             "srgb": lambda x: x,  # the reader's sRGB encoding is the whole rendering
             "filmic": _narkowicz,
             "linear": lambda x: x}  # no DNG form: declared None, the identity written


@pytest.fixture
def registry(monkeypatch):
    """TONE as it is, restored after the test (a toy entry must not leak into other tests)."""
    monkeypatch.setattr(TONE, "_entries", dict(TONE._entries))
    return TONE


def _toy(linear, *, ev=0.0):
    """A toy look: x^0.8 on the exposed linear values (clipped to [0, 1]), then the sRGB encoding."""
    exposed = np.clip(np.asarray(linear, np.float32) * np.float32(2.0 ** ev), 0, 1)
    return srgb_oetf(exposed ** np.float32(0.8))


def test_a_tone_curve_registered_from_outside_reaches_the_dngs_it_renders(registry, tmp_path):
    """A toy entry added from this module: a scene that names it exposes a RAW whose DNG carries
    the toy's curve x^0.8 (tifffile reads tag 50940), not the identity, with DefaultBlackRender
    None (the toy has no black point of its own)."""
    registry.add("toy_power", _toy, dng_curve=lambda x: x ** 0.8, description="x^0.8, a test's toy")
    scene = sc.scene_from_dict({"illuminant": {"spd": "D65"}, "isp": {"tone": "toy_power"},
                                "sensor": {"model": "ideal", "width_px": 16, "height_px": 16},
                                "exposure": {"time_s": "auto"}})
    image = uniform_image(lambertian_radiance("D65", [0.18], illuminance_lux=500.0)[0], (16, 16))
    path = write_dng(sc.expose(image, scene), tmp_path / "toy.dng")
    with tifffile.TiffFile(path) as tif:
        pairs = np.asarray(tif.pages[0].tags[50940].value, float).reshape(-1, 2)
        black_render = tif.pages[0].tags[51110].value
    assert len(pairs) == 129
    np.testing.assert_allclose(pairs[:, 0], np.linspace(0, 1, 129), atol=1e-7)
    np.testing.assert_allclose(pairs[:, 1], pairs[:, 0] ** 0.8, atol=1e-6)  # float32 in the file
    assert black_render == 1
    # a toy that places black itself, as Adobe's rendering does, asks readers for Auto (DNG 1.7.1 §6, 51110)
    registry.add("toy_black", _toy, dng_curve=lambda x: x ** 0.8, sets_black=True, description="sets black")
    black = sc.expose(image, scene.replace(**{"isp.tone": "toy_black"}))
    with tifffile.TiffFile(write_dng(black, tmp_path / "black.dng")) as tif:
        assert tif.pages[0].tags[51110].value == 0


def test_a_tone_curve_that_does_not_say_what_its_dngs_carry_is_refused(registry):
    """No silent identity: an entry without ``dng_curve`` (or with one that is not a function) is a
    ValueError naming the choice to make, and the name stays unregistered."""
    with pytest.raises(ValueError, match=r"toy_silent.*dng_curve=.*dng_curve=None"):
        registry.add("toy_silent", _toy)
    with pytest.raises(ValueError, match="dng_curve"):
        registry.register("toy_decorated")(_toy)
    with pytest.raises(ValueError, match="dng_curve"):
        registry.add("toy_number", _toy, dng_curve=0.8)
    assert not {"toy_silent", "toy_decorated", "toy_number"} & set(registry)
    registry.add("toy_none", _toy, dng_curve=None)  # the explicit choice: no DNG form, the identity
    np.testing.assert_array_equal(profile_tone_curve("toy_none")[:, 1], np.linspace(0, 1, 129))


def test_a_dng_curve_that_leaves_zero_one_is_a_config_error(registry):
    registry.add("toy_high", _toy, dng_curve=lambda x: 2 * x)
    with pytest.raises(ConfigError, match=r"toy_high.*\[0, 1\]"):
        profile_tone_curve("toy_high")


def test_every_bundled_tone_curve_has_an_independent_reference():
    """A bundled curve added without a reference here fails, so the next one is checked too."""
    assert set(TONE) == set(REFERENCE)


@pytest.mark.parametrize("method", sorted(REFERENCE))
def test_each_bundled_curve_writes_the_function_it_names(method):
    """``adobe``: the DNG SDK's published ACR3 table at its nodes; ``filmic``: Narkowicz's fit;
    ``srgb``, ``linear``: the identity. Where the curve is a rendering's whole (srgb, filmic), the
    reader's rendering of a neutral (the curve, then colour-science's sRGB encoding) is ours."""
    pairs = profile_tone_curve(method)
    x, y = pairs[:, 0], pairs[:, 1]
    np.testing.assert_allclose(x, np.linspace(0.0, 1.0, 129), atol=0)
    if method == "adobe":
        nodes = np.isin(x, list(ACR3_PUBLISHED))
        assert nodes.sum() == len(ACR3_PUBLISHED)
        np.testing.assert_allclose(y[nodes], [ACR3_PUBLISHED[v] for v in x[nodes]], atol=1e-7)
        return
    np.testing.assert_allclose(y, REFERENCE[method](x), atol=1e-12)
    if method in ("srgb", "filmic"):
        neutral = np.repeat(x[None, :, None], 3, axis=-1).astype(np.float32)
        shown = TONE[method](neutral)[0, :, 1]
        np.testing.assert_allclose(shown, colour.cctf_encoding(y, function="sRGB"), atol=2e-6)
