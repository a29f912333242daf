"""camera.json (issue 27 #1) against OpenCV: world points projected by ``cv2.projectPoints``
with the file's K, distortion and pose land where Mitsuba renders them. The scene is a user's
XML file whose camera looks at small emitting spheres from an oblique pose, so K, the axis
flips and the pose are all exercised; the spheres' image centroids (radiance-weighted, found
independently with ``scipy.ndimage.label``) are the reference."""

from __future__ import annotations

import contextlib
import json

import cv2
import numpy as np
import pytest
from scipy import ndimage

import spectral_cam as sc
from spectral_cam.job import run_render_job
from spectral_cam.spectral_exr import read_spectral_exr

from .support.dots import POINTS, centroids, dots_xml

pytestmark = pytest.mark.timeout(300)



@pytest.mark.parametrize("model, distortion", [("pinhole", [0.0] * 5), ("thin", [0.0] * 5),
                                               ("spectral_thin", [-0.12, 0.03, 0.001, -0.002, 0.0])])
def test_opencv_projects_world_points_where_they_render(tmp_path, model, distortion):
    scene = {"scene": {"mitsuba_xml": str(dots_xml(tmp_path / "dots.xml"))},
             "sensor": {"width_px": 192, "height_px": 144, "pixel_pitch_um": 6.0},
             "lens": {"model": model, "distortion": distortion, "f_number": 8.0, "focus_distance_m": 2.9},
             "illuminant": {"emitter": "dot0"}, "render": {"spp": 64, "diffraction": "off"}}
    config = sc.scene_from_dict(scene)
    run_render_job(config, tmp_path / "out")
    camera = json.loads((tmp_path / "out" / "camera.json").read_text())
    pose = np.array(camera["world_to_camera_opencv"])
    rvec, _ = cv2.Rodrigues(pose[:3, :3])
    projected, _ = cv2.projectPoints(POINTS, rvec, pose[:3, 3], np.array(camera["K"]), np.array(camera["distortion"]))
    projected = projected.reshape(-1, 2)
    found = centroids(read_spectral_exr(tmp_path / "out" / "radiance.exr").data)
    assert len(found) == len(POINTS)
    distances = np.linalg.norm(projected[:, None, :] - found[None, :, :], axis=-1)
    assert distances.min(axis=1).max() < 0.5, distances.min(axis=1)
    assert camera["image_size"] == [192, 144]
    # OpenGL's pose is OpenCV's with y and z flipped
    np.testing.assert_allclose(np.diag([1, -1, -1, 1]) @ pose, camera["world_to_camera_opengl"], atol=1e-12)
    # the camera sits where the XML puts it
    np.testing.assert_allclose(np.array(camera["camera_to_world_opencv"])[:3, 3], [1.2, 0.7, -2.6], atol=1e-5)


@pytest.mark.parametrize("model", ["spectral_thin", "prescription"])
def test_our_python_cameras_follow_an_xml_cameras_pose(tmp_path, model):
    """Our Mitsuba cameras written in Python transformed the ray direction as a point
    (Point3f − Point3f stays a Point3f in Mitsuba's Python types), adding the camera's translation
    to it: from an XML camera at (1.2, 0.7, −2.6) the dots were missed (zero radiance). Through an
    ideal-glass thin lens the render must equal Mitsuba's own thin lens; through a prescription
    (50 mm: a 0.7° view of the dot it looks at), the dot's light must be centred in the frame."""
    lens = {"model": model, "f_number": 8.0, "focus_distance_m": 2.9}
    if model == "spectral_thin":
        lens["glass"] = "ideal"
    scene = {"scene": {"mitsuba_xml": str(dots_xml(tmp_path / "dots.xml"))}, "sensor": {"width_px": 96, "height_px": 72},
             "lens": lens, "illuminant": {"emitter": "dot0"}, "render": {"spp": 16, "diffraction": "off"}}
    with pytest.warns() if model == "prescription" else contextlib.nullcontext():
        ours = sc.render(sc.scene_from_dict(scene))
    if model == "spectral_thin":
        mitsuba = sc.render(sc.scene_from_dict({**scene, "lens": {**lens, "model": "thin"}}))
        assert float(mitsuba.data.sum()) > 0
        np.testing.assert_allclose(ours.data, mitsuba.data, rtol=1e-4, atol=1e-6)
    else:
        light = ours.data.sum(axis=-1)
        assert light.sum() > 0
        row, column = ndimage.center_of_mass(light)
        assert abs(column - 47.5) < 1.0 and abs(row - 35.5) < 1.0


