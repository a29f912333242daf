"""Scene refusals say what they said before the keys were declared by their owners (issue 41 #3: "every
existing test passes unchanged"; the inputs accepted and the messages the same). Each message is the
rule as docs/design.md and the old scene.py wrote it: ``section.key = <the value as the scene file
writes it>: <rule>``, a list key's value echoed as a TOML list, not a Python tuple.

Found by a differential run of 668 scene dicts (every bundled scene with single-key and combined
overrides) through the old ``scene.py`` and the new ``scene/`` package.
"""

from pathlib import Path

import pytest

from spectral_cam import scene as sc
from spectral_cam.errors import ConfigError

XML = str(Path(__file__).resolve().parents[1] / "scenes" / "glass_sphere.xml")


def _refusal(data: dict) -> str:
    with pytest.raises(ConfigError) as caught:
        sc.scene_from_dict(data)
    return str(caught.value)


@pytest.mark.parametrize(("data", "message"), [
    ({"motion": {"camera_velocity_mps": [1, 0]}},
     "motion.camera_velocity_mps = [1.0, 0.0]: give three numbers within ±1e5"),
    ({"motion": {"object_velocity_mps": [0, 0, 2e5]}},
     "motion.object_velocity_mps = [0.0, 0.0, 200000.0]: give three numbers within ±1e5"),
    ({"scene": {"mitsuba_xml": XML, "camera_rotation_deg": [0, 0, 181]}},
     "scene.camera_rotation_deg = [0.0, 0.0, 181.0]: give three numbers within ±180"),
    ({"lens": {"distortion": [0.1, 0]}},
     "lens.distortion = [0.1, 0.0]: give Brown–Conrady [k1, k2, p1, p2, k3] (OpenCV's order), each within ±1"),
    ({"scene": {"preset": "dead_leaves", "leaf_radius_px": [120, 3]}},
     "scene.leaf_radius_px = [120.0, 3.0]: give [smallest, largest] disc radius in pixels, smallest < largest"),
])
def test_a_list_key_is_echoed_as_the_scene_file_writes_it(data, message):
    assert _refusal(data) == message


def test_a_bad_shutter_names_both_shutters_and_what_each_does():
    assert _refusal({"sensor": {"shutter": "nope"}}) == (
        "sensor.shutter = 'nope': valid: 'global' (every row at once), 'rolling' (row by row, row_time_s apart)")


def test_a_spad_key_out_of_its_range_is_refused_for_its_range_before_its_kind():
    """A dead time of 2 s is wrong for any kind: its range is said first; a valid one on a CMOS is
    refused as the SPAD's."""
    assert _refusal({"sensor": {"dead_time_s": 2.0}}) == (
        "sensor.dead_time_s = 2.0: a SPAD's dead time in 0..1 s (tens of ns are typical)")
    assert _refusal({"sensor": {"kind": "qis", "afterpulsing": 1.5}}) == (
        "sensor.afterpulsing = 1.5: a SPAD's afterpulsing probability in 0..1")
    assert _refusal({"sensor": {"dead_time_s": 1e-8}}) == (
        "sensor.dead_time_s = 1e-08: dead time and afterpulsing belong to sensor.kind = 'spad'")


def test_dof_targets_needs_three_depths_beside_an_xml_scene_too():
    message = _refusal({"scene": {"mitsuba_xml": XML, "preset": "dof_targets", "depths_m": [1.0, 2.0]}})
    assert message == "scene.depths_m = (1.0, 2.0): dof_targets needs three or more depths"


def test_a_path_length_mitsuba_cannot_hold_is_refused_when_the_scene_is_read():
    """Mitsuba's integrators take max_depth as a 32-bit int (mi.load_dict refuses 2**31 + 5: "out of
    bounds"); every other whole number >= 1 is accepted as before."""
    assert sc.scene_from_dict({"render": {"max_depth": 2 ** 31 - 1}}).render.max_depth == 2 ** 31 - 1
    assert _refusal({"render": {"max_depth": 0}}) == "render.max_depth = 0: must be a whole number >= 1"
    assert _refusal({"render": {"max_depth": 2 ** 31 + 5}}).startswith("render.max_depth = 2147483653: must be a "
                                                                      "whole number >= 1 and < 2**31")
