"""Issue 15 #3: a dataset over a folder of the user's XML scenes (one drawn per item), its camera
pose (around the file's), aperture and focus randomised, on the local cluster, resumable; each
item white-balanced for its own scene's light."""

from __future__ import annotations

import json

import pytest

from spectral_cam.apps.dataset import generate_dataset, load_spec
from spectral_cam.errors import ConfigError

from .reading import read_manifest

pytestmark = pytest.mark.timeout(300)

ROOM = """<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="{fov}"/>
    <transform name="to_world"><lookat origin="0, 1, -3" target="0, 0.4, 0" up="0, 1, 0"/></transform></sensor>
  <shape type="rectangle" id="floor">
    <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><spectrum name="reflectance" value="0.7"/></bsdf></shape>
  <shape type="sphere" id="ball"><point name="center" value="0.3, 0.4, 0.5"/><float name="radius" value="0.4"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.4, 0.7"/></bsdf></shape>
  <shape type="rectangle" id="lamp">
    <transform name="to_world"><rotate x="1" angle="90"/><translate value="0, 3, 0"/></transform>
    <emitter type="area"><spectrum name="radiance" type="blackbody"><float name="temperature" value="{kelvin}"/></spectrum></emitter>
  </shape>
</scene>"""

SPEC = """
[dataset]
seed = 3
outputs = ["raw", "image", "depth", "defocus"]

[scene]
mitsuba_xml = { files = "rooms/*.xml" }
camera_rotation_deg = { uniform = [[-10.0, -5.0, 0.0], [10.0, 5.0, 0.0]] }
camera_offset_m = { uniform = [[-0.2, -0.1, -0.5], [0.2, 0.1, 0.5]] }

[sensor]
width_px = 32
height_px = 24

[render]
spp = 4

[lens]
model = "thin"
f_number = { log_uniform = [1.4, 8.0] }
focus_distance_m = { uniform = [1.0, 5.0] }
"""


@pytest.fixture
def rooms_spec(tmp_path):
    (tmp_path / "rooms").mkdir()
    for name, fov, kelvin in (("tungsten", 50, 2856), ("daylight", 70, 6500)):
        (tmp_path / "rooms" / f"{name}.xml").write_text(ROOM.format(fov=fov, kelvin=kelvin))
    (tmp_path / "rooms" / "notes.txt").write_text("not a scene")
    path = tmp_path / "spec.toml"
    path.write_text(SPEC)
    return path


def test_a_folder_of_xml_scenes_is_a_choice_per_item_lit_by_its_own_emitter(rooms_spec, cluster, tmp_path):
    spec = load_spec(rooms_spec)
    rooms = sorted(str(p.resolve()) for p in (rooms_spec.parent / "rooms").glob("*.xml"))
    assert spec.distributions["scene.mitsuba_xml"].values == tuple(rooms)
    out = tmp_path / "out"
    # 10 items: each file is drawn with probability 1/2, so both appear but with odds 2/2**10
    summary = generate_dataset(spec, out, n=10, executor=cluster.executor, progress=False)
    assert (summary.rendered, summary.failed) == (10, 0)
    drawn = set()
    for row in read_manifest(out):
        meta = json.loads((out / row["path"] / "meta.json").read_text())
        xml = row["params"]["scene.mitsuba_xml"]
        drawn.add(xml)
        kelvin = 2856 if xml.endswith("tungsten.xml") else 6500
        assert meta["config"]["illuminant"]["spd"] == f"blackbody:{kelvin}"
        assert meta["model_decisions"]["field_of_view"]["choice"] == "kept"
        assert meta["model_decisions"]["field_of_view"]["xml_fov_x_deg"] == pytest.approx(50 if kelvin == 2856 else 70)
        assert 1.4 <= meta["config"]["lens"]["f_number"] <= 8.0
        yaw, pitch, roll = row["params"]["scene.camera_rotation_deg"]  # the pose drawn around the file's
        assert abs(yaw) <= 10 and abs(pitch) <= 5 and roll == 0
        assert meta["config"]["scene"]["camera_offset_m"] == pytest.approx(row["params"]["scene.camera_offset_m"])
    assert drawn == set(rooms)
    again = generate_dataset(spec, out, n=10, executor=cluster.executor, progress=False)  # resume
    assert (again.rendered, again.resumed) == (0, 10)


def test_a_files_pattern_that_matches_nothing_is_refused(tmp_path):
    path = tmp_path / "spec.toml"
    path.write_text(SPEC.replace("rooms/*.xml", "nowhere/*.xml"))
    with pytest.raises(ConfigError, match="matches no file"):
        load_spec(path)


def test_focus_on_a_named_object_is_its_surface_depth(tmp_path, make_scene):
    """``lens.focus_object = "ball"`` focuses on the sphere's near surface along the ray from the
    camera to its centre: depth (|c − o| − r)·(u·axis) by ray–sphere geometry, to 1e-5."""
    import numpy as np

    from spectral_cam import render

    path = tmp_path / "room.xml"
    path.write_text(ROOM.format(fov=50, kelvin=4000))
    config = make_scene(scene={"mitsuba_xml": str(path)}, lens={"focus_object": "ball", "model": "pinhole"},
                        render={"spp": 1})
    image = render(config, with_depth=False)
    origin, target, centre, radius = np.array([0, 1, -3.0]), np.array([0, 0.4, 0.0]), np.array([0.3, 0.4, 0.5]), 0.4
    axis = (target - origin) / np.linalg.norm(target - origin)
    distance = np.linalg.norm(centre - origin)
    expected = (distance - radius) * ((centre - origin) / distance) @ axis
    record = image.meta["model_decisions"]["focus"]
    assert record["object"] == "ball" and record["choice"] == pytest.approx(expected, rel=1e-5)
    assert image.lens.focus_distance_m == pytest.approx(expected, rel=1e-5)
    with pytest.raises(ConfigError, match="no shape of the scene; its shapes: ball, floor, lamp"):
        render(config.replace(**{"lens.focus_object": "chair"}), with_depth=False)


def test_a_dataset_focuses_each_item_on_the_object_it_names(rooms_spec, cluster, tmp_path):
    """Every item, whatever pose it drew, is focused on the ball: its defocus label is ~0 on the
    ball's pixels nearest the camera (|CoC| < 0.05 px somewhere in the frame)."""
    import numpy as np
    import OpenEXR

    text = rooms_spec.read_text().replace('focus_distance_m = { uniform = [1.0, 5.0] }', 'focus_object = "ball"')
    rooms_spec.write_text(text)
    out = tmp_path / "focused"
    summary = generate_dataset(load_spec(rooms_spec), out, n=2, executor=cluster.executor, progress=False)
    assert (summary.rendered, summary.failed) == (2, 0)
    for row in read_manifest(out):
        meta = json.loads((out / row["path"] / "meta.json").read_text())
        assert meta["model_decisions"]["focus"]["object"] == "ball"
        with OpenEXR.File(str(out / row["path"] / "defocus.exr")) as exr:
            coc = np.asarray(exr.channels()["CoC"].pixels)
        assert np.nanmin(np.abs(coc)) < 0.05
