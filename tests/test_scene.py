"""Scene files, overrides and validation: bad input gets a message that says what is valid."""

from __future__ import annotations

import json

import pytest

from spectral_cam import ConfigError, load_scene, scene_from_dict
from spectral_cam.spectra import camera_names, illuminant_names, parse_bands


def test_defaults_and_round_trip_through_dict(tmp_path):
    config = scene_from_dict({"lens": {"f_number": 2}})
    assert config.lens.f_number == 2.0 and isinstance(config.lens.f_number, float)
    again = scene_from_dict(json.loads(json.dumps(config.to_dict())))
    assert again == config


def test_toml_file_with_overrides(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[scene]\npreset = "flat_field"\nreflectance = "dark skin"\n[lens]\nf_number = 4\n')
    config = load_scene(path, overrides=["lens.f_number=2.8", "sensor.model=canon_eos_5d_mkiv",
                                         "scene.depths_m=[1, 2, 3]"])
    assert config.lens.f_number == 2.8
    assert config.sensor.model == "canon_eos_5d_mkiv"
    assert config.scene.depths_m == (1.0, 2.0, 3.0)
    assert config.scene.reflectance == "dark skin"


def test_bundled_scenes_load():
    from pathlib import Path

    for path in sorted((Path(__file__).parent.parent / "scenes").glob("*.toml")):
        load_scene(path)


def test_bands_are_centres():
    bands = parse_bands("400:700:10")
    assert len(bands) == 31
    assert bands.centres_nm[0] == 400 and bands.edges_nm[0] == 395 and bands.edges_nm[-1] == 705


@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"illuminant.spd": "D66"}, "unknown illuminant 'D66'; valid:"),
        ({"sensor.model": "nikon_d9000"}, "unknown camera 'nikon_d9000'; valid:"),
        ({"lens.focus_distance_m": 0.04, "lens.focal_length_mm": 50}, "focuses only beyond its focal length"),
        ({"lens.focus_distance_m": 0.05, "lens.focal_length_mm": 50}, "focuses only beyond its focal length"),
        ({"lens.f_number": 0}, "lens.f_number = 0.0: must be a number in [0.5, 1000]"),
        ({"lens.f_number": -2}, "lens.f_number = -2.0: must be a number in [0.5, 1000]"),
        ({"sensor.width_px": 0}, "sensor.width_px = 0: must be a whole number of pixels"),
        ({"sensor.height_px": -5}, "sensor.height_px = -5: must be a whole number of pixels"),
        ({"sensor.pixel_pitch_um": 0}, "sensor.pixel_pitch_um = 0.0: must be a number in [0.1, 1000] µm"),
        ({"sensor.width_px": 1}, "Bayer sensor needs at least 2×2 pixels"),
        ({"sensor.width_px": 2.5}, "sensor.width_px = 2.5: has the wrong type"),
        ({"lens.model": "fisheye"}, "valid: auto, thin, pinhole"),
        ({"scene.preset": "teapot"}, "unknown preset; valid: colorchecker"),
        ({"render.bands": "700:400:10"}, "need step > 0 and stop >= start"),
        ({"render.bands": "300:700:10"}, "Mitsuba samples 360–830 nm only"),
        ({"lens.aperture": 2}, "unknown key(s) lens.aperture; valid keys of [lens]:"),
        ({"optics.f_number": 2}, "use section.key with a section among scene, illuminant"),
        ({"illuminant.illuminance_lux": -1}, "must be a number in [1e-06, 1e+07] lx"),
        ({"scene.reflectance": 1.5}, "reflectance 1.5 must lie in [0, 1]"),
    ],
)
def test_bad_values_are_refused_with_what_is_valid(overrides, message):
    with pytest.raises(ConfigError) as info:
        scene_from_dict({}, overrides=overrides)
    assert message in str(info.value)


