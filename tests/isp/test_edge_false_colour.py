"""False colour at sharp, off-grid edges (issue 37 #7): the default demosaic leaves no coloured rims.

Independent reference: a disc or a slanted half-plane at a sub-pixel position, in camera RGB
(already white-balanced), box-integrated over each pixel (16 × 16 sub-samples, the renders'
box filter, no optical low-pass filter); the same image mosaicked through the RGGB tile and
developed, against it developed as a three-colour (linear) RAW through the same ISP. Error:
the mean chroma difference ΔC*ab = |Δ(a*, b*)| (CIELAB of the sRGB display values) on the pixels
the edge crosses, dilated by 1 px. Colours: a sunlit leaf on dark soil (the vegetation scene's
magenta rims), sand against a blue shadow.

Measured (mean of 6 positions; old default menon2007 in brackets):
leaf/soil disc 4.7 (19.7), slanted 3.8 (19.0); sand/shadow disc 3.4 (8.7), slanted 3.0 (8.6).
menon2007 interpolates red and blue as green plus the neighbours' mean colour difference, which
jumps across a step between a saturated and a neutral colour: the leaf's rim turns magenta, the
soil's goes below zero (worse than bilinear, 6.6, on leaf/soil). The thresholds sit about 1.5×
above rcd and below half of menon2007.
"""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.cfa import LINEAR, channel_index
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.isp.demosaic import demosaic, rcd
from spectral_cam.raw import RawImage

pytestmark = pytest.mark.timeout(120)

LEAF, SOIL = (0.10, 0.55, 0.05), (0.05, 0.035, 0.02)
SAND, SHADOW = (0.70, 0.55, 0.40), (0.04, 0.05, 0.09)
SIZE, SUPERSAMPLE = 64, 16


def _scene(inside, a, b):
    """(camera RGB, coverage): each pixel the box-filtered mix of ``a`` (inside) and ``b``."""
    offsets = (np.arange(SUPERSAMPLE) + 0.5) / SUPERSAMPLE
    coords = (np.arange(SIZE)[:, None] + offsets[None, :]).ravel()
    hit = inside(coords[:, None], coords[None, :]).astype(np.float32)
    cover = hit.reshape(SIZE, SUPERSAMPLE, SIZE, SUPERSAMPLE).mean(axis=(1, 3))
    rgb = cover[..., None] * np.float32(a) + (1 - cover[..., None]) * np.float32(b)
    return rgb.astype(np.float32), cover


def _develop(rgb, method):
    """Display sRGB of ``rgb`` developed as a three-colour RAW (method None) or its RGGB mosaic."""
    white = 4095
    if method is None:
        raw = RawImage(rgb * white, LINEAR, black_level=0.0, white_level=white, as_shot_neutral=np.ones(3))
    else:
        index = channel_index(rgb.shape[:2], "RGGB").astype(np.intp)
        mosaic = np.take_along_axis(rgb, index[..., None], axis=2)[..., 0]
        raw = RawImage(mosaic * white, "RGGB", black_level=0.0, white_level=white, as_shot_neutral=np.ones(3))
    return develop(raw, ISPConfig(demosaic=method or "rcd", colour_matrix="none", tone="srgb")).image


