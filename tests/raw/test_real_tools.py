"""Our DNG opened by the tools photographers use (issue 13 #1, #2): exiftool's validator,
dcraw's metadata and its development under D65 against colour-science's ground truth.
CI installs both (``.ci/run``: Debian ``dcraw``, ``libimage-exiftool-perl``)."""

from __future__ import annotations

import io
import shutil
import subprocess

import numpy as np
import pytest
import tifffile

from spectral_cam import expose, scene_from_dict
from spectral_cam.charts import reflectance_set, synthetic_chart
from spectral_cam.colorimetry import patch_linear_srgb
from spectral_cam.metrics import colorchecker_delta_e
from spectral_cam.raw import write_dng

pytestmark = pytest.mark.timeout(120)

QUIET = {"shot_noise": False, "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0}


def _tool(name: str) -> str:
    path = shutil.which(name)
    assert path, f"{name} is needed: apt-get install dcraw libimage-exiftool-perl (as .ci/run does)"
    return path


def _chart_dng(tmp_path, illuminant: str, **lens):
    """A noise-free synthetic ColorChecker under ``illuminant``, auto-exposed on its white."""
    chart = synthetic_chart(reflectance_set("colorchecker"), illuminant, patch_px=16, gap_px=4)
    height, width = chart.radiance.data.shape[:2]
    config = scene_from_dict({"scene": {"preset": "flat_field"}, "illuminant": {"spd": illuminant},
                              "lens": {"focal_length_mm": 35.0, "f_number": 5.6, **lens},
                              "sensor": {"width_px": width, "height_px": height, "vignetting": False, **QUIET},
                              "exposure": {"iso": 400}})
    mask = np.zeros((height, width), bool)
    mask[chart.patches[chart.white_index].interior(0.2)] = True
    raw = expose(chart.radiance, config, white_mask=mask)
    return chart, raw, write_dng(raw, tmp_path / f"chart_{illuminant}.dng")


def test_exiftool_validates_our_dng_without_a_warning(tmp_path):
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
    result = colorchecker_delta_e(linear_srgb, patch_linear_srgb("D65"), chart.patches[:24])
    assert result["mean"] < 1.1 and result["max"] < 3.2
