"""Issue 15 #1: a user's XML scene is white-balanced, colour-corrected and given its ground truth
under its own emitters' light, and keeps its camera's field of view."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from spectral_cam import scene_from_dict
from spectral_cam.errors import ConfigError, SceneWarning
from spectral_cam.render.lights import LIGHT_GRID_NM, resolve_light, scene_emitters
from spectral_cam.xml_scene import xml_field_of_view

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.timeout(240)

CAMERA = """<sensor type="perspective">
    <float name="fov" value="{fov}"/>{axis}
    <transform name="to_world"><lookat origin="0, 1.2, -3" target="0, 0.4, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="320"/><integer name="height" value="240"/></film>
  </sensor>"""

ROOM = """<scene version="3.0.0">
  {camera}
  <shape type="rectangle" id="floor">
    <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><spectrum name="reflectance" value="0.8"/></bsdf>
  </shape>
  <shape type="sphere" id="ball"><point name="center" value="0.6, 0.4, 0.5"/><float name="radius" value="0.4"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.2, 0.1"/></bsdf></shape>
  {lights}
</scene>"""

TUNGSTEN = """<shape type="rectangle" id="lamp">
    <transform name="to_world"><scale value="1.5"/><rotate x="1" angle="90"/><translate value="0, 3, 0"/></transform>
    <emitter type="area"><spectrum name="radiance" type="blackbody"><float name="temperature" value="2856"/></spectrum></emitter>
  </shape>"""


def _scene(tmp_path, lights=TUNGSTEN, fov=60.0, axis="", **sections):
    path = tmp_path / "room.xml"
    path.write_text(ROOM.format(camera=CAMERA.format(fov=fov, axis=axis), lights=lights))
    sections.setdefault("sensor", {"width_px": 48, "height_px": 36})
    sections.setdefault("render", {"spp": 16})
    return scene_from_dict({"scene": {"mitsuba_xml": str(path)}, **sections})


def _relative(values):
    values = np.asarray(values, float)
    return values / values.max()


def test_a_tungsten_area_light_is_read_as_cie_illuminant_a(tmp_path):
    """Issue check: the 2856 K blackbody emitter equals colour-science's Standard Illuminant A
    (Planck at 2856 K with c2 = 1.435e-2 m·K) in shape within 0.5 % over 380–780 nm."""
    import colour

    config = _scene(tmp_path)
    (lamp,) = scene_emitters(config)
    assert lamp.name == "lamp" and lamp.plugin == "AreaLight" and lamp.temperature_k == pytest.approx(2856)
    a = colour.SDS_ILLUMINANTS["A"].copy().align(colour.SpectralShape(360, 830, 5))
    visible = (LIGHT_GRID_NM >= 380) & (LIGHT_GRID_NM <= 780)
    ratio = lamp.spectrum[visible] / a.values[visible]
    assert np.ptp(ratio / ratio.mean()) < 0.005
    resolved, record = resolve_light(config)
    assert resolved.illuminant.spd == "blackbody:2856" and record["emitter"] == "lamp"


def test_a_tabulated_emitter_spectrum_is_taken_as_the_file_writes_it(tmp_path):
    """An irregular spectrum on a point light: the resolved CSV holds the XML's own numbers
    (linearly interpolated between them, zero outside, as Mitsuba's irregular spectrum is)."""
    from spectral_cam.spectra import load_spectrum_csv

    xml_points = [(400, 1.0), (450, 3.0), (600, 2.0), (700, 0.5)]
    value = ", ".join(f"{w}:{v}" for w, v in xml_points)
    lights = f'<emitter type="point" id="bulb"><point name="position" value="0, 2, 0"/>' \
             f'<spectrum name="intensity" value="{value}"/></emitter>'
    resolved, record = resolve_light(_scene(tmp_path, lights=lights))
    assert record["emitter"] == "bulb" and resolved.illuminant.spd.endswith(".csv")
    sd = load_spectrum_csv(resolved.illuminant.spd)
    expected = np.interp(sd.wavelengths, *zip(*xml_points), left=0.0, right=0.0)
    np.testing.assert_allclose(_relative(sd.values), _relative(expected), atol=2e-3)


def test_the_emitter_sending_the_camera_most_light_is_chosen_and_recorded(tmp_path):
    weak_blue = '<emitter type="point" id="blue_bulb"><point name="position" value="-1, 1, -1"/>' \
                '<spectrum name="intensity" value="400:0.5, 500:0.1, 700:0.01"/></emitter>'
    config = _scene(tmp_path, lights=TUNGSTEN + weak_blue)
    resolved, record = resolve_light(config)
    assert record["emitter"] == "lamp" and resolved.illuminant.spd == "blackbody:2856"
    shares = {name: e["share"] for name, e in record["emitters"].items()}
    assert set(shares) == {"lamp", "blue_bulb"} and sum(shares.values()) == pytest.approx(1.0)
    assert shares["lamp"] > 0.9
    chosen = config.replace(**{"illuminant.emitter": "blue_bulb"})
    assert resolve_light(chosen)[1]["emitter"] == "blue_bulb"
    with pytest.raises(ConfigError, match="lamp, blue_bulb|blue_bulb, lamp"):
        resolve_light(config.replace(**{"illuminant.emitter": "sun"}))


def test_an_emitter_named_for_a_preset_is_refused():
    config = scene_from_dict({"illuminant": {"emitter": "lamp"}})
    with pytest.raises(ConfigError, match="is lit by \\[illuminant\\]"):
        resolve_light(config)


def test_setting_illuminant_for_an_xml_scene_is_a_warning(tmp_path):
    config = _scene(tmp_path, illuminant={"spd": "D65"})
    with pytest.warns(SceneWarning, match="does not light the scene"):
        resolved, record = resolve_light(config)
    assert resolved.illuminant.spd == "D65"


def test_a_white_floor_under_tungsten_develops_neutral_without_touching_illuminant(tmp_path):
    """Acceptance: as-shot white balance and the matrix from the scene's own 2856 K light make
    the white floor neutral (chroma C*ab < 1 in CIELAB, colour-science); assuming D65, as
    before, leaves it orange (C*ab > 10)."""
    from spectral_cam.job import simulate
    from tests.support.chroma import region_chroma

    def floor_chroma(config):
        sim = simulate(config)
        return region_chroma(sim.developed.image, (0.75, 0.95), (0.1, 0.4)), sim

    isp = {"tone": "srgb"}
    chroma, sim = floor_chroma(_scene(tmp_path, sensor={"width_px": 96, "height_px": 72}, isp=isp))
    assert sim.config.illuminant.spd == "blackbody:2856"
    assert sim.radiance.meta["model_decisions"]["illuminant"]["emitter"] == "lamp"
    assert chroma < 1.0, chroma
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        wrong, _ = floor_chroma(_scene(tmp_path, sensor={"width_px": 96, "height_px": 72}, isp=isp,
                                       illuminant={"spd": "D65"}))
    assert wrong > 10.0, wrong


@pytest.mark.parametrize("fov, axis, expected_x", [
    (60.0, "", 60.0),
    # fov on y of a 320 × 240 film: tan(x/2) = tan(30°)·320/240
    (60.0, '<string name="fov_axis" value="y"/>', 2 * math.degrees(math.atan(math.tan(math.radians(30)) * 4 / 3))),
    # diagonal: tan(x/2) = tan(30°)·320/400
    (60.0, '<string name="fov_axis" value="diagonal"/>', 2 * math.degrees(math.atan(math.tan(math.radians(30)) * 0.8))),
])
def test_the_xml_cameras_field_of_view_is_kept(tmp_path, fov, axis, expected_x):
    """Unset lens.focal_length_mm: the focal length is derived so our thin lens, focused where
    the file says, has the XML camera's horizontal field of view on our sensor."""
    from spectral_cam.optics import ThinLens

    config = _scene(tmp_path, fov=fov, axis=axis)
    assert xml_field_of_view(config.scene.mitsuba_xml).fov_x_deg == pytest.approx(expected_x, rel=1e-9)
    assert ThinLens.from_config(config.lens, config.sensor).fov_x_deg == pytest.approx(expected_x, rel=1e-9)


def test_a_focal_length_that_replaces_the_xml_field_of_view_warns_and_is_recorded(tmp_path):
    from spectral_cam import render

    config = _scene(tmp_path, lens={"focal_length_mm": 25.0})
    with pytest.warns(SceneWarning, match="replacing the XML camera's 60° field of view") as caught:
        image = render(config, with_depth=False)
    assert len([w for w in caught if issubclass(w.category, SceneWarning)]) == 1  # said once
    record = image.meta["model_decisions"]["field_of_view"]
    assert record["choice"] == "replaced" and record["xml_fov_x_deg"] == pytest.approx(60.0)
    kept = render(_scene(tmp_path), with_depth=False).meta["model_decisions"]["field_of_view"]
    assert kept["choice"] == "kept" and kept["fov_x_deg"] == pytest.approx(60.0)


def test_a_35mm_equivalent_focal_length_sets_the_diagonal_field_of_view(tmp_path):
    """Mitsuba's focal_length is 35 mm-film equivalent: the diagonal of 36 × 24 mm."""
    path = tmp_path / "f.xml"
    path.write_text('<scene version="3.0.0"><sensor type="thinlens"><string name="focal_length" value="28mm"/>'
                    '<film type="hdrfilm"><integer name="width" value="300"/><integer name="height" value="200"/>'
                    '</film></sensor></scene>')
    diagonal_half_tan = math.hypot(36, 24) / 2 / 28
    expected = 2 * math.degrees(math.atan(diagonal_half_tan * 300 / math.hypot(300, 200)))
    assert xml_field_of_view(path).fov_x_deg == pytest.approx(expected, rel=1e-12)


def test_the_cli_says_a_scene_warning_in_one_line(tmp_path, capsys):
    from spectral_cam.cli import main

    config = _scene(tmp_path)
    scene = tmp_path / "scene.toml"
    scene.write_text(f'[scene]\nmitsuba_xml = "{config.scene.mitsuba_xml}"\n[illuminant]\nspd = "D65"\n'
                     "[sensor]\nwidth_px = 32\nheight_px = 24\n[render]\nspp = 4\n")
    assert main(["render", str(scene), "-o", str(tmp_path / "out"), "-q"]) == 0
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if "warning" in line]
    assert len(lines) == 1 and lines[0].startswith("spectral-cam: warning: illuminant.spd = 'D65' does not light")