def _edge_chroma_error(method, a, b, kind):
    import cv2
    from skimage.color import rgb2lab

    rng = np.random.default_rng(1)
    errors = []
    for k in range(6):
        cy, cx = SIZE / 2 + rng.random(2)
        if kind == "disc":
            radius = 13.0 + rng.random()

            def inside(y, x):
                return (y - cy) ** 2 + (x - cx) ** 2 < radius ** 2
        else:
            angle = np.deg2rad([3, 17, 30, 45, 60, 80][k])

            def inside(y, x):
                return (x - cx) * np.cos(angle) + (y - cy) * np.sin(angle) > 0
        truth, cover = _scene(inside, a, b)
        band = cv2.dilate(((cover > 0.02) & (cover < 0.98)).astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
        band[:6] = band[-6:] = False
        band[:, :6] = band[:, -6:] = False
        reference = rgb2lab(_develop(truth, None).astype(np.float64))
        out = rgb2lab(_develop(truth, method).astype(np.float64))
        errors.append(float(np.hypot(*(out[..., 1:] - reference[..., 1:]).transpose(2, 0, 1))[band].mean()))
    return float(np.mean(errors))


@pytest.mark.parametrize("a, b, kind, limit, old", [
    (LEAF, SOIL, "disc", 7.0, 19.7),
    (LEAF, SOIL, "slant", 6.0, 19.0),
    (SAND, SHADOW, "disc", 5.0, 8.7),
    (SAND, SHADOW, "slant", 4.5, 8.6),
])
def test_the_default_demosaic_leaves_no_coloured_rims_on_off_grid_edges(a, b, kind, limit, old):
    default = ISPConfig().demosaic
    assert default == "rcd"
    error = _edge_chroma_error(default, a, b, kind)
    assert error < limit, f"{default}: ΔC*ab {error:.2f} on the edge (limit {limit})"
    # the former default fails the same limit (measured `old`): the test tells the two apart
    former = _edge_chroma_error("menon2007", a, b, kind)
    assert former > 1.5 * limit and former == pytest.approx(old, abs=1.0)


def test_red_and_blue_do_not_overshoot_across_a_step_between_colours():
    # the mechanism of the rims: menon2007 gives red and blue at a pixel as its green plus the
    # neighbours' mean R − G, B − G, whatever side of the edge they lie on; across a saturated
    # leaf / neutral soil step those differences jump, so the leaf's edge pixels get the soil's
    # (R, B too high: magenta; measured B +144 %, R +58 %) and the soil's the leaf's (B below zero
    # at 18 % of the edge pixels: clipped, a dark rim). rcd weights each side by its inverse
    # gradient (measured: B +21 %, R +11 %; 1.2 % negative).
    truth, cover = _scene(lambda y, x: (y - 32.3) ** 2 + (x - 31.6) ** 2 < 13.4 ** 2, LEAF, SOIL)
    index = channel_index(truth.shape[:2], "RGGB")
    mosaic = np.ascontiguousarray(np.take_along_axis(truth, index[..., None].astype(np.intp), axis=2)[..., 0])
    edge = (cover > 0.02) & (cover < 0.98)
    leaf_side = edge & (cover >= 0.5)

    def errors(method):
        rgb = demosaic(mosaic, "RGGB", method=method)
        overshoot = ((rgb - truth) / truth)[leaf_side][:, [0, 2]].mean(axis=0)
        return overshoot, float((rgb[edge] < 0).any(axis=-1).mean())

    (red, blue), negative = errors("rcd")
    assert red < 0.2 and blue < 0.35 and negative < 0.03
    (red, blue), negative = errors("menon2007")
    assert red > 0.4 and blue > 1.0 and negative > 0.1


@pytest.mark.parametrize("cfa", ["RGGB", "GRBG", "GBRG", "BGGR"])
def test_rcd_is_exact_on_linear_colour_ramps_and_keeps_samples_without_the_median(cfa):
    y, x = np.mgrid[0:48, 0:40].astype(np.float32)
    truth = np.stack([0.2 + 0.003 * x, 0.3 + 0.002 * y, 0.25 + 0.001 * (x + y)], axis=-1).astype(np.float32)
    index = channel_index(truth.shape[:2], cfa).astype(np.intp)
    mosaic = np.ascontiguousarray(np.take_along_axis(truth, index[..., None], axis=2)[..., 0])
    np.testing.assert_allclose(rcd(mosaic, cfa)[6:-6, 6:-6], truth[6:-6, 6:-6], atol=1e-5)
    plain = rcd(mosaic, cfa, median=False)
    np.testing.assert_array_equal(np.take_along_axis(plain, index[..., None], axis=2)[..., 0], mosaic)


def test_rcd_does_not_depend_on_the_cut_into_bands_and_takes_any_size():
    from spectral_cam.isp.rcd import rcd as rcd_bands

    rng = np.random.default_rng(0)
    mosaic = rng.random((101, 77)).astype(np.float32)
    whole = rcd_bands(mosaic, "GBRG", band_rows=1000, workers=1)
    np.testing.assert_array_equal(rcd_bands(mosaic, "GBRG", band_rows=10, workers=3), whole)
    for shape in ((2, 2), (3, 5), (5, 3), (17, 9)):
        out = rcd(rng.random(shape).astype(np.float32), "BGGR")
        assert out.shape == (*shape, 3) and np.isfinite(out).all()
