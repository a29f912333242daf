"""Issue 39 #18: ``spectral-cam render`` takes a Mitsuba 3 ``.xml`` scene directly, without a
wrapper TOML, and keeps the XML camera's field of view."""

from __future__ import annotations

import json
import math

import pytest

from spectral_cam.cli import main

pytestmark = pytest.mark.timeout(240)

FOV_X_DEG = 40.0
SCENE = f"""<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="{FOV_X_DEG}"/>
    <transform name="to_world"><lookat origin="0, 0, -3" target="0, 0, 0" up="0, 1, 0"/></transform>
  </sensor>
  <shape type="rectangle" id="card">
    <bsdf type="diffuse"><rgb name="reflectance" value="0.18"/></bsdf>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="1.0"/></emitter>
</scene>
"""


def test_render_takes_an_xml_scene_and_keeps_its_field_of_view(tmp_path, monkeypatch):
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "card.xml").write_text(SCENE)
    monkeypatch.chdir(tmp_path)  # a relative path, as a user types it
    args = ["render", "scenes/card.xml", "-o", "out", "-q", "--set", "sensor.width_px=48",
            "--set", "sensor.height_px=32", "--set", "render.spp=4"]
    assert main(args) == 0
    camera = json.loads((tmp_path / "out" / "camera.json").read_text())
    width = 48
    fx = camera["K"][0][0]
    # pinhole: fx = (W/2) / tan(fov_x/2), the XML's own field of view on our sensor (the thin
    # lens focused at finite distance keeps the field of view, not the focal length)
    assert 2 * math.degrees(math.atan(width / 2 / fx)) == pytest.approx(FOV_X_DEG, rel=0.02)
    resolved = (tmp_path / "out" / "scene.toml").read_text()
    assert str((tmp_path / "scenes" / "card.xml").resolve()) in resolved


def test_a_missing_xml_scene_is_refused_naming_what_is_valid(tmp_path, capsys):
    assert main(["render", str(tmp_path / "nope.xml"), "-o", str(tmp_path / "out")]) != 0
    assert "does not exist; give a .toml scene file or a Mitsuba 3 .xml scene" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
