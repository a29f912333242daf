"""Issue 27 #3: intrinsic images. The albedo of each ColorChecker patch, as camera RGB under the
scene light's white, against the camera's own response to the patch's reflectance under that
light integrated independently on a 1-nm grid (``camera_responses``); and albedo × shading
against the clean camera RGB of the radiance render on the flat, diffuse patches (rendered on the
albedo's 5-nm bands, 256 spp, diffraction off: its Airy blur carries the neighbours' light into a
small patch, 2.6 % on the blue patch's red)."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.apps.dataset import write_item
from spectral_cam.presets import colorchecker_patches
from spectral_cam.sensor.colour_calibration import camera_responses
from spectral_cam.spectra import colorchecker_reflectances

from .reading import read_exr

pytestmark = pytest.mark.timeout(300)


@pytest.mark.parametrize("light", ["D65", "A"])
def test_colorchecker_albedo_and_shading(make_scene, tmp_path, light):
    config = make_scene(scene={"preset": "colorchecker"}, sensor={"width_px": 120, "height_px": 80},
                        illuminant={"spd": light}, render={"spp": 256, "bands": "380:720:5", "diffraction": "off"})
    meta = write_item(config, tmp_path / "item", outputs=["albedo", "clean_rgb"])
    albedo, shading = read_exr(tmp_path / "item" / "albedo.exr"), read_exr(tmp_path / "item" / "shading.exr")["S"]
    clean = read_exr(tmp_path / "item" / "clean_rgb.exr")
    white = np.asarray(meta["albedo"]["white_camera_rgb_g1"])
    model = config.sensor.model
    reference_white = camera_responses(model, light, [1.0])[0]
    for patch, sd in zip(colorchecker_patches(config), colorchecker_reflectances().values()):
        rows, cols = patch.interior(0.25)
        expected = camera_responses(model, light, [sd])[0] / reference_white
        ours = np.array([albedo[c][rows, cols].mean() for c in "RGB"])
        np.testing.assert_allclose(ours, expected, rtol=0.01, err_msg=patch.name)
        # albedo × shading × the white's colour reproduces the clean image (R and B against G)
        s = shading[rows, cols].mean()
        for c, k in (("R", 0), ("B", 2)):
            ratio = clean[c][rows, cols].mean() / clean["G"][rows, cols].mean()
            assert ratio == pytest.approx(ours[k] * white[k] / ours[1], rel=0.02), (patch.name, c)
        assert 0.2 < s < 1.2
    assert meta["albedo"]["light"] == light
