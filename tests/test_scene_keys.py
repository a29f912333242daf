"""Scene keys declared by their owners (issue 41 #3): a preset, a lens model and a sensor kind registered
from this test module bring their own keys — the scene file takes them with their defaults and checks,
refuses bad values with the owner's rule, lists them in the unknown-key message, ``spectral-cam keys``
and ``render --help`` — and scene.py is not touched. README's key table is the declarations'."""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest

import spectral_cam as sc
from spectral_cam.errors import ConfigError
from spectral_cam.keys import Key, declared_once, number_in
from spectral_cam.presets import PRESETS
from spectral_cam.render.lens_models import LENS_MODELS, pinhole_camera
from spectral_cam.scene import key_table, section_class
from spectral_cam.sensor.kinds import SENSOR_KINDS, SensorKind

pytestmark = pytest.mark.timeout(120)

ROOT = Path(__file__).resolve().parents[1]


def _remove(registry, name):
    registry._entries.pop(name, None)


@pytest.fixture
def toy_owners():
    """A preset, a lens model and a sensor kind, each declaring one key of its own."""
    preset_key = Key("toy_tilt_deg", 3.0, "float", "the toy preset's tilt", (number_in(0.0, 45.0, "°"),))
    PRESETS.add("toy_preset", PRESETS["flat_field"].function, options=("distance_m", "reflectance"),
                keys=(preset_key,), description="a flat field with a tilt (a test's toy)")
    LENS_MODELS.add("toy_lens", pinhole_camera, description="a pinhole with a toy key",
                    keys=(Key("toy_stop", 2, "int", "the toy's stop count", (lambda v, s: None if v > 0 else "must be > 0",)),))
    SENSOR_KINDS.add_kind(SensorKind("toy_kind", SENSOR_KINDS["cmos"].function, description="a CMOS with a toy key",
                                     keys=(Key("toy_gain", 1.5, "float", "the toy's gain", (number_in(1.0, 4.0),)),)))
    yield
    _remove(PRESETS, "toy_preset")
    _remove(LENS_MODELS, "toy_lens")
    SENSOR_KINDS.remove("toy_kind")


def test_keys_a_registered_owner_declares_are_scene_keys_with_defaults_and_checks(toy_owners):
    config = sc.scene_from_dict({"scene": {"preset": "toy_preset", "toy_tilt_deg": 10},
                                 "lens": {"model": "toy_lens"}, "sensor": {"kind": "toy_kind", "toy_gain": 2}})
    assert config.scene.toy_tilt_deg == 10.0 and isinstance(config.scene.toy_tilt_deg, float)  # int -> float
    assert config.lens.toy_stop == 2 and config.sensor.toy_gain == 2.0
    assert sc.scene_from_dict({}).sensor.toy_gain == 1.5  # every section holds every declared key
    with pytest.raises(ConfigError, match=r"scene\.toy_tilt_deg = 60\.0: must be a number in \[0, 45\] °"):
        sc.scene_from_dict({"scene": {"preset": "toy_preset", "toy_tilt_deg": 60}})
    with pytest.raises(ConfigError, match=r"lens\.toy_stop = 0: must be > 0"):
        sc.scene_from_dict({"lens": {"model": "toy_lens", "toy_stop": 0}})
    with pytest.raises(ConfigError, match=r"sensor\.toy_gain = 'x': has the wrong type; expected float"):
        sc.scene_from_dict({"sensor": {"toy_gain": "x"}})
    # a copy, a TOML round trip and a pickle (a Dask worker) keep the keys
    assert sc.scene_from_dict({}, overrides={"sensor.toy_gain": 3.0}).replace(**{"lens.toy_stop": 5}).lens.toy_stop == 5
    assert pickle.loads(pickle.dumps(config)) == config


def test_the_listings_name_a_registered_owner_and_its_keys(toy_owners):
    listing = key_table.text_listing(("scene", "lens", "sensor"))
    assert "scene preset toy_preset:\n    toy_tilt_deg = 3    # the toy preset's tilt" in listing
    assert "lens model toy_lens:\n    toy_stop = 2" in listing and "sensor kind toy_kind:\n    toy_gain = 1.5" in listing
    assert "toy_gain" in key_table.help_epilog()
    with pytest.raises(ConfigError, match=r"unknown key\(s\) sensor\.gain; valid keys of \[sensor\]: .*toy_gain"):
        sc.scene_from_dict({"sensor": {"gain": 2}})


def test_a_removed_owner_takes_its_keys_with_it(toy_owners):
    assert "toy_gain" in {f for f in section_class("sensor").__dataclass_fields__}
    SENSOR_KINDS.remove("toy_kind")
    assert "toy_gain" not in section_class("sensor").__dataclass_fields__
    with pytest.raises(ConfigError, match=r"unknown key\(s\) sensor\.toy_gain"):
        sc.scene_from_dict({"sensor": {"toy_gain": 2.0}})


def test_a_key_declared_twice_differently_is_refused():
    one, other = Key("gain", 1.0, "float", "a"), Key("gain", 2.0, "float", "b")
    assert [owner for owner, _ in declared_once([("a", (one,)), ("b", (one,))])] == ["a"]  # one reads the other's
    with pytest.raises(ValueError, match="declared by a and again, differently, by b"):
        declared_once([("a", (one,)), ("b", (other,))])


def test_every_bundled_key_default_passes_its_own_checks_and_is_documented():
    for section in ("scene", "illuminant", "sky", "lens", "sensor", "exposure", "motion", "render"):
        for name, default, doc, owner in key_table.key_rows(section):
            assert doc and owner, f"{section}.{name} needs a doc line"
    sc.scene_from_dict({})  # the defaults build every section


def test_readme_key_table_is_the_declarations():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert key_table.markdown_block() in readme, (
        "README's key table differs from the declarations: python -m spectral_cam.scene.key_table README.md")


def test_spectral_cam_keys_lists_a_section_and_refuses_an_unknown_one(capsys):
    from spectral_cam.cli import main

    assert main(["keys", "sensor"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("[sensor]") and "sensor kind qis:\n    jot_frames = 256" in out and "[lens]" not in out
    assert main(["keys", "lenses"]) == 2
    assert "unknown section(s) lenses; valid: scene, illuminant" in capsys.readouterr().err


def test_a_sensor_kinds_keys_are_its_options_and_its_checks_run_when_it_is_chosen():
    """add_kind lists a kind's declared keys among its options (as Registry.add does), and the kind's
    own combination checks run for a sensor of that kind only."""
    def gain_below_full_well(sensor):
        if sensor.toy_gain * 1000 > sensor.full_well_e:
            return "sensor.toy_gain", sensor.toy_gain, "the toy's gain times 1000 e⁻ must fit the full well"
        return None

    SENSOR_KINDS.add_kind(SensorKind("toy_checked", SENSOR_KINDS["cmos"].function, description="a toy",
                                     keys=(Key("toy_gain", 1.5, "float", "the toy's gain"),),
                                     checks=(gain_below_full_well,)))
    try:
        assert "toy_gain" in SENSOR_KINDS["toy_checked"].options
        with pytest.raises(ConfigError, match="must fit the full well"):
            sc.scene_from_dict({"sensor": {"kind": "toy_checked", "toy_gain": 30.0}})
        assert sc.scene_from_dict({"sensor": {"kind": "cmos", "toy_gain": 30.0}}).sensor.toy_gain == 30.0
    finally:
        SENSOR_KINDS.remove("toy_checked")