#: A grid of dots 2 m ahead of a camera at the origin, out to 21° off axis.
WIDE_POINTS = np.array([[x, y, 2.0] for x in (-0.75, 0.0, 0.75) for y in (-0.5, 0.0, 0.5)])


def test_a_prescriptions_fitted_distortion_projects_where_its_real_rays_render(tmp_path):
    """Through the double Gauss (k1 ≈ −0.07: the dots at 21° move by ~1 px), camera.json's K
    (the chief rays' traced scale) and distortion (fitted to the chief rays) put OpenCV's
    projections within 0.5 px of the dots' centroids rendered through the real surfaces; K alone,
    without the distortion, misses by more."""
    spheres = "".join(f'''
    <shape type="sphere" id="dot{i}">
        <point name="center" x="{x}" y="{y}" z="{z}"/><float name="radius" value="0.006"/>
        <emitter type="area"><rgb name="radiance" value="20"/></emitter>
    </shape>''' for i, (x, y, z) in enumerate(WIDE_POINTS))
    xml = tmp_path / "grid.xml"
    xml.write_text(f'''<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 0" target="0, 0, 1" up="0, 1, 0"/></transform>
    </sensor>{spheres}
</scene>''')
    scene = {"scene": {"mitsuba_xml": str(xml)},
             "sensor": {"width_px": 160, "height_px": 120, "pixel_pitch_um": 260.0},
             "lens": {"model": "prescription", "prescription": "dgauss_50mm", "f_number": 8.0,
                      "focus_distance_m": 2.0},
             "illuminant": {"emitter": "dot4"}, "render": {"spp": 64, "diffraction": "off"}}
    with pytest.warns():  # the prescription's focal length replaces the configured one
        run_render_job(sc.scene_from_dict(scene), tmp_path / "out")
    camera = json.loads((tmp_path / "out" / "camera.json").read_text())
    assert camera["distortion"][0] < -0.03 and camera["distortion_residual_px"] < 0.05
    pose = np.array(camera["world_to_camera_opencv"])
    rvec, _ = cv2.Rodrigues(pose[:3, :3])
    found = centroids(read_spectral_exr(tmp_path / "out" / "radiance.exr").data)
    assert len(found) == len(WIDE_POINTS)

    def miss(distortion):
        projected, _ = cv2.projectPoints(WIDE_POINTS, rvec, pose[:3, 3], np.array(camera["K"]), np.array(distortion))
        distances = np.linalg.norm(projected.reshape(-1, 2)[:, None, :] - found[None, :, :], axis=-1)
        return distances.min(axis=1).max()

    assert miss(camera["distortion"]) < 0.5
    assert miss([0.0] * 5) > 0.7


def test_a_moving_cameras_pose_is_its_pose_at_mid_exposure(tmp_path):
    """A camera sliding sideways smears each dot into a streak whose centroid is the dot's image
    at mid-exposure: camera.json's pose projects there (within 0.5 px) and records the velocity."""
    scene = {"scene": {"mitsuba_xml": str(dots_xml(tmp_path / "dots.xml"))},
             "sensor": {"width_px": 192, "height_px": 144, "pixel_pitch_um": 6.0},
             "lens": {"model": "pinhole", "focus_distance_m": 2.9}, "exposure": {"time_s": 0.02},
             "motion": {"camera_velocity_mps": [1.5, 0.0, 0.0]},
             "illuminant": {"emitter": "dot0"}, "render": {"spp": 64, "diffraction": "off"}}
    run_render_job(sc.scene_from_dict(scene), tmp_path / "out")
    camera = json.loads((tmp_path / "out" / "camera.json").read_text())
    assert camera["motion"]["velocity_mps_opencv"] == [-1.5, -0.0, 0.0] and "middle" in camera["pose_time"]
    pose = np.array(camera["world_to_camera_opencv"])
    rvec, _ = cv2.Rodrigues(pose[:3, :3])
    projected, _ = cv2.projectPoints(POINTS, rvec, pose[:3, 3], np.array(camera["K"]), np.array(camera["distortion"]))
    found = centroids(read_spectral_exr(tmp_path / "out" / "radiance.exr").data)
    assert len(found) == len(POINTS)
    distances = np.linalg.norm(projected.reshape(-1, 2)[:, None, :] - found[None, :, :], axis=-1)
    assert distances.min(axis=1).max() < 0.5, distances.min(axis=1)
