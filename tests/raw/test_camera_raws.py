"""A real camera's raw file (issue 13 #4): ``read_raw`` + ``develop`` against LibRaw (rawpy)
on the same file, and the same data through our DNG writer.

The file is a Canon EOS 30D CR2 from Debian's archive (tests/support/samples.py gives its
provenance and licence). Reference: LibRaw's development with the camera's white balance, no
auto-brightening, linear output in sRGB primaries, AHD. Colour is compared on 8 × 8-pixel box
means (so the two demosaicers' different edge rendering does not count), patches where
neither image clips.
"""

from __future__ import annotations

import re
from pathlib import Path

import colour
import numpy as np
import pytest
import rawpy

from spectral_cam.errors import RawFormatError
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.raw import read_raw, write_dng

from ..support.samples import CANON_30D_CR2, sample_path

pytestmark = pytest.mark.timeout(240)

LINEAR_DNG = ISPConfig(colour_matrix="dng", tone="linear", white_balance="as_shot")


def _libraw_linear_srgb(path) -> np.ndarray:
    with rawpy.imread(str(path)) as handle:
        rgb = handle.postprocess(use_camera_wb=True, no_auto_bright=True, gamma=(1, 1), output_bps=16,
                                 output_color=rawpy.ColorSpace.sRGB, demosaic_algorithm=rawpy.DemosaicAlgorithm.AHD,
                                 user_flip=0)
    return rgb.astype(np.float64) / 65535.0


def _box_means(rgb: np.ndarray, k: int = 8) -> np.ndarray:
    h, w = rgb.shape[0] // k * k, rgb.shape[1] // k * k
    return rgb[:h, :w].reshape(h // k, k, w // k, k, 3).mean(axis=(1, 3))


def _compare(ours: np.ndarray, libraw: np.ndarray) -> tuple[float, float]:
    """(mean ΔE2000, exposure ratio ours/LibRaw in luminance) on unclipped box means."""
    a, b = _box_means(ours), _box_means(libraw)
    unclipped = (a.max(axis=-1) < 0.9) & (b.max(axis=-1) < 0.9) & (b.min(axis=-1) > 1e-3)
    space = colour.models.RGB_COLOURSPACE_sRGB

    def lab(rgb):
        return colour.XYZ_to_Lab(colour.RGB_to_XYZ(rgb, space, apply_cctf_decoding=False))

    delta_e = colour.delta_E(lab(a[unclipped]), lab(b[unclipped]), method="CIE 2000")
    luminance = np.array([0.2126, 0.7152, 0.0722])
    return float(delta_e.mean()), float((a[unclipped] @ luminance).mean() / (b[unclipped] @ luminance).mean())


@pytest.fixture(scope="module")
def canon_cr2():
    return sample_path(CANON_30D_CR2)


@pytest.fixture(scope="module")
def canon_as_dng(canon_cr2, tmp_path_factory):
    return write_dng(read_raw(canon_cr2), tmp_path_factory.mktemp("canon") / "IMG_5952.dng")


def test_a_canon_cr2_reads_with_the_camera_metadata_libraw_knows(canon_cr2):
    raw = read_raw(canon_cr2)
    with rawpy.imread(str(canon_cr2)) as handle:
        assert np.array_equal(raw.mosaic, handle.raw_image_visible) and raw.cfa == "RGGB"
        assert raw.white_level == handle.white_level
        wb = np.asarray(handle.camera_whitebalance[:3], float)
        np.testing.assert_allclose(raw.as_shot_neutral, (1 / wb) / (1 / wb).max())
        cam_xyz = np.asarray(handle.rgb_xyz_matrix[:3])  # LibRaw's table (Adobe's D65 matrix)
    np.testing.assert_allclose(raw.color_matrix / np.abs(raw.color_matrix).max(), cam_xyz / np.abs(cam_xyz).max())
    assert (raw.meta["make"], raw.meta["model"]) == ("Canon", "Canon EOS 30D")
    top, left, height, width = raw.crop  # the camera's crop, inside the visible area
    assert top + height <= raw.mosaic.shape[0] and left + width <= raw.mosaic.shape[1]


def test_a_canon_cr2_develops_as_libraw_develops_it(canon_cr2):
    """Measured: 0.43 mean ΔE2000, exposure ratio 1.0015 (the issue asks ≤ 1.5 and 1 %)."""
    raw = read_raw(canon_cr2)
    ours = develop(raw, LINEAR_DNG).linear
    top, left, height, width = raw.crop  # LibRaw develops the whole visible area
    libraw = _libraw_linear_srgb(canon_cr2)[top:top + height, left:left + width]
    assert ours.shape == libraw.shape
    delta_e, exposure = _compare(ours, libraw)
    assert delta_e < 1.5 and exposure == pytest.approx(1.0, abs=0.01), (delta_e, exposure)


def test_the_canon_data_in_our_dng_keeps_everything_and_develops_as_libraw_develops_it(canon_cr2, canon_as_dng):
    """The camera's mosaic, levels, white balance, matrix and crop through write_dng: read back
    unchanged, and the DNG developed by us and by LibRaw agrees as the CR2 did."""
    original, back = read_raw(canon_cr2), read_raw(canon_as_dng)
    assert np.array_equal(original.mosaic, back.mosaic) and back.crop == original.crop
    np.testing.assert_array_equal(np.asarray(back.black_level), np.asarray(original.black_level))
    np.testing.assert_allclose(back.as_shot_neutral, original.as_shot_neutral, rtol=1e-6)
    np.testing.assert_allclose(back.color_matrix, original.color_matrix, atol=1e-4)
    ours = develop(back, LINEAR_DNG).linear
    top, left, height, width = back.crop
    libraw = _libraw_linear_srgb(canon_as_dng)[top:top + height, left:left + width]
    delta_e, exposure = _compare(ours, libraw)
    assert delta_e < 1.5 and exposure == pytest.approx(1.0, abs=0.01), (delta_e, exposure)


CUT_DOWN = Path(__file__).resolve().parents[1] / "data" / "cut_down_raws"


@pytest.mark.parametrize("name, what", [("canon_350d_cut_down.dng", "22 bytes for 8.2 MP"),
                                        ("panasonic_lx3_cut_down.rw2", "99.8% of the samples are 0")])
def test_cut_down_camera_raws_are_refused_not_developed_to_black(tmp_path, cli_env, name, what):
    """ExifTool's test raws keep the metadata and drop the image data; LibRaw opens them without
    an error. The DNG's raw SubIFD has 22 bytes of lossless JPEG for 8.2 MP (LibRaw fills the
    image with zeros, or with stale memory: the check reads the file's structure); the RW2,
    which tifffile cannot parse, decodes to 0.2 % set samples, far below its black level 15."""
    import subprocess
    import sys

    with pytest.raises(RawFormatError, match=f"holds no data \\({re.escape(what)}"):
        read_raw(CUT_DOWN / name)
    out = tmp_path / "out.png"
    done = subprocess.run([sys.executable, "-m", "spectral_cam.cli", "develop", str(CUT_DOWN / name), "-o", str(out)],
                          capture_output=True, text=True, env=cli_env, timeout=60)
    assert done.returncode == 2 and "holds no data" in done.stderr and "Traceback" not in done.stderr
    assert not list(tmp_path.iterdir())