def test_unknown_names_list_the_valid_ones():
    with pytest.raises(ConfigError) as info:
        scene_from_dict({"illuminant": {"spd": "sunlight"}})
    assert all(name in str(info.value) for name in ("D65", "A", "FL11", "blackbody:<K>"))
    with pytest.raises(ConfigError) as info:
        scene_from_dict({"sensor": {"model": "leica"}})
    assert all(name in str(info.value) for name in camera_names())
    assert len(camera_names()) == 19  # 17 measured (pbrt-v4/PhysLight) + colour-science's 2
    assert "D65" in illuminant_names()


def test_blackbody_and_csv_spectra(tmp_path):
    csv = tmp_path / "led.csv"
    csv.write_text("wavelength_nm,value\n400,0\n450,1\n500,0\n")
    scene_from_dict({"illuminant": {"spd": "blackbody:3200"}})
    config = load_scene(_scene_file(tmp_path, '[illuminant]\nspd = "led.csv"\n'))
    assert config.illuminant.spd == str(csv.resolve())
    with pytest.raises(ConfigError, match="blackbody"):
        scene_from_dict({"illuminant": {"spd": "blackbody:-5"}})
    bad = tmp_path / "bad.csv"
    bad.write_text("400,1\n450,-1\n")
    with pytest.raises(ConfigError, match="non-negative"):
        scene_from_dict({"illuminant": {"spd": str(bad)}})


def _scene_file(folder, text):
    path = folder / "scene.toml"
    path.write_text(text)
    return path


def test_corrupt_toml_is_a_clear_error(tmp_path):
    with pytest.raises(ConfigError, match="not a valid TOML scene file"):
        load_scene(_scene_file(tmp_path, "[lens\nf_number = "))
    path = tmp_path / "binary.toml"
    path.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ConfigError, match="cannot read scene file"):
        load_scene(path)
    with pytest.raises(ConfigError, match="does not exist"):
        load_scene(tmp_path / "missing.toml")


def test_ir_cut_filter_halves_at_its_cut_off_and_dims_the_red_channel():
    import numpy as np

    from spectral_cam.sensor import film_curves
    from spectral_cam.spectra import sample, transmission

    sd = transmission("ir_cut:650")
    assert sample(sd, [650.0])[0] == pytest.approx(0.5)
    assert sample(sd, [500.0])[0] > 0.99 and sample(sd, [720.0])[0] < 0.01
    wl = np.arange(400.0, 711.0)
    plain = film_curves(scene_from_dict({}), wl).sum(axis=0)
    filtered = film_curves(scene_from_dict({"sensor": {"ir_cut": "ir_cut:650"}}), wl).sum(axis=0)
    assert filtered[0] / plain[0] < filtered[2] / plain[2]  # red loses most
    with pytest.raises(ConfigError, match="ir_cut:<cut-off nm>"):
        scene_from_dict({"sensor": {"ir_cut": "hot mirror"}})


def test_review_findings_on_names_seeds_bands_and_transmissions():
    # colour-science light-source names may hold a "/" and are names, not paths
    assert scene_from_dict({"illuminant": {"spd": "F40/DX (Broadband FL)"}}).illuminant.spd == "F40/DX (Broadband FL)"
    with pytest.raises(ConfigError, match="sensor.seed"):
        scene_from_dict({"sensor": {"seed": -1}})
    with pytest.raises(ConfigError, match="whole number of steps"):
        scene_from_dict({"render": {"bands": "400:706:10"}})
    with pytest.raises(ConfigError, match="at most"):
        scene_from_dict({"render": {"bands": "400:700:0.001"}})
    with pytest.raises(ConfigError, match=r"must lie in \(0, 1\]"):
        scene_from_dict({"lens": {"transmission": 0}})
    with pytest.raises(ConfigError, match="no spectrum to write"):
        scene_from_dict({"render": {"bands": "camera"}})


def test_monochrome_sensor_never_gets_the_camera_film():
    from spectral_cam.render.decisions import decide_bands

    mono = scene_from_dict({"sensor": {"model": "ideal", "cfa": "none"}, "render": {"spectral_output": False}})
    assert decide_bands(mono, False)[0] is False