SHAPES = ('<shape type="rectangle"><bsdf type="diffuse"/></shape>'
          '<emitter type="constant"><rgb name="radiance" value="1"/></emitter>')


def test_an_xml_camera_is_read_through_includes_and_refused_or_explained(tmp_path):
    """Issue 25 #4: a camera with fov = nan, an orthographic camera, or one in an <include>
    rendered through the default 8 mm lens (≈ 2° instead of 40°) without a word."""
    import pytest

    from spectral_cam import scene_from_dict
    from spectral_cam.errors import ConfigError, SceneWarning
    from spectral_cam.optics import ThinLens

    sensor = '<sensor type="perspective"><float name="fov" value="40"/></sensor>'
    (tmp_path / "camera.xml").write_text(f'<scene version="3.0.0">{sensor}</scene>')
    (tmp_path / "main.xml").write_text(f'<scene version="3.0.0"><include filename="camera.xml"/>{SHAPES}</scene>')
    config = scene_from_dict({"scene": {"mitsuba_xml": str(tmp_path / "main.xml")},
                              "sensor": {"width_px": 64, "height_px": 48}})
    assert ThinLens.from_config(config.lens, config.sensor).fov_x_deg == pytest.approx(40.0, rel=1e-6)

    (tmp_path / "nan.xml").write_text('<scene version="3.0.0"><sensor type="perspective">'
                                      f'<float name="fov" value="nan"/></sensor>{SHAPES}</scene>')
    with pytest.raises(ConfigError, match=r"nan.xml: the camera's field of view .* is not one: give fov in \(0, 180\)"):
        scene_from_dict({"scene": {"mitsuba_xml": str(tmp_path / "nan.xml")}})

    (tmp_path / "ortho.xml").write_text(f'<scene version="3.0.0"><sensor type="orthographic"/>{SHAPES}</scene>')
    with pytest.warns(SceneWarning, match=r"the camera is 'orthographic', which has no field of view"):
        scene_from_dict({"scene": {"mitsuba_xml": str(tmp_path / "ortho.xml")}})


