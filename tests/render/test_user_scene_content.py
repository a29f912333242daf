"""Issue 15 #1: a user's XML scene with the content people bring (a bitmap-textured wall, a
checkerboard floor, spheres, an OBJ mesh, an environment map and an area light) renders through
the whole chain with depth and every dataset label."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spectral_cam import scene_from_dict
from spectral_cam.apps.dataset.labels import LABELS, write_item
from spectral_cam.exr import write_exr_channels
from spectral_cam.isp.encode import png_bytes

pytestmark = pytest.mark.timeout(300)

ORIGIN, TARGET = np.array([0.0, 1.2, -3.0]), np.array([0.0, 0.4, 0.0])

SCENE = """<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="50"/>
    <transform name="to_world"><lookat origin="0, 1.2, -3" target="0, 0.4, 0" up="0, 1, 0"/></transform>
  </sensor>
  <shape type="rectangle" id="floor">
    <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><texture name="reflectance" type="checkerboard">
      <rgb name="color0" value="0.2"/><rgb name="color1" value="0.8"/>
      <transform name="to_uv"><scale x="8" y="8"/></transform></texture></bsdf>
  </shape>
  <shape type="rectangle" id="wall">
    <transform name="to_world"><scale x="4" y="2"/><translate value="0, 2, 3"/></transform>
    <bsdf type="diffuse"><texture name="reflectance" type="bitmap"><string name="filename" value="wall.png"/></texture></bsdf>
  </shape>
  <shape type="sphere" id="red_ball"><point name="center" value="0.9, 0.4, 0.6"/><float name="radius" value="0.4"/>
    <bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.7, 0.1, 0.1"/></bsdf></shape>
  <shape type="sphere" id="glass_ball"><point name="center" value="-0.9, 0.3, 0.2"/><float name="radius" value="0.3"/>
    <bsdf type="dielectric"/></shape>
  <shape type="obj" id="pyramid"><string name="filename" value="pyramid.obj"/>
    <transform name="to_world"><scale value="0.5"/><translate value="-1.8, 0, 1.8"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.5, 0.2"/></bsdf></shape>
  <shape type="rectangle" id="lamp">
    <transform name="to_world"><scale value="1.5"/><rotate x="1" angle="90"/><translate value="0, 3.5, 0"/></transform>
    <emitter type="area"><spectrum name="radiance" type="blackbody"><float name="temperature" value="2856"/></spectrum></emitter>
  </shape>
  <emitter type="envmap" id="sky"><string name="filename" value="sky.exr"/><float name="scale" value="0.5"/></emitter>
