"""DNG writing checked by an independent reader (LibRaw via rawpy, tags via tifffile)."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.metering import GREY_RAW
import rawpy
import tifffile

from spectral_cam import sensor as S
from spectral_cam import spectra
from spectral_cam.errors import ConfigError, RawFormatError
from spectral_cam.raw import RawImage, read_raw, write_dng
from spectral_cam.image import SpectralImage
from spectral_cam.scene import scene_from_dict

BANDS = spectra.parse_bands("400:700:10")


def flat_field(illuminant, size=64, reflectance=0.5, lux=500.0):
    """Radiance ρ·E/π of a spectrally flat Lambertian reflector, as band integrals."""
    wl, irradiance = spectra.absolute_irradiance(illuminant, lux)
    radiance = spectra.band_integrals(reflectance * irradiance / np.pi, wl, BANDS)
    data = np.broadcast_to(radiance.astype(np.float32), (size, size, len(BANDS))).copy()
    return SpectralImage(data, np.asarray(BANDS.centres_nm), np.asarray(BANDS.edges_nm))


def d850_white_level() -> int:
    """The D850's white level from its published 14-bit RAW (data/cameras/sensor_figures.csv)."""
    return 2 ** int(spectra.camera_figures("nikon_d850")["bit_depth"].value) - 1


def exposed(cfa="RGGB", model="nikon_d850", illuminant="D65", size=64, **sensor):
    cfg = scene_from_dict({"sensor": {"width_px": size, "height_px": size, "cfa": cfa, "model": model, **sensor},
                           "illuminant": {"spd": illuminant, "illuminance_lux": 500.0}})
    return S.expose(flat_field(illuminant, size), cfg, frame_seed=1)


@pytest.mark.parametrize("cfa", ["RGGB", "BGGR", "GRBG", "GBRG"])
def test_rawpy_reads_what_we_wrote(tmp_path, cfa):
    raw = exposed(cfa)
    path = write_dng(raw, tmp_path / "raw.dng")
    with rawpy.imread(str(path)) as handle:
        assert np.array_equal(handle.raw_image_visible, raw.mosaic)
        assert list(handle.black_level_per_channel) == [256] * 4
        assert handle.white_level == d850_white_level() == 16383
        letters = handle.color_desc.decode()
        assert "".join(letters[i] for i in handle.raw_pattern.ravel()) == cfa
        multipliers = np.asarray(handle.camera_whitebalance[:3])
        np.testing.assert_allclose(multipliers / multipliers[1],
                                   (1 / raw.as_shot_neutral) / (1 / raw.as_shot_neutral[1]), rtol=1e-5)


def test_dng_tags(tmp_path):
    raw = exposed("GRBG")
    path = write_dng(raw, tmp_path / "raw.dng")
    with tifffile.TiffFile(path) as tif:
        tags = {tag.code: tag.value for tag in tif.pages[0].tags}
    assert tags[262] == 32803  # PhotometricInterpretation = CFA
    assert tuple(tags[50706]) == (1, 4, 0, 0)
    assert tuple(tags[33421]) == (2, 2) and tuple(tags[33422]) == (1, 0, 2, 1)  # G R B G
    # Adobe's slot order (issue 13 #1): Standard A first, D65 second, each with its forward matrix
    assert (tags[50778], tags[50779]) == (17, 21)

    def matrix(code):
        pairs = np.asarray(tags[code], dtype=float).reshape(9, 2)
        return (pairs[:, 0] / pairs[:, 1]).reshape(3, 3)

    np.testing.assert_allclose(matrix(50721), raw.color_matrix_2, atol=1e-6)  # ColorMatrix1 = A
    np.testing.assert_allclose(matrix(50722), raw.color_matrix, atol=1e-6)    # ColorMatrix2 = D65
    for code in (50964, 50965):  # ForwardMatrix1/2 map camera white onto D50 (DNG spec ch. 6)
        np.testing.assert_allclose(matrix(code) @ np.ones(3), [0.9642, 1.0, 0.8249], atol=2e-6)
    assert tags[50717] == d850_white_level() and tags[50714] == 256
    np.testing.assert_allclose(tags[51041], raw.noise_profile)
    assert tags[50708] == raw.camera_model == "spectral_cam nikon_d850"
    assert tags[271] == "spectral_cam" and tags[272] == raw.camera_model