@pytest.mark.parametrize("strength", ["nan", "inf"])
def test_an_emitter_of_no_finite_strength_is_named(tmp_path, strength):
    """Issue 25 #14: two emitters with ids, one of NaN (or infinite) strength, reported "give each an id"."""
    from spectral_cam import render, scene_from_dict
    from spectral_cam.errors import ConfigError

    xml = ('<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/></sensor>'
           '<shape type="rectangle"><transform name="to_world"><translate value="0, 0, 3"/></transform>'
           '<bsdf type="diffuse"/></shape>'
           '<emitter type="point" id="lamp"><point name="position" value="0, 1, 1"/>'
           f'<spectrum name="intensity" value="{strength}"/></emitter>'
           '<emitter type="constant" id="sky"><spectrum name="radiance" value="0.1"/></emitter></scene>')
    (tmp_path / "two.xml").write_text(xml)
    config = scene_from_dict({"scene": {"mitsuba_xml": str(tmp_path / "two.xml")},
                              "sensor": {"width_px": 32, "height_px": 24}, "render": {"spp": 4}})
    with pytest.raises(ConfigError, match=r"emitter 'lamp' sends the camera a light that is not finite"):
        render(config)


def test_a_result_folder_keeps_the_light_it_was_rendered_with(tmp_path, monkeypatch):
    """Issue 25 #2: an emitter's tabulated spectrum was referenced in the user's cache folder; the
    result folder now holds a copy, named relatively, and loads again with the cache gone."""
    import shutil

    from spectral_cam import load_scene, scene_from_dict
    from spectral_cam.job import run_render_job

    monkeypatch.setenv("SPECTRAL_CAM_CACHE_DIR", str(tmp_path / "cache"))
    xml = ('<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/></sensor>'
           '<shape type="rectangle"><transform name="to_world"><rotate y="1" angle="180"/>'
           '<translate value="0, 0, 3"/></transform><bsdf type="diffuse"/></shape>'
           '<shape type="sphere"><point name="center" value="0, 1, 1"/><float name="radius" value="0.2"/>'
           '<emitter type="area"><spectrum name="radiance" value="400:1, 500:3, 600:2, 700:1"/></emitter>'
           '</shape></scene>')
    (tmp_path / "lit.xml").write_text(xml)
    config = scene_from_dict({"scene": {"mitsuba_xml": str(tmp_path / "lit.xml")},
                              "sensor": {"width_px": 32, "height_px": 24},
                              "render": {"spp": 4, "spectral_output": False}})
    run_render_job(config, tmp_path / "out")
    text = (tmp_path / "out" / "scene.toml").read_text()
    copies = list((tmp_path / "out").glob("light_*.csv"))
    assert len(copies) == 1 and f'spd = "{copies[0].name}"' in text
    shutil.rmtree(tmp_path / "cache")
    shutil.move(tmp_path / "out", tmp_path / "moved")
    moved = load_scene(tmp_path / "moved" / "scene.toml")
    assert moved.illuminant.spd.endswith(copies[0].name)


