"""illuminant.json (issue 27 #4) against independent references: the light's camera RGB as a
plain NumPy integral of the bundled camera curves (their CSV read here) against the SPD
(colour-science's tables on a 1-nm grid), and its chromaticity and CCT against the CIE values
of the standard illuminants."""

from __future__ import annotations

import json
from pathlib import Path

import colour
import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.job import run_render_job

pytestmark = pytest.mark.timeout(300)
CAMERAS = Path(sc.__file__).parent / "data" / "cameras"


def _camera_rgb(model: str, spd: str) -> np.ndarray:
    table = np.loadtxt(CAMERAS / f"{model}.csv", delimiter=",", skiprows=1)
    grid = np.arange(table[0, 0], table[-1, 0] + 1.0)
    curves = np.stack([np.interp(grid, table[:, 0], table[:, c]) for c in (1, 2, 3)], axis=1)
    sd = colour.SDS_ILLUMINANTS[spd].copy().align(colour.SpectralShape(360, 830, 1))
    power = np.interp(grid, sd.wavelengths, sd.values)
    rgb = (power[:, None] * curves).sum(axis=0)  # per-energy responsivities × spectral power, 1-nm steps
    return rgb / rgb.max()


@pytest.mark.parametrize("spd, x, y, cct", [("D65", 0.31272, 0.32903, 6504.0), ("A", 0.44757, 0.40745, 2856.0),
                                            ("FL11", 0.38052, 0.37713, 4000.0)])
def test_the_lights_camera_rgb_chromaticity_and_cct(tmp_path, spd, x, y, cct):
    # CIE 15:2004 Table T.3/T.8 chromaticities; CCTs: D65 6504 K, A 2856 K, FL11 4000 K
    config = sc.scene_from_dict({"sensor": {"width_px": 48, "height_px": 32, "model": "nikon_d850"},
                                 "illuminant": {"spd": spd}, "render": {"spp": 2}})
    run_render_job(config, tmp_path / "out")
    record = json.loads((tmp_path / "out" / "illuminant.json").read_text())
    np.testing.assert_allclose(record["camera_rgb"], _camera_rgb("nikon_d850", spd), rtol=0.005)
    rgb = np.array(record["camera_rgb"])
    np.testing.assert_allclose(record["camera_rgb_g1"], rgb / rgb[1], rtol=1e-12)
    assert np.linalg.norm(record["camera_rgb_unit"]) == pytest.approx(1.0)
    assert record["xy"] == pytest.approx([x, y], abs=2e-4)
    assert record["cct_k"] == pytest.approx(cct, abs=40 if spd == "FL11" else 5)