def test_read_raw_round_trip(tmp_path):
    raw = exposed("BGGR", illuminant="A")
    back = read_raw(write_dng(raw, tmp_path / "raw.dng"))
    assert back.cfa == "BGGR" and back.black_level == 256 and back.white_level == d850_white_level()
    assert np.array_equal(back.mosaic, raw.mosaic) and back.mosaic.dtype == np.uint16
    np.testing.assert_allclose(back.as_shot_neutral, raw.as_shot_neutral, rtol=1e-5)
    np.testing.assert_allclose(back.color_matrix, raw.color_matrix, atol=2e-4)  # via LibRaw's float32 matrix
    assert back.noise_profile == pytest.approx(raw.noise_profile)
    assert back.camera_model == raw.camera_model


def test_monochrome_linear_raw(tmp_path):
    raw = exposed("none", "ideal")
    path = write_dng(raw, tmp_path / "mono.dng")
    with tifffile.TiffFile(path) as tif:
        assert tif.pages[0].tags[262].value == 34892  # LinearRaw
    with rawpy.imread(str(path)) as handle:
        assert handle.num_colors == 1
        assert np.array_equal(handle.raw_image_visible, raw.mosaic)
    back = read_raw(path)
    assert back.cfa == "none" and back.color_matrix is None


@pytest.mark.parametrize("illuminant", ["D65", "A"])
def test_flat_field_develops_neutral_in_rawpy(tmp_path, illuminant):
    raw = exposed("RGGB", illuminant=illuminant)
    path = write_dng(raw, tmp_path / "flat.dng")
    with rawpy.imread(str(path)) as handle:
        for space in (rawpy.ColorSpace.raw, rawpy.ColorSpace.sRGB):
            rgb = handle.postprocess(use_camera_wb=True, gamma=(1, 1), no_auto_bright=True, adjust_maximum_thr=0,
                                     output_bps=16, output_color=space)
            mean = rgb[8:-8, 8:-8].reshape(-1, 3).astype(float).mean(axis=0)
            np.testing.assert_allclose(mean / mean[1], 1.0, atol=0.01)
            # metered auto exposure: a flat grey lands at 10/78 of saturation (ISO 12232's mid grey)
            assert mean[1] / 65535 == pytest.approx(GREY_RAW, rel=0.05)


