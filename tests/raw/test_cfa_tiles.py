"""Issue 29 #2: colour filter arrays beyond RGGB — X-Trans (6 × 6), Quad Bayer (4 × 4) and RGBW (Kodak's
4 × 4 with white pixels). The DNG carries the tile (CFARepeatPatternDim, CFAPattern, CFAPlaneColor);
LibRaw reads the X-Trans tile exactly and develops it; Adobe's DNG SDK reads all three without a
warning; our develop of a ColorChecker through each tile is within 0.5 mean ΔE2000 of the Bayer develop
(colour-science's truth)."""

from __future__ import annotations

import shutil
import subprocess
import sys

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.cfa import EXTENDED_PATTERNS, cfa_pattern
from spectral_cam.colour_ground_truth import patch_linear_srgb
from spectral_cam.errors import ConfigError
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.metrics import colorchecker_delta_e
from spectral_cam.radiance_targets import reflectance_set, synthetic_chart
from spectral_cam.raw import RawImage, read_raw, write_dng

pytestmark = pytest.mark.timeout(120)

QUIET = {"shot_noise": False, "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0}


def _chart_capture(tmp_path, cfa: str, **sensor):
    """A noise-free ColorChecker under D65 through ``cfa`` (12-px margin: a whole number of X-Trans and
    Quad Bayer tiles), its DNG and the chart."""
    chart = synthetic_chart(reflectance_set("colorchecker"), "D65", patch_px=24, gap_px=6, margin_px=12)
    h, w = chart.radiance.frame[2:]
    scene = sc.scene_from_dict({"scene": {"preset": "flat_field"}, "illuminant": {"spd": "D65"},
                                "lens": {"focal_length_mm": 35.0, "f_number": 5.6},
                                "sensor": {"width_px": w, "height_px": h, "vignetting": False, "cfa": cfa,
                                           "crop_margin_px": 12, **QUIET, **sensor},
                                "exposure": {"iso": 100}})
    mask = np.zeros(chart.radiance.data.shape[:2], bool)
    mask[chart.patches[chart.white_index].interior(0.2)] = True
    raw = sc.expose(chart.radiance, scene, white_mask=mask)
    return chart, raw, write_dng(raw, tmp_path / f"{cfa}.dng")


@pytest.mark.parametrize("cfa", ["XTRANS", "QUAD_RGGB", "RGBW"])
def test_the_dng_carries_the_tile_and_reads_back_bit_for_bit(tmp_path, cfa):
    """CFARepeatPatternDim is the tile's size, CFAPattern its TIFF/EP colour codes (white 6) and
    CFAPlaneColor the planes (tifffile); read_raw returns the same CFA, mosaic and, for RGBW, its four
    planes' AsShotNeutral and 4 × 3 ColorMatrix."""
    import tifffile

    _, raw, path = _chart_capture(tmp_path, cfa)
    codes = np.where(cfa_pattern(cfa) == 3, 6, cfa_pattern(cfa))
    with tifffile.TiffFile(path) as tif:
        tags = tif.pages[0].tags
        assert tuple(tags[33421].value) == cfa_pattern(cfa).shape
        assert tuple(tags[33422].value) == tuple(int(c) for c in codes.ravel())
        assert tuple(tags[50710].value) == ((0, 1, 2, 6) if cfa == "RGBW" else (0, 1, 2))
    back = read_raw(path)
    assert back.cfa == cfa and np.array_equal(back.mosaic, raw.mosaic)
    if cfa == "RGBW":
        np.testing.assert_allclose(back.as_shot_neutral, raw.as_shot_neutral, rtol=1e-6)
        np.testing.assert_allclose(back.color_matrix, raw.color_matrix, atol=1e-6)


def test_libraw_reads_the_x_trans_tile_exactly_and_develops_it(tmp_path):
    """rawpy's raw_pattern is our 6 × 6 tile (colour description RGBG: codes 0, 1, 2); LibRaw develops
    the chart (LINEAR interpolation: its default 3-pass X-Trans interpolation stops with "Input/output
    error" on images under 512 px a side) within 0.5 mean ΔE2000 of its own Bayer develop."""
    import rawpy

    scores = {}
    for cfa in ("RGGB", "XTRANS"):
        chart, _, path = _chart_capture(tmp_path, cfa)
        with rawpy.imread(str(path)) as handle:
            if cfa == "XTRANS":
                assert np.array_equal(np.asarray(handle.raw_pattern), cfa_pattern("XTRANS"))
                assert bytes(handle.color_desc)[:3] == b"RGB"
            rgb = handle.postprocess(demosaic_algorithm=rawpy.DemosaicAlgorithm.LINEAR, gamma=(1, 1),
                                     no_auto_bright=True, use_camera_wb=True, output_bps=16, user_flip=0,
                                     output_color=rawpy.ColorSpace.sRGB)
        linear = rgb.astype(float) / 65535.0
        h, w = chart.radiance.frame[2:]
        dy, dx = (linear.shape[0] - h) // 2, (linear.shape[1] - w) // 2
        scores[cfa] = colorchecker_delta_e(linear[dy:dy + h, dx:dx + w], patch_linear_srgb("D65"),
                                           chart.patches[:24])["mean"]
    assert abs(scores["XTRANS"] - scores["RGGB"]) < 0.5, scores


@pytest.mark.parametrize("cfa", ["XTRANS", "QUAD_RGGB", "RGBW"])
def test_adobe_dng_sdk_reads_the_tile_without_a_warning(tmp_path, cfa):
    """Adobe's DNG SDK (dngpy, built with qDNGValidate) parses both tiles silently and returns the
    mosaic bit for bit (RGBW: four colour planes, a 4 × 3 ColorMatrix). LibRaw, whose CFA is dcraw's
    8-row × 2-column ``filters``, cannot hold a 4 × 4 tile (it reads RGBW as GMCY): read_raw takes
    them from the DNG's own tags."""
    pytest.importorskip("dngpy", reason="dngpy (Adobe's DNG SDK) is a test extra: pip install -e '.[test]'")
    _, raw, path = _chart_capture(tmp_path, cfa)
    script = ("import sys, numpy, dngpy\n"
              "dng = dngpy.Dng(sys.argv[1])\n"
              "pixels = numpy.asarray(dng.raw_pixels)\n"
              "numpy.save(sys.argv[2], pixels)\n")
    out = tmp_path / "pixels.npy"
    run = subprocess.run([sys.executable, "-c", script, str(path), str(out)], capture_output=True, text=True,
                         timeout=60, check=False)
    assert run.returncode == 0, run.stderr
    assert not (run.stdout + run.stderr).strip(), run.stdout + run.stderr
    pixels = np.load(out).reshape(raw.mosaic.shape)
    assert np.array_equal(pixels, raw.mosaic)


@pytest.mark.parametrize(("cfa", "methods"), [("XTRANS", ("colour_difference",)),
                                              ("QUAD_RGGB", ("quad_remosaic", "quad_binning", "colour_difference")),
                                              ("RGBW", ("rgbw_fusion",))])
def test_our_develop_through_each_tile_is_within_half_a_delta_e_of_bayer(tmp_path, cfa, methods):
    """Mean ΔE2000 of the 24 patches against colour-science's truth, through the tile and each of its
    methods, within 0.5 of the RGGB develop by menon2007 (measured: X-Trans and Quad Bayer within 0.04
    of 0.97, RGBW 1.02 — metered so its white pixels, which clip first, hold the white patch); a Bayer
    method asked of the tile falls back to the tile's own and the develop says so."""
    chart, _, bayer_path = _chart_capture(tmp_path, "RGGB")
    truth = patch_linear_srgb("D65")
    bayer = colorchecker_delta_e(develop(read_raw(bayer_path), ISPConfig(tone="linear")).linear, truth,
                                 chart.patches[:24])["mean"]
    _, _, path = _chart_capture(tmp_path, cfa)
    raw = read_raw(path)
    for method in methods:
        tile = colorchecker_delta_e(develop(raw, ISPConfig(tone="linear", demosaic=method)).linear, truth,
                                    chart.patches[:24])["mean"]
        assert abs(tile - bayer) < 0.5, (method, tile, bayer)
    fallback = develop(raw, ISPConfig(tone="linear", demosaic="menon2007"))
    assert "needs a 2×2 Bayer mosaic" in fallback.meta["demosaic"]


def test_exiftool_validates_both_tiles(tmp_path):
    exiftool = shutil.which("exiftool")
    assert exiftool, "exiftool is needed: apt-get install libimage-exiftool-perl (as .ci/run does)"
    for cfa in EXTENDED_PATTERNS:  # RGBW's DNG has four colour planes
        _, _, path = _chart_capture(tmp_path, cfa)
        out = subprocess.run([exiftool, "-validate", "-warning", "-a", str(path)], capture_output=True, text=True,
                             check=True).stdout
        assert out.split() == ["Validate", ":", "OK"], (cfa, out)


def test_a_bayer_only_method_refuses_a_larger_tile_with_what_would_do():
    from spectral_cam.isp.demosaic import demosaic

    with pytest.raises(ConfigError, match="XTRANS is a larger tile"):
        demosaic(np.zeros((12, 12), np.float32), "XTRANS", method="malvar2004")
    with pytest.raises(ConfigError, match="QUAD_RGGB"):
        develop(RawImage(np.full((32, 32), 500, np.uint16), "RGGB", 64.0, 4095, as_shot_neutral=np.ones(3)),
                ISPConfig(demosaic="quad_binning"))


def test_rgbw_white_pixels_collect_what_the_three_filters_share():
    """A flat grey under D65 through RGBW: each white pixel's signal equals the sum of its red, green and
    blue neighbours' (its QE is their sum, radiometry.white_quantum_efficiency) within 1 %: 2.3× the green
    pixels' light, the sensitivity a panchromatic CFA buys."""
    from spectral_cam.cfa import channel_index
    from spectral_cam.radiance_targets import lambertian_radiance, uniform_image

    radiance = uniform_image(lambertian_radiance("D65", [0.5])[0], (32, 32))
    scene = sc.scene_from_dict({"sensor": {"width_px": 32, "height_px": 32, "vignetting": False, "cfa": "RGBW",
                                           "crop_margin_px": 0, "bit_depth": 16, **QUIET},
                                "illuminant": {"spd": "D65"}, "exposure": {"time_s": 0.001}})
    raw = sc.expose(radiance, scene)
    index = channel_index(raw.mosaic.shape, "RGBW")
    net = raw.mosaic.astype(float) - raw.black_level
    r, g, b, w = (net[index == c].mean() for c in range(4))
    assert w == pytest.approx(r + g + b, rel=0.01)
    assert w / g > 2.0


def test_an_rgbw_sensor_needs_spectral_bands(make_scene):
    """The camera film holds R, G and B only: an RGBW sensor refuses it and says what to render."""
    from spectral_cam import render
    from spectral_cam.errors import SensorError

    config = make_scene(scene={"preset": "flat_field"}, sensor={"width_px": 16, "height_px": 16, "cfa": "RGBW"},
                        render={"spp": 4, "bands": "camera", "spectral_output": False, "diffraction": "off"})
    with pytest.raises(SensorError, match="spectral bands"):
        sc.expose(render(config, with_depth=False), config)


def test_libraw_cannot_hold_a_four_column_tile(tmp_path):
    """Why read_raw takes Quad Bayer and RGBW from the DNG's tags: LibRaw describes a CFA by dcraw's
    ``filters``, 8 rows × 2 columns at most, so the raw_pattern it gives for a 4 × 4 tile repeats every 2
    columns — not the tile, whose columns 0–1 and 2–3 differ (it still reads the mosaic bit for bit). If a
    LibRaw release learns 4 × 4 tiles, this test says so and read_raw can trust it."""
    import rawpy

    for cfa in ("QUAD_RGGB", "RGBW"):
        _, raw, path = _chart_capture(tmp_path, cfa)
        with rawpy.imread(str(path)) as handle:
            pattern = np.asarray(handle.raw_pattern)
            tile = cfa_pattern(cfa)
            assert not np.array_equal(tile[:, :2], tile[:, 2:])
            assert pattern.shape[1] <= 2 or np.array_equal(pattern[:, :2], pattern[:, 2:4]), (cfa, pattern)
            assert np.array_equal(handle.raw_image_visible, raw.mosaic)
