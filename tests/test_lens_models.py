"""The lens-model registry (issue 41 #2): a model registered from outside the package renders end to
end through the render job, camera.json's K from its entry; every bundled model answers every field.

The reference for the toy model is OpenCV's pinhole projection (``cv2.projectPoints``) with the
K its entry declares: the rendered dots must lie where OpenCV puts them.
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings

import cv2
import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.errors import ConfigError
from spectral_cam.job import run_render_job
from spectral_cam.render.lens_models import LENS_MODELS, LensModel, pinhole_camera
from spectral_cam.spectral_exr import read_spectral_exr

from .support.dots import POINTS, centroids, dots_xml

pytestmark = pytest.mark.timeout(300)

#: The toy model: a pinhole behind a 1.25× teleconverter (its focal length 1.25 × the image distance).
TOY = "test_teleconverter_pinhole"
SCALE = 1.25



def _toy_camera(mi, config, lens, film, spp):
    """Mitsuba's perspective camera with the teleconverter's narrower field of view."""
    fov = 2.0 * math.degrees(math.atan(0.5 * lens.sensor_width_m / (SCALE * lens.image_distance_m)))
    return dict(pinhole_camera(mi, config, lens, film, spp), fov=fov)


def _toy_intrinsics(config, frame):
    return {"focal_length_m": SCALE * frame.image_distance_m, "coefficients": (0.0,) * 5,
            "source": "the toy teleconverter: no distortion", "residual_m": None}


if TOY not in LENS_MODELS:  # a module imported twice (pytest's rewrites) registers once
    LENS_MODELS.add(TOY, _toy_camera, intrinsics=_toy_intrinsics, description="a pinhole behind a 1.25× converter")


def test_a_lens_model_registered_outside_the_package_renders_end_to_end(tmp_path):
    scene = {"scene": {"mitsuba_xml": str(dots_xml(tmp_path / "dots.xml", fov_deg=None))},
             "sensor": {"width_px": 96, "height_px": 72, "pixel_pitch_um": 12.0},
             "lens": {"model": TOY, "f_number": 8.0, "focus_distance_m": 2.9},
             "illuminant": {"emitter": "dot0"}, "render": {"spp": 16, "diffraction": "off"}}
    config = sc.scene_from_dict(scene)
    run_render_job(config, tmp_path / "out")
    camera = json.loads((tmp_path / "out" / "camera.json").read_text())
    assert camera["lens_model"] == TOY
    # K from the entry: the converter's focal length (1.25 × the image distance) over the pixel pitch
    assert camera["K"][0][0] == pytest.approx(SCALE * camera["image_distance_mm"] * 1e-3 / 12e-6, rel=1e-12)
    pose = np.array(camera["world_to_camera_opencv"])
    rvec, _ = cv2.Rodrigues(pose[:3, :3])
    projected, _ = cv2.projectPoints(POINTS, rvec, pose[:3, 3], np.array(camera["K"]), np.array(camera["distortion"]))
    found = centroids(read_spectral_exr(tmp_path / "out" / "radiance.exr").data)
    assert len(found) == len(POINTS)
    distances = np.linalg.norm(projected.reshape(-1, 2)[:, None, :] - found[None, :, :], axis=-1)
    assert distances.min(axis=1).max() < 0.5, distances.min(axis=1)


def test_every_bundled_model_has_every_field():
    bundled = ("thin", "pinhole", "layered", "spectral_thin", "prescription")
    assert set(bundled) <= set(LENS_MODELS)
    config = sc.scene_from_dict({"sensor": {"width_px": 32, "height_px": 24}})
    frame = sc.optics.ThinLens.from_config(config.lens, config.sensor)
    for name in bundled:
        entry = LENS_MODELS[name]
        assert isinstance(entry, LensModel)
        for field in dataclasses.fields(LensModel):
            value = getattr(entry, field.name)
            assert value is not None or field.name == "render", (name, field.name)
        assert entry.memory_bytes_per_pixel(31) >= 0.0
        with warnings.catch_warnings():  # a prescription's own focal length replaces the configured one
            warnings.simplefilter("ignore")
            shading = entry.shading(config.replace(**{"lens.model": name}))
        assert set(shading) == {"traced_vignetting", "chief_ray_prescription"}
    # the layered model holds its defocus cubes; the path-traced ones nothing beyond the radiance
    assert LENS_MODELS["layered"].memory_bytes_per_pixel(31) > 6 * 4 * 31
    assert LENS_MODELS["thin"].memory_bytes_per_pixel(31) == 0.0
    optics = LENS_MODELS["thin"].intrinsics(config, frame)
    assert optics["focal_length_m"] is None and tuple(optics["coefficients"]) == (0.0,) * 5


def test_the_scene_checks_lens_model_against_the_registry():
    assert sc.scene_from_dict({"lens": {"model": TOY}}).lens.model == TOY
    with pytest.raises(ConfigError, match=f"valid: auto, thin, pinhole.*{TOY}"):
        sc.scene_from_dict({"lens": {"model": "fisheye"}})
    # a model that does not declare blades refuses them (the registry's field, not a name list)
    with pytest.raises(ConfigError, match="aperture blades"):
        sc.scene_from_dict({"lens": {"model": TOY, "blades": 6}})
    with pytest.raises(ValueError, match="auto"):
        LENS_MODELS.add("auto", pinhole_camera)


def test_the_sensor_shades_as_the_rendered_models_entry_says():
    """The render records its entry's shading; the sensor reads it from the image (sensor/ imports
    nothing of render/): a model that traces its vignetting gets no cos⁴ on top."""
    from types import SimpleNamespace

    from spectral_cam.sensor.radiometry import lens_shading

    config = sc.scene_from_dict({"sensor": {"width_px": 32, "height_px": 24}})
    traced = {"traced_vignetting": True, "chief_ray_prescription": "dgauss_50mm"}
    assert lens_shading(SimpleNamespace(meta={"lens_shading": traced}), config) == traced
    # an image that records none (a synthetic chart): the configured model's entry-free default
    assert lens_shading(SimpleNamespace(meta={}), config) == {"traced_vignetting": False,
                                                              "chief_ray_prescription": None}
    radiance = sc.render(sc.scene_from_dict({"sensor": {"width_px": 24, "height_px": 16},
                                             "lens": {"model": TOY}, "render": {"spp": 4}}))
    assert radiance.meta["lens_shading"] == LENS_MODELS[TOY].shading(config)