</scene>
"""

PYRAMID = """v -1 0 -1
v 1 0 -1
v 1 0 1
v -1 0 1
v 0 1.5 0
f 1 2 5
f 2 3 5
f 3 4 5
f 4 1 5
"""


@pytest.fixture
def room(tmp_path):
    y, x = np.mgrid[0:64, 0:128]
    stripes = np.stack([(x // 8) % 2 * 200 + 30, (y // 8) % 2 * 150 + 50, np.full_like(x, 120)], axis=-1)
    (tmp_path / "wall.png").write_bytes(png_bytes(stripes.astype(np.uint8)))
    sky = np.linspace(0.2, 1.0, 32, dtype=np.float32)[:, None] * np.ones((32, 64), np.float32)
    write_exr_channels({"R": 0.6 * sky, "G": 0.8 * sky, "B": sky}, tmp_path / "sky.exr")
    (tmp_path / "pyramid.obj").write_text(PYRAMID)
    (tmp_path / "room.xml").write_text(SCENE)
    return scene_from_dict({"scene": {"mitsuba_xml": str(tmp_path / "room.xml")},
                            "sensor": {"width_px": 64, "height_px": 48}, "render": {"spp": 16},
                            "lens": {"model": "thin", "f_number": 8.0, "focus_distance_m": 4.0}})


def test_a_textured_meshed_env_lit_scene_gives_every_label(room, tmp_path):
    import warnings

    from spectral_cam.errors import SceneWarning

    outputs = list(LABELS)
    with warnings.catch_warnings():
        warnings.simplefilter("error", SceneWarning)  # re-renders of the resolved scene stay quiet
        meta = write_item(room, tmp_path / "item", outputs=outputs, dataset={"id": "room"})
    files = {p.name for p in (tmp_path / "item").iterdir()}
    for name in ("raw.dng", "image.png", "depth.exr", "defocus.exr", "clean_rgb.exr", "all_in_focus.png", "meta.json"):
        assert name in files, (name, files)
    decision = meta["model_decisions"]["illuminant"]
    assert decision["emitter"] == "lamp" and set(decision["emitters"]) == {"lamp", "sky"}
    assert meta["config"]["illuminant"]["spd"] == "blackbody:2856" and meta["config"]["illuminant"]["emitter"] == "lamp"
    assert meta["model_decisions"]["field_of_view"]["choice"] == "kept"


def test_depth_of_a_user_scene_matches_its_geometry(room):
    """Down the middle columns the camera sees the floor (y = 0). For pixel row r the ray leaves
    (0, 1.2, −3) at the vertical angle θ_r, tan θ_r = (H/2 − r − ½)/(W/2)·tan(fov_x/2), and meets
    the floor at t = 1.2/(−d_y); its camera-space z is t·(d·forward). The depth label, averaged
    over 8 columns (one random sample per pixel), matches within 1.5 %; the centre row within
    a pixel's spread of the 1.5·√(0.8² + 3²) m the axis meets."""
    from spectral_cam import render

    image = render(room)
    h, w = image.depth_m.shape
    forward = (TARGET - ORIGIN) / np.linalg.norm(TARGET - ORIGIN)
    left = np.cross([0.0, 1.0, 0.0], forward)
    up = np.cross(forward, left / np.linalg.norm(left))
    half_tan = math.tan(math.radians(image.meta["model_decisions"]["field_of_view"]["fov_x_deg"]) / 2)
    for row in range(h // 2, h // 2 + 8):
        direction = forward + (h / 2 - row - 0.5) / (w / 2) * half_tan * up
        direction /= np.linalg.norm(direction)
        expected = ORIGIN[1] / -direction[1] * direction @ forward
        measured = float(image.depth_m[row, w // 2 - 4:w // 2 + 4].mean())
        assert abs(measured / expected - 1) < 0.015, (row, measured, expected)
    assert abs(image.depth_m[h // 2 - 1:h // 2 + 1, w // 2 - 4:w // 2 + 4].mean() / (1.5 * math.hypot(0.8, 3.0)) - 1) < 0.02


@pytest.mark.parametrize("offset, rotation, expected", [
    ([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], 4.0),  # a metre closer to the plane 5 m ahead
    ([0.0, 0.0, 0.0], [20.0, 0.0, 0.0], 5.0 / math.cos(math.radians(20.0))),  # yawed: the axis meets it at 5/cos θ
    ([0.0, 0.0, 0.0], [0.0, 20.0, 0.0], 5.0 / math.cos(math.radians(20.0))),  # pitched, the same
])
def test_the_xml_camera_moves_in_its_own_frame(tmp_path, offset, rotation, expected):
    """The XML camera at (1, 2, −3) faces a plane at z = 2: moved along its view it sees the
    plane 1 m nearer; turned by θ its central ray meets the plane at 5/cos θ, which is that
    point's camera-space depth. Column 0 is image-left (camera +x), row 0 image-up."""
    from spectral_cam import render

    from .test_radiometry import XML_SCENE

    path = tmp_path / "plane.xml"
    path.write_text(XML_SCENE)
    config = scene_from_dict({"scene": {"mitsuba_xml": str(path), "camera_offset_m": offset,
                                        "camera_rotation_deg": rotation},
                              "sensor": {"width_px": 16, "height_px": 12}, "render": {"spp": 4}})
    depth = render(config).depth_m
    centre = depth[5:7, 7:9].mean()
    assert centre == pytest.approx(expected, rel=2e-3)
    # turned left (yaw > 0), image-left rays meet the plane more obliquely, so farther; tilted up
    # (pitch > 0), the top rows do
    if rotation[0] > 0:
        assert depth[:, 0].mean() > depth[:, -1].mean()
    if rotation[1] > 0:
        assert depth[0].mean() > depth[-1].mean()


def test_moving_a_presets_camera_is_refused():
    from spectral_cam.errors import ConfigError

    with pytest.raises(ConfigError, match="move an XML scene's camera"):
        scene_from_dict({"scene": {"camera_offset_m": [0.0, 0.0, 1.0]}})
