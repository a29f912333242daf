"""The README's Python snippet and ``spectral-cam render`` give the same RAW, byte for byte
(issue 12 #3: the API auto-exposed on the 99th percentile, the CLI on the white patch)."""

from __future__ import annotations

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.cli import main
from spectral_cam.sensor import signal_model

pytestmark = pytest.mark.timeout(180)

SMALL = {"sensor.width_px": 96, "sensor.height_px": 64, "render.spp": 16}


def test_the_readme_snippet_and_the_cli_write_the_same_dng(tmp_path):
    scene_file = "scenes/colorchecker.toml"
    # the README's snippet, on a small frame
    scene = sc.load_scene(scene_file, overrides={"lens.f_number": 2.8, **SMALL})
    radiance = sc.render(scene, with_margin=True)
    raw = sc.expose(radiance, scene)
    sc.write_dng(raw, tmp_path / "api.dng")
    # the command line on the same scene
    args = ["render", scene_file, "-o", str(tmp_path / "cli"), "-q", "--set", "lens.f_number=2.8"]
    for key, value in SMALL.items():
        args += ["--set", f"{key}={value}"]
    assert main(args) == 0
    assert (tmp_path / "api.dng").read_bytes() == (tmp_path / "cli" / "raw.dng").read_bytes()
    # and both metered as a camera meters (ISO 12232): the mean white-balanced luminance
    # ¼R + ½G + ¼B of the photo-electron rates (gains 1/AsShotNeutral) at 10/78 of saturation,
    # t = (10/78)·saturation / (r + I_d)
    model = signal_model(radiance, scene)
    rates = np.asarray(radiance.data, float).reshape(-1, radiance.data.shape[-1]) @ np.asarray(model.weights, float)
    rates *= np.asarray(model.cos4, float).reshape(-1, 1)  # natural vignetting, cos⁴θ
    gains = 1.0 / np.asarray(raw.as_shot_neutral, float)
    r = (rates @ (np.array([0.25, 0.5, 0.25]) * gains)).mean()
    expected = 10 / 78 * raw.meta["saturation_e"] / (r + scene.sensor.dark_current_e_per_s)
    assert raw.meta["exposure_s"] == pytest.approx(expected, rel=1e-5)