def _cct_of_csv(path) -> float:
    """CCT (K) of a resolved light's CSV by colour-science (Robertson 1968 on CIE 1960 uv)."""
    import colour

    table = np.loadtxt(path, delimiter=",", skiprows=1)
    sd = colour.SpectralDistribution(dict(zip(table[:, 0], table[:, 1])))
    xy = colour.XYZ_to_xy(colour.sd_to_XYZ(sd.align(colour.SpectralShape(360, 830, 5))))
    return float(colour.temperature.uv_to_CCT_Robertson1968(colour.xy_to_UCS_uv(xy))[0])


@pytest.mark.timeout(600)
def test_the_light_of_a_sky_lit_scene_does_not_jump_with_its_layout():
    """Issue 37 #6: the light was read where the centre ray hit; in a leaf's shadow the frame was
    balanced for skylight (vegetation at 10 h: 17 740 K at layout_seed 1, 5 528 K at seed 3, a
    13 355 K spread over seeds 0–9). Averaged over the surfaces the frame sees, the same scene
    at the same hour over 10 layouts spreads by at most 300 K (measured: 34 K), near the
    sun and sky's ~5 900 K."""
    import spectral_cam as sc

    base = sc.load_scene(ROOT / "scenes" / "vegetation.toml")
    ccts = []
    for seed in range(10):
        resolved, record = resolve_light(base.replace(**{"scene.layout_seed": seed}))
        assert "averaged" in record["method"]
        ccts.append(_cct_of_csv(resolved.illuminant.spd))
    assert max(ccts) - min(ccts) <= 300.0, ccts
    assert 5000 < np.mean(ccts) < 7000