def test_resolved_scene_round_trips_through_toml(tmp_path):
    config = scene_from_dict({"scene": {"preset": "dof_targets", "depths_m": [0.5, 1, 3]},
                              "illuminant": {"spd": 'F40/DX (Broadband FL)'},
                              "render": {"spp": "auto", "seed": 7}, "sensor": {"shot_noise": False}})
    path = tmp_path / "resolved.toml"
    path.write_text(config.to_toml())
    assert load_scene(path) == config


HOSTILE_OVERRIDES = [  # issue 12 #11: each overflowed into a traceback
    "lens.f_number=1e308", "sensor.full_well_e=1e-300", "sensor.base_iso=1e-300", "exposure.iso=1e308",
    "sensor.read_noise_e=1e308", "scene.distance_m=1e308", "sensor.prnu=1e308", "sensor.dsnu_e=1e308",
    "exposure.time_s=1e38", "sensor.full_well_e=1e308", "scene.checker_px=1e-300", "scene.checker_px=1e300",
    "render.spp=1000000000000",
]


@pytest.mark.timeout(60)
@pytest.mark.parametrize("override", HOSTILE_OVERRIDES)
def test_physical_keys_outside_their_range_are_clear_errors(tmp_path, capsys, override):
    from spectral_cam.cli import main

    scene = tmp_path / "scene.toml"
    scene.write_text("[sensor]\nwidth_px = 24\nheight_px = 16\n")
    status = main(["render", str(scene), "-o", str(tmp_path / "out"), "-q", "--set", override])
    err = capsys.readouterr().err
    assert status == 2 and "Traceback" not in err
    key = override.split("=")[0]
    assert key in err and ("must be a number in [" in err or "whole number in 1.." in err), err
    assert not (tmp_path / "out").exists()


def test_every_range_is_a_real_interval():
    from spectral_cam.scene import PHYSICAL_RANGES

    for key, (low, high, _) in PHYSICAL_RANGES.items():
        assert 0 <= low < high < float("inf"), key


def test_asset_and_scatter_tables_round_trip_and_override(tmp_path):
    """[[scene.assets]] and [[scene.scatter]] (arrays of tables) are written back as inline tables
    that read back equal, through JSON too, and --set replaces them (one table or a list)."""
    from pathlib import Path

    config = load_scene(Path(__file__).parent.parent / "scenes" / "field_litter.toml")
    assert [a.name for a in config.scene.assets] == ["rock", "crate", "mushroom"]
    assert [s.kind for s in config.scene.scatter] == ["stones", "clods", "straw", "grass_blades"]
    text = config.to_toml()
    assert "assets = [{file = \"rock\"" in text and "size_m = {lognormal = [-4.2, 0.5]}" in text
    (tmp_path / "again.toml").write_text(text)
    assert load_scene(tmp_path / "again.toml") == config
    assert scene_from_dict(json.loads(json.dumps(config.to_dict()))) == config
    one = load_scene(tmp_path / "again.toml", overrides=['scene.scatter={kind = "straw", density_per_m2 = 5}'])
    assert [(s.kind, s.density_per_m2.a) for s in one.scene.scatter] == [("straw", 5.0)]
    none = config.replace(**{"scene.assets": [], "scene.scatter": []})
    assert none.scene.assets == () and none.scene.scatter == ()
    with pytest.raises(ConfigError, match="array of tables"):
        config.replace(**{"scene.assets": "rock"})


def test_an_unset_iso_is_the_named_cameras_base_iso():
    """Issue 39 #9: a scene that names a camera and leaves the ISO unset exposes at that camera's
    published base ISO (data/cameras/sensor_figures.csv: the D850's is 64), as before for the
    generic sensor (100); an ISO given is kept."""
    from spectral_cam import spectra

    d850 = scene_from_dict({"sensor": {"model": "nikon_d850"}})
    assert d850.exposure.iso == spectra.camera_figures("nikon_d850")["base_iso"].value == 64
    assert scene_from_dict({"sensor": {"model": "ideal"}}).exposure.iso == 100
    assert scene_from_dict({"sensor": {"model": "nikon_d850"}, "exposure": {"iso": 400}}).exposure.iso == 400
