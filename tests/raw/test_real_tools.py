"""Our DNG opened by the tools photographers use (issue 13 #1, #2, "Real references in the
suite"): exiftool's validator, dcraw's metadata and its development under D65 against
colour-science's ground truth, Adobe's DNG SDK (through dngpy) reading the mosaic, and
RawTherapee developing the D65 ColorChecker. CI installs the programs (``.ci/run``: Debian
``dcraw``, ``libimage-exiftool-perl``, ``rawtherapee``); dngpy is a test extra. The README's
table of the tools (``benchmarks/dng_tools.py``) is checked against its CSV."""

from __future__ import annotations

import csv
import io
import os
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import tifffile

from spectral_cam import expose, scene_from_dict
from spectral_cam.radiance_targets import reflectance_set, synthetic_chart
from spectral_cam.colour_ground_truth import patch_linear_srgb
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.metrics import colorchecker_delta_e
from spectral_cam.raw import read_raw, write_dng

pytestmark = pytest.mark.timeout(120)

REPO = Path(__file__).resolve().parents[2]

QUIET = {"shot_noise": False, "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0}


def _tool(name: str) -> str:
    path = shutil.which(name)
    assert path, f"{name} is needed: apt-get install dcraw libimage-exiftool-perl (as .ci/run does)"
    return path


#: The chart's surround outside the DNG's default crop (what sensor.crop_margin_px gives a render).
CROP_MARGIN_PX = 8


def _chart_dng(tmp_path, illuminant: str, *, patch_px: int = 16, gap_px: int = 4, **lens):
    """A noise-free synthetic ColorChecker under ``illuminant``, auto-exposed on its white
    (124 × 84 px with the default patches)."""
    chart = synthetic_chart(reflectance_set("colorchecker"), illuminant, patch_px=patch_px, gap_px=gap_px,
                            margin_px=CROP_MARGIN_PX)
    height, width = chart.radiance.frame[2:]
    config = scene_from_dict({"scene": {"preset": "flat_field"}, "illuminant": {"spd": illuminant},
                              "lens": {"focal_length_mm": 35.0, "f_number": 5.6, **lens},
                              "sensor": {"width_px": width, "height_px": height, "vignetting": False, **QUIET},
                              "exposure": {"iso": 400}})
    mask = np.zeros((height, width), bool)
    mask[chart.patches[chart.white_index].interior(0.2)] = True
    raw = expose(chart.radiance, config, white_mask=mask)
    return chart, raw, write_dng(raw, tmp_path / f"chart_{illuminant}.dng")


def _centred(image: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``image`` on a grid of ``shape``: tools crop (RawTherapee: 4 px a side for demosaicing) or
    keep (a DNG's border outside its default crop) symmetric margins, so the chart is in the
    middle; a smaller image is centred on a NaN canvas (a patch reaching it fails loudly)."""
    dy, dx = image.shape[0] - shape[0], image.shape[1] - shape[1]
    assert dy % 2 == 0 and dx % 2 == 0, f"{image.shape[:2]} is no symmetric margin around {shape}"
    if dy >= 0 and dx >= 0:
        return image[dy // 2:dy // 2 + shape[0], dx // 2:dx // 2 + shape[1]]
    canvas = np.full((*shape, *image.shape[2:]), np.nan)
    canvas[-dy // 2:-dy // 2 + image.shape[0], -dx // 2:-dx // 2 + image.shape[1]] = image
    return canvas


def test_exiftool_validates_our_dng_without_a_warning(tmp_path):
    """exiftool -validate says OK: every array, the hue/sat maps' 486 floats included, is under the 500
    past which it skips an array with a minor "Not decoding some large array(s)" warning."""
    _, _, path = _chart_dng(tmp_path, "D65")
    out = subprocess.run([_tool("exiftool"), "-validate", "-warning", "-a", str(path)],
                         capture_output=True, text=True, check=True).stdout
    assert out.split() == ["Validate", ":", "OK"], out


def test_dcraw_reads_the_capture_the_simulation_knows(tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")  # 2023-11-14 22:13:20 UTC
    _, raw, path = _chart_dng(tmp_path, "D65")
    out = subprocess.run([_tool("dcraw"), "-i", "-v", str(path)], capture_output=True, text=True, check=True).stdout
    info = dict(line.split(": ", 1) for line in out.splitlines() if ": " in line)
    assert info["ISO speed"] == "400" and info["Aperture"] == "f/5.6" and info["Focal length"] == "35.0 mm"
    assert float(info["Shutter"].split("/")[1].split()[0]) == pytest.approx(1 / raw.meta["exposure_s"], rel=1e-3)
    assert info["Camera"] == "spectral_cam nikon_d850" and "2023" in info["Timestamp"]
    again = write_dng(raw, tmp_path / "again.dng")  # the same capture gives the same bytes
    assert again.read_bytes() == path.read_bytes()


def test_dcraw_develops_our_dng_with_the_d65_matrix(tmp_path):
    """dcraw keeps the colour matrix it reads last: with Adobe's slot order (A first, D65
    second) that is D65's, and under D65 it develops our ColorChecker as well as the 3×3 matrix
    allows (measured 0.97 mean ΔE2000; with the slots the other way round it was 1.88)."""
    chart, _, path = _chart_dng(tmp_path, "D65")
    out = subprocess.run([_tool("dcraw"), "-w", "-W", "-4", "-T", "-o", "1", "-c", str(path)],
                         capture_output=True, check=True).stdout
    linear_srgb = tifffile.imread(io.BytesIO(out)).astype(float) / 65535.0  # -4: linear 16-bit sRGB
    linear_srgb = _centred(linear_srgb, tuple(chart.radiance.frame[2:]))
    result = colorchecker_delta_e(linear_srgb, patch_linear_srgb("D65"), chart.patches[:24])
    assert result["mean"] < 1.1 and result["max"] < 3.2


# ----------------------------------------------------------------------------- Adobe's DNG SDK
def _dngpy():
    return pytest.importorskip("dngpy", reason="dngpy (Adobe's DNG SDK) is a test extra: pip install -e '.[test]'")


def test_adobe_dng_sdk_reads_our_mosaic_bit_for_bit(tmp_path):
    """Adobe's DNG SDK (the specification's reference reader; dngpy 0.1.3 bundles it as
    ``libdng.so.1.7.1``) returns the stage-1 CFA plane equal, bit for bit, to the mosaic we
    wrote and to LibRaw's reading of the file, with our Bayer phase, AsShotNeutral and EXIF
    capture fields."""
    dngpy = _dngpy()
    _, raw, path = _chart_dng(tmp_path, "D65")
    sdk = dngpy.Dng(str(path))
    stage1 = sdk.raw_pixels
    assert stage1.dtype == np.uint16 and stage1.ndim == 3 and stage1.shape[2] == 1  # one CFA plane
    stage1 = stage1[..., 0]
    np.testing.assert_array_equal(_centred(stage1, raw.mosaic.shape), raw.mosaic)
    libraw = read_raw(path).mosaic
    np.testing.assert_array_equal(_centred(stage1, libraw.shape), libraw)
    assert sdk.get_bayer_pattern() == raw.cfa
    np.testing.assert_allclose(sdk.get_white_balance(), raw.as_shot_neutral, rtol=1e-5)
    exif = sdk.exif
    assert exif.iso == 400 and exif.f_number == pytest.approx(5.6) and exif.focal_length == pytest.approx(35.0)
    # the SDK snaps ExposureTime as it parses it (dng_exif::SnapExposureTime: to a standard speed
    # within 2 %, else, between 1/130 and 1/20 s, to an inverse multiple of 5: our 1/122 s reads 1/120)
    assert exif.exposure_time == pytest.approx(raw.meta["exposure_s"], rel=0.025)
    assert exif.model == raw.camera_model


def test_adobe_dng_sdk_reads_our_dng_without_a_warning(tmp_path):
    """dngpy's SDK is built with ``qDNGValidate``: every departure from the DNG specification
    the SDK notices while parsing and reading is printed as ``*** Warning: … ***`` (as Adobe's
    ``dng_validate`` prints it), e.g. a CFA image whose default crop lies less than 1.9 px
    inside the active area on any side ("Too little padding", ``dng_ifd::IsValidDNG``). Run
    in a child process so that all its output is caught."""
    _dngpy()
    _, _, path = _chart_dng(tmp_path, "D65")
    script = ("import sys, dngpy\n"
              "dng = dngpy.Dng(sys.argv[1])\n"
              "dng.raw_pixels, dng.metadata, dng.exif, dng.color_info, dng.get_white_balance()\n")
    run = subprocess.run([sys.executable, "-c", script, str(path)], capture_output=True, text=True, timeout=60,
                         check=False)
    assert run.returncode == 0, run.stderr
    said = (run.stdout + run.stderr).strip()
    assert not said, f"Adobe's DNG SDK on our DNG:\n{said}"


# ----------------------------------------------------------------------------- RawTherapee
#: The settings the README's tool table reports (benchmarks/dng_tools.py uses the same file).
RAWTHERAPEE_PROFILE = Path(__file__).resolve().parents[2] / "plans" / "rawtherapee_neutral.pp3"


def _icc_tags(profile: bytes) -> dict[str, bytes]:
    """The tagged elements of an ICC profile (ICC.1:2010 §7.3: a count, then signature, offset, size)."""
    count = struct.unpack(">I", profile[128:132])[0]
    table = (struct.unpack(">4sII", profile[132 + 12 * i:144 + 12 * i]) for i in range(count))
    return {sig.decode("latin-1"): profile[offset:offset + size] for sig, offset, size in table}


def _s15fixed16(data: bytes) -> np.ndarray:
    return np.array(struct.unpack(f">{len(data) // 4}i", data[:len(data) // 4 * 4])) / 65536.0


def test_rawtherapee_develops_our_d65_chart_as_we_do(tmp_path, record_property):
    """RawTherapee 5.9's development of our D65 ColorChecker DNG, with its built-in neutral
    profile (no tone curve, no auto-exposure) and, pinned in a partial pp3, white balance
    "Camera", the input profile "(camera)" (the DNG's matrix) and the output profile
    RTv4_sRGB, within 1.0 mean ΔE2000 of ours (colour_matrix = "dng") and as close to
    colour-science's ground truth as dcraw (measured 0.025 from ours; 0.97, max 3.0 from the
    truth). RawTherapee's fork of dcraw keeps the ColorMatrix whose CalibrationIlluminant is
    not Standard A (17), our D65 slot. Its TIFF embeds the output profile; the test checks
    that this is sRGB (colorants and parametric TRC) before decoding with colour-science."""
    import colour

    rawtherapee = shutil.which("rawtherapee-cli")
    if not rawtherapee:
        pytest.skip("rawtherapee-cli is absent: apt-get install rawtherapee (as .ci/run does)")
    # larger patches: RawTherapee 5.9 refuses raw files under 100 000 bytes (identify() in its dcraw.cc)
    chart, _, path = _chart_dng(tmp_path, "D65", patch_px=40, gap_px=8)
    assert path.stat().st_size >= 100_000
    out = tmp_path / "rawtherapee.tif"
    env = {**os.environ, "XDG_CONFIG_HOME": str(tmp_path / "config"), "XDG_CACHE_HOME": str(tmp_path / "cache")}
    run = subprocess.run([rawtherapee, "-q", "-Y", "-t", "-b16", "-p", str(RAWTHERAPEE_PROFILE), "-o", str(out),
                          "-c", str(path)],
                         capture_output=True, text=True, env=env, timeout=60, check=False)
    assert run.returncode == 0 and out.exists(), run.stdout + run.stderr

    with tifffile.TiffFile(out) as tif:
        encoded, icc = tif.pages[0].asarray(), bytes(tif.pages[0].tags[34675].value)  # InterColorProfile
    tags = _icc_tags(icc)
    srgb = colour.RGB_COLOURSPACES["sRGB"]
    d50 = _s15fixed16(tags["wtpt"][8:20])
    to_d50 = colour.adaptation.matrix_chromatic_adaptation_VonKries(colour.xy_to_XYZ(srgb.whitepoint), d50, "Bradford")
    colorants = np.stack([_s15fixed16(tags[c][8:20]) for c in ("rXYZ", "gXYZ", "bXYZ")], axis=1)
    np.testing.assert_allclose(colorants, to_d50 @ np.asarray(srgb.matrix_RGB_to_XYZ), atol=1e-3)
    assert tags["rTRC"][:4] == b"para" and struct.unpack(">H", tags["rTRC"][8:10])[0] == 4  # (aX + b)^g | cX
    np.testing.assert_allclose(_s15fixed16(tags["rTRC"][12:32]), [2.4, 1 / 1.055, 0.055 / 1.055, 1 / 12.92, 0.04045],
                               atol=2e-3)
    shape = tuple(chart.radiance.frame[2:])
    linear = _centred(colour.cctf_decoding(encoded.astype(float) / 65535.0, "sRGB"), shape)

    ours = _centred(develop(read_raw(path), ISPConfig(colour_matrix="dng", tone="linear")).linear, shape)
    patches = chart.patches[:24]
    against_ours = colorchecker_delta_e(linear, ours, patches)
    against_truth = colorchecker_delta_e(linear, patch_linear_srgb("D65"), patches)
    record_property("delta_e_vs_ours", float(against_ours["mean"]))
    record_property("delta_e_vs_truth", float(against_truth["mean"]))
    assert against_ours["mean"] < 1.0, against_ours["mean"]
    assert against_truth["mean"] < 1.1 and against_truth["max"] < 3.2, (against_truth["mean"], against_truth["max"])


def _rawtherapee_with_profile(tmp_path, dng: Path, dcp: Path, *, hue_sat_map: bool) -> np.ndarray:
    """RawTherapee 5.9 developing ``dng`` with the camera profile ``dcp`` as its input profile
    (its hue/sat map on or off; no profile tone curve, look table or baseline-exposure offset),
    camera white balance, RTv4_sRGB out: the image decoded to linear sRGB."""
    import colour

    rawtherapee = shutil.which("rawtherapee-cli")
    if not rawtherapee:
        pytest.skip("rawtherapee-cli is absent: apt-get install rawtherapee (as .ci/run does)")
    settings = tmp_path / f"profile_{hue_sat_map}.pp3"
    settings.write_text("[White Balance]\nEnabled=true\nSetting=Camera\n\n[RAW Bayer]\nMethod=amaze\n\n"
                        f"[Color Management]\nInputProfile=file:{dcp}\nToneCurve=false\nApplyLookTable=false\n"
                        f"ApplyBaselineExposureOffset=false\nApplyHueSatMap={str(hue_sat_map).lower()}\n"
                        "DCPIlluminant=0\nWorkingProfile=ProPhoto\nOutputProfile=RTv4_sRGB\n", encoding="utf-8")
    out = tmp_path / f"rawtherapee_{dng.stem}_{hue_sat_map}.tif"
    env = {**os.environ, "XDG_CONFIG_HOME": str(tmp_path / "config"), "XDG_CACHE_HOME": str(tmp_path / "cache")}
    run = subprocess.run([rawtherapee, "-q", "-Y", "-t", "-b16", "-p", str(settings), "-o", str(out), "-c", str(dng)],
                         capture_output=True, text=True, env=env, timeout=60, check=False)
    assert run.returncode == 0 and out.exists(), run.stdout + run.stderr
    return colour.cctf_decoding(tifffile.imread(out).astype(float) / 65535.0, "sRGB")


@pytest.mark.parametrize("illuminant", ["D65", "A"])
def test_rawtherapee_applies_our_hue_sat_map_as_our_develop_does(tmp_path, illuminant, record_property):
    """Issue 28 #1: the camera profile our DNG carries (ForwardMatrix1/2 and the ProfileHueSatMap
    fitted on the rawtoaces training set), written as a .dcp and loaded by RawTherapee as its input
    profile, develops the noise-free ColorChecker as our ``colour_matrix = "dng_profile"`` does:
    within 0.3 mean ΔE2000 over the 23 patches inside sRGB (RawTherapee clips the cyan to sRGB's
    edge), with the map (measured 0.014 D65, 0.045 A) and without it (the forward matrices alone:
    0.015, 0.074). Both tools gain alike from the map against colour-science's truth, out of
    sample (the map never saw the ColorChecker): D65 0.89 → 0.49 both; A 1.10/1.07 → 0.63/0.63."""
    import dataclasses

    from spectral_cam.raw.dng import write_dcp

    chart, _, path = _chart_dng(tmp_path, illuminant, patch_px=40, gap_px=8)
    raw = read_raw(path)
    assert raw.hue_sat_map is not None and raw.hue_sat_map_2 is not None
    dcp = write_dcp(raw, tmp_path / "camera.dcp")
    shape = tuple(chart.radiance.frame[2:])
    truth = patch_linear_srgb(illuminant)
    inside = [i for i in range(24) if np.all((truth[i] > 0) & (truth[i] < 1))]
    patches = [chart.patches[i] for i in inside]
    gains = {}
    for with_map in (True, False):
        source = raw if with_map else dataclasses.replace(raw, hue_sat_map=None, hue_sat_map_2=None)
        ours = _centred(develop(source, ISPConfig(colour_matrix="dng_profile", tone="linear")).linear, shape)
        theirs = _centred(_rawtherapee_with_profile(tmp_path, path, dcp, hue_sat_map=with_map), shape)
        between = colorchecker_delta_e(theirs, ours, patches, white_index=inside.index(chart.white_index))["mean"]
        record_property(f"ours_vs_rawtherapee_map_{with_map}", float(between))
        assert between < 0.3, (with_map, between)
        gains[with_map] = [colorchecker_delta_e(image, truth[inside], patches,
                                                white_index=inside.index(chart.white_index))["mean"]
                           for image in (ours, theirs)]
    for tool in (0, 1):  # ours, RawTherapee: the map takes off at least 0.25 of the mean
        assert gains[True][tool] < gains[False][tool] - 0.25, gains


def test_exiftool_reads_the_hue_sat_map_we_write(tmp_path):
    """ProfileHueSatMapDims (hues, saturations, values) and both maps' data as exiftool reads them."""
    _, raw, path = _chart_dng(tmp_path, "D65")
    out = subprocess.run([_tool("exiftool"), "-s", "-s", "-s", "-ProfileHueSatMapDims", str(path)],
                         capture_output=True, text=True, check=True).stdout.split()
    assert tuple(int(v) for v in out) == raw.hue_sat_map.dims == (27, 6, 1)


