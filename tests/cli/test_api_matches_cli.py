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
    # and both exposed for the white patch: t = fraction·saturation / (r + I_d), r the patch's
    # mean max-channel photo-electron rate (ISO 12232 saturation-based exposure)
    white = radiance.white_reference
    assert white is not None and white.sum() > 4
    model = signal_model(radiance, scene)
    rates = np.asarray(radiance.data, float)[white] @ np.asarray(model.weights, float)
    rates *= np.asarray(model.cos4, float)[white][:, None]  # natural vignetting, cos⁴θ
    r = rates.max(axis=1).mean()
    expected = scene.exposure.auto_fraction * raw.meta["saturation_e"] / (r + scene.sensor.dark_current_e_per_s)
    assert raw.meta["exposure_s"] == pytest.approx(expected, rel=1e-5)