@pytest.mark.timeout(600)
def test_the_recorded_neutral_is_what_a_grey_card_in_the_scene_receives():
    """Issue 37 #6: the DNG's AsShotNeutral within 2 % of the light that reaches the grey patches
    of a ColorChecker standing in the sunlit tabletop, measured from the rendered radiance (patch
    radiance / its BabelColor reflectance, through the camera's curves). The ground is the grey
    checker, so no coloured bounce (a brown soil's warms a card leaning over it by 1.5–2 % in R/G,
    light the illuminant leaves out on purpose). Measured: within 0.8 %."""
    import scipy.ndimage as ndimage

    import spectral_cam as sc
    from spectral_cam import spectra
    from spectral_cam.job import simulate
    from spectral_cam.render import render_shape_map
    from spectral_cam.sensor.colour_calibration import camera_responses
    from spectral_cam.spectrum import Spectrum

    config = sc.load_scene(ROOT / "scenes" / "tabletop.toml", overrides={
        "scene.chart": True, "scene.ground": "checker", "scene.scatter": [], "sensor.width_px": 240, "sensor.height_px": 160,
        "sensor.pixel_pitch_um": 12.0, "render.spp": 64, "render.spectral_output": True})
    sim = simulate(config)
    radiance = sim.radiance.framed()
    index, names = render_shape_map(config)
    patches = spectra.colorchecker_reflectances()
    cards = []
    for k in (18, 19, 20, 21):  # white 9.5, neutral 8, 6.5, 5
        inside = ndimage.binary_erosion(index == names.index(f"chart_patch_{k:02d}"))
        assert inside.sum() > 30
        reflectance = spectra.sample(list(patches.values())[k], radiance.wavelengths_nm)
        irradiance = radiance.data[inside].mean(axis=0) / reflectance / radiance.band_widths_nm
        card = camera_responses(config.sensor.model, Spectrum(radiance.wavelengths_nm, irradiance), [1.0])[0]
        cards.append(card / card[1])
    neutral = np.asarray(sim.raw.as_shot_neutral, float)
    np.testing.assert_allclose(neutral / neutral[1], np.mean(cards, axis=0), rtol=0.02)