def test_corrupt_missing_and_truncated_files(tmp_path):
    with pytest.raises(RawFormatError, match="does not exist"):
        read_raw(tmp_path / "missing.dng")
    text = tmp_path / "notes.dng"
    text.write_text("not a raw file")
    with pytest.raises(RawFormatError, match="not a readable raw file"):
        read_raw(text)
    good = write_dng(exposed(size=128), tmp_path / "good.dng").read_bytes()
    truncated = tmp_path / "truncated.dng"
    truncated.write_bytes(good[: len(good) // 3])
    with pytest.raises(RawFormatError, match="truncated"):
        read_raw(truncated)


def test_write_dng_rejects_bad_raw(tmp_path):
    with pytest.raises(RawFormatError, match="mosaic"):
        write_dng(RawImage(np.zeros((2, 2, 3), np.uint16), "RGGB", 0, 4095), tmp_path / "x.dng")
    with pytest.raises(ConfigError, match="CFA pattern"):
        write_dng(RawImage(np.zeros((4, 4), np.uint16), "RGBX", 0, 4095), tmp_path / "x.dng")
    with pytest.raises(RawFormatError, match="black"):
        write_dng(RawImage(np.zeros((4, 4), np.uint16), "RGGB", 5000, 4095), tmp_path / "x.dng")
    assert not list(tmp_path.iterdir())  # nothing half-written


def test_colour_matrix_2_under_illuminant_a_is_written_read_and_interpolated(tmp_path):
    """A tungsten scene developed from the DNG alone: with ColorMatrix2 (Standard A,
    CalibrationIlluminant2 = 17) interpolated by the white's CCT (DNG spec ch. 6) the colour
    error is that of a matrix fitted under A; with the D65 matrix alone it doubles.
    Ground truth: colour-science XYZ of the patches under A, Bradford to D65."""
    import tifffile

    from spectral_cam import expose, scene_from_dict
    from spectral_cam.colour_ground_truth import patch_linear_srgb
    from spectral_cam.isp import ISPConfig, develop
    from spectral_cam.metrics import colorchecker_delta_e
    from spectral_cam.raw import read_raw, write_dng
    from spectral_cam.radiance_targets import reflectance_set, synthetic_chart

    chart = synthetic_chart(reflectance_set("colorchecker"), "A", patch_px=16, gap_px=4)
    height, width = chart.radiance.data.shape[:2]
    quiet = {"shot_noise": False, "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0}
    config = scene_from_dict({"scene": {"preset": "flat_field"}, "illuminant": {"spd": "A"},
                              "sensor": {"width_px": width, "height_px": height, "vignetting": False, **quiet}})
    mask = np.zeros((height, width), bool)
    mask[chart.patches[chart.white_index].interior(0.2)] = True
    path = tmp_path / "tungsten.dng"
    write_dng(expose(chart.radiance, config, white_mask=mask), path)
    with tifffile.TiffFile(path) as tif:
        assert tif.pages[0].tags[50778].value == 17  # CalibrationIlluminant1 = Standard A (Adobe's order)
    raw = read_raw(path)
    assert raw.color_matrix_2 is not None
    truth = patch_linear_srgb("A")

    def mean_delta_e(image):
        linear = develop(image, ISPConfig(colour_matrix="dng", tone="linear")).linear
        return colorchecker_delta_e(linear, truth, chart.patches[:24])["mean"]

    both = mean_delta_e(raw)
    d65_only = mean_delta_e(type(raw)(**{**raw.__dict__, "color_matrix_2": None}))
    assert both < 1.3 and d65_only > both + 1.0


def test_per_site_black_levels_round_trip_through_libraw_and_normalise_per_site(tmp_path):
    """A camera-style DNG with a different black level per CFA site (BlackLevelRepeatDim
    2×2): LibRaw reports them by colour index, read_raw maps them back to the sites, and
    the ISP normalises each site by (DN − black_site)/(white − black_site) (DNG spec ch. 5)."""
    from spectral_cam.isp.normalise import normalise
    from spectral_cam.raw import RawImage, read_raw, write_dng

    black = np.array([[512.0, 500.0], [520.0, 508.0]])  # R, Gr / Gb, B sites of RGGB
    white, level = 4095, 0.25
    tiles = np.tile(black, (16, 20))
    mosaic = np.rint(tiles + level * (white - tiles)).astype(np.uint16)
    path = tmp_path / "per_site.dng"
    write_dng(RawImage(mosaic, "RGGB", black, white), path)
    raw = read_raw(path)
    assert np.array_equal(np.asarray(raw.black_level), black)
    normalised = normalise(raw.mosaic, black_level=raw.black_level, white_level=raw.white_level)
    assert np.allclose(normalised, level, atol=0.5 / (white - black.max()))


@pytest.mark.parametrize("exposure_s, focal_mm", [(1.35e-8, 8.0), (1e-9, 0.1), (10000.0, 10000.0), (1 / 122, 35.0)])
def test_capture_numbers_survive_the_dng_rationals(tmp_path, exposure_s, focal_mm):
    """Issue 25 #3: a fixed denominator of 10⁶ wrote exposure times under 5·10⁻⁷ s as 0 and refused
    times or focal lengths above 4294.97 after the render; best rational approximations keep every
    documented value to 10⁻⁶ (read back by tifffile)."""
    raw = RawImage(np.full((32, 32), 300, np.uint16), "RGGB", 64.0, 4095, as_shot_neutral=np.ones(3),
                   meta={"exposure_s": exposure_s, "iso": 100, "f_number": 2.8, "focal_length_mm": focal_mm})
    path = write_dng(raw, tmp_path / "capture.dng")
    with tifffile.TiffFile(path) as tif:
        exif = tif.pages[0].tags["ExifTag"].value
    numerator, denominator = exif["ExposureTime"]
    assert numerator / denominator == pytest.approx(exposure_s, rel=1e-6)
    numerator, denominator = exif["FocalLength"]
    assert numerator / denominator == pytest.approx(focal_mm, rel=1e-6)


@pytest.mark.parametrize("pattern", [(0, 0, 0, 0), (0, 1, 1, 1), (3, 3, 3, 3)])
def test_a_cfa_pattern_without_red_green_and_blue_is_refused(tmp_path, pattern):
    """Issue 25 #7: CFAPattern 0 0 0 0 read as a monochrome image and developed grey (exit 0)."""
    from spectral_cam.errors import RawFormatError

    raw = RawImage(np.full((64, 64), 500, np.uint16), "RGGB", 64.0, 4095, as_shot_neutral=np.ones(3))
    path = write_dng(raw, tmp_path / "cfa.dng")
    with tifffile.TiffFile(path, mode="r+b") as tif:
        tif.pages[0].tags[33422].overwrite(pattern)
    with pytest.raises(RawFormatError, match=r"CFAPattern .* lacks one of red \(0\), green \(1\) and blue \(2\)"):
        read_raw(path)


def test_an_empty_file_is_called_empty(tmp_path):
    """Issue 25 #16: a 0-byte file reported LibRaw's "Input/output error"."""
    from spectral_cam.errors import RawFormatError

    (tmp_path / "empty.dng").write_bytes(b"")
    with pytest.raises(RawFormatError, match=r"is empty \(0 bytes\): not a raw file"):
        read_raw(tmp_path / "empty.dng")


def test_libraw_messages_join_our_error_instead_of_leaking(tmp_path, monkeypatch, capfd):
    """Issue 25 #16: LibRaw's default data callback prints "<file>: Unexpected end of file" on
    file descriptor 2 (C stdio, past Python's sys.stderr) and goes on with zeros; the line leaked
    above our message. Here a stand-in for rawpy.imread writes it to descriptor 2 as LibRaw's C
    code does, once failing and once returning data."""
    import os

    import rawpy

    from spectral_cam.errors import RawFormatError
    from spectral_cam.raw import RawImage, write_dng

    path = write_dng(RawImage(np.full((32, 32), 500, np.uint16), "RGGB", 64.0, 4095), tmp_path / "x.dng")
    real = rawpy.imread

    def failing(name):
        os.write(2, f"{name}: Unexpected end of file\n".encode())
        raise rawpy.LibRawIOError(b"Input/output error")

    def reading_on(name):
        os.write(2, f"{name}: Unexpected end of file\n".encode())
        return real(name)

    for stand_in, expected in ((failing, r"Input/output error'? \(LibRaw: .*Unexpected end of file\)"),
                               (reading_on, r"truncated or corrupt: LibRaw read it with errors \(.*Unexpected end")):
        monkeypatch.setattr(rawpy, "imread", stand_in)
        with pytest.raises(RawFormatError, match=expected):
            read_raw(path)
        assert capfd.readouterr().err == ""  # nothing reached the terminal
    monkeypatch.setattr(rawpy, "imread", real)
    os.write(2, b"after\n")  # descriptor 2 is the terminal's again
    assert read_raw(path).mosaic.shape == (32, 32) and capfd.readouterr().err == "after\n"