# ----------------------------------------------------------------------------- the README's table
def test_the_readme_table_of_real_tools_is_the_committed_csv():
    """The block ``benchmarks/dng_tools.py`` writes in the README shows the CSV's tools,
    versions, settings and ΔE2000 (mean, max) under each illuminant, and nothing else."""
    with open(REPO / "docs" / "bench" / "dng_tools.csv", newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    block = readme.split("<!-- dng-tools:begin -->", 1)[1].split("<!-- dng-tools:end -->", 1)[0]
    lines = [line for line in block.splitlines() if line.startswith("|")]
    header = [cell.strip() for cell in lines[0].strip("|").split("|")]
    table = {cells[0]: dict(zip(header, cells))
             for cells in ([cell.strip() for cell in line.strip("|").split("|")] for line in lines[2:])}
    assert rows and set(table) == {row["tool"] for row in rows}
    for row in rows:
        shown = table[row["tool"]]
        assert shown["version"] == row["version"] and shown["settings"] == f"`{row['settings']}`", row["tool"]
        mean, worst = float(row["delta_e_mean"]), float(row["delta_e_max"])
        assert shown[row["illuminant"]] == f"{mean:.2f} (max {worst:.1f})", (row["tool"], row["illuminant"])


def test_exiftool_gives_the_35mm_equivalent_focal_length_of_our_sensor(tmp_path):
    """Issue 25 #18: with FocalPlaneX/YResolution (pixels per cm) exiftool derives the sensor's
    size: a 480 × 320 sensor of 6 µm pixels (2.88 × 1.92 mm, diagonal 3.46 mm) is 12.5× smaller
    than 35 mm film (43.27 mm), so an 8 mm lens is a 100 mm equivalent (it said 8 mm)."""
    import numpy as np

    from spectral_cam.raw import RawImage

    raw = RawImage(np.full((320, 480), 500, np.uint16), "RGGB", 64.0, 4095, as_shot_neutral=np.ones(3),
                   meta={"exposure_s": 0.01, "iso": 100, "f_number": 2.8, "focal_length_mm": 8.0,
                         "pixel_area_m2": (6e-6) ** 2})
    path = write_dng(raw, tmp_path / "size.dng")
    out = subprocess.run([_tool("exiftool"), "-n", "-s3", "-FocalLength35efl", "-ScaleFactor35efl", str(path)],
                         capture_output=True, text=True, check=True).stdout.split()
    expected = 43.2666 / np.hypot(2.88, 1.92)
    assert float(out[-1]) == pytest.approx(expected, rel=0.01)
    assert float(out[0]) == pytest.approx(8.0 * expected, rel=0.01)
