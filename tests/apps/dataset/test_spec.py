"""Dataset specs: draws, sweeps, item plans and the errors of a bad spec."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from spectral_cam.apps.dataset import parse_sweep, spec_from_dict
from spectral_cam.errors import ConfigError

pytestmark = pytest.mark.timeout(60)


def test_spec_draws_sweeps_and_errors(tmp_path):
    spec = spec_from_dict({
        "dataset": {"seed": 3, "n": 50},
        "sensor": {"width_px": {"uniform": [20, 40]}, "height_px": 16},
        "scene": {"preset": "dof_targets", "depths_m": {"uniform": [[0.5, 1.0, 2.0], [1.0, 3.0, 8.0]]}},
        "lens": {"f_number": {"log_uniform": [1.4, 16.0]}},
    })
    plans = [spec.plan_item(i) for i in range(50)]
    assert all(p.error is None for p in plans)
    widths = [p.params["sensor.width_px"] for p in plans]
    assert all(isinstance(w, int) and 20 <= w <= 40 for w in widths) and len(set(widths)) > 5
    depths = np.array([p.params["scene.depths_m"] for p in plans])
    assert np.all(depths >= [0.5, 1.0, 2.0]) and np.all(depths <= [1.0, 3.0, 8.0])
    logs = np.log([p.params["lens.f_number"] for p in plans])
    assert np.log(1.4) <= logs.min() and logs.max() <= np.log(16.0)
    # an item's draw does not depend on how many items there are, nor on the outputs
    more = spec_from_dict({**{"dataset": {"seed": 3, "outputs": ["raw"]}},
                           "sensor": {"width_px": {"uniform": [20, 40]}, "height_px": 16},
                           "scene": {"preset": "dof_targets",
                                     "depths_m": {"uniform": [[0.5, 1.0, 2.0], [1.0, 3.0, 8.0]]}},
                           "lens": {"f_number": {"log_uniform": [1.4, 16.0]}}})
    assert more.hash == spec.hash and more.plan_item(7).params == plans[7].params
    assert spec_from_dict({"dataset": {"seed": 4}}).hash != spec_from_dict({"dataset": {"seed": 3}}).hash

    sweep = parse_sweep("lens.f_number=1.4:5.6:3:log")
    assert sweep.values == pytest.approx((1.4, 2.8, 5.6))
    assert parse_sweep("lens.focus_distance_m=0.5:5:10").values[-1] == 5.0
    assert parse_sweep("sensor.width_px=[32, 48]").values == (32, 48)
    grid = spec_from_dict({}, sweeps=["lens.f_number=[2.0, 4.0]", "lens.focus_distance_m=1:3:3"])
    assert grid.item_count(2) == 12
    assert [grid.plan_item(i, 2).params for i in (0, 1, 2, 11)] == [
        {"lens.f_number": 2.0, "lens.focus_distance_m": 1.0}, {"lens.f_number": 2.0, "lens.focus_distance_m": 1.0},
        {"lens.f_number": 2.0, "lens.focus_distance_m": 2.0}, {"lens.f_number": 4.0, "lens.focus_distance_m": 3.0}]

    bad = [
        ({"lens": {"f_numbr": 2.0}}, "unknown key 'lens.f_numbr'"),
        ({"lens": {"f_number": {"gaussian": [1, 2]}}}, "exactly one of uniform, log_uniform, choice"),
        ({"lens": {"f_number": {"log_uniform": [0, 2]}}}, "must be > 0"),
        ({"lens": {"f_number": {"uniform": [4, 2]}}}, "low <= high"),
        ({"sensor": {"model": {"choice": ["a", "b"], "weights": [1]}}}, "weights must be 2 numbers"),
        ({"dataset": {"outputs": ["raw", "jpeg"]}}, "unknown output 'jpeg'"),
        ({"dataset": {"sede": 1}}, "valid keys of \\[dataset\\]"),
        ({"render": {"spectral_output": True}}, "add or remove 'radiance'"),
    ]
    for data, message in bad:
        with pytest.raises(ConfigError, match=message):
            spec_from_dict(data)
    for text, message in [("lens.f_number=1:2", "start:stop:count"), ("lens.f_number=0:2:3:log", "start, stop > 0"),
                          ("lens.f_number", "section.key=start:stop:count")]:
        with pytest.raises(ConfigError, match=message):
            parse_sweep(text)
    with pytest.raises(ConfigError, match="both swept and drawn"):
        spec_from_dict({"lens": {"f_number": {"uniform": [2, 4]}}}, sweeps=["lens.f_number=[2.0]"])
    with pytest.raises(ConfigError, match="-n N"):
        spec_from_dict({}).item_count()


def test_whole_number_bounds_beyond_float_precision_are_refused():
    with pytest.raises(ConfigError, match="below 2\\*\\*53"):
        spec_from_dict({"sensor": {"width_px": {"uniform": [1e30, 2e30]}}})


def test_the_same_spec_and_scene_file_give_the_same_items_in_any_folder(tmp_path):
    """An XML scene counts by its content, not its path: the spec and scene copied to another folder
    keep the spec hash (so every item's seed; the absolute path once made them differ between a
    checkout and a fresh clone); an edited scene changes it."""
    import shutil

    from spectral_cam.apps.dataset import load_spec

    plans = Path(__file__).resolve().parents[3] / "plans"
    copies = []
    for name in ("a", "b"):
        folder = tmp_path / name / "plans"
        folder.mkdir(parents=True)
        shutil.copy(plans / "mixed_light_room.toml", folder)
        (tmp_path / name / "scenes").mkdir()
        shutil.copy(plans.parent / "scenes" / "mixed_light_room.xml", tmp_path / name / "scenes")
        copies.append(load_spec(folder / "mixed_light_room.toml"))
    assert copies[0].hash == copies[1].hash and copies[0].item_seed(3) == copies[1].item_seed(3)
    scene = tmp_path / "b" / "scenes" / "mixed_light_room.xml"
    scene.write_text(scene.read_text().replace('value="2856"', 'value="3000"'))
    assert load_spec(tmp_path / "b" / "plans" / "mixed_light_room.toml").hash != copies[0].hash


def test_whole_number_uniform_draws_every_value_including_both_ends_equally_often():
    """Issue 39 #13: ``uniform = [4, 10]`` on a whole-number key gave 4 and 10 half as often as
    5 … 9 (a rounded continuous draw). Against the discrete uniform distribution on 4 … 10
    (SciPy's chi-square goodness of fit, 7000 draws: expected 1000 each)."""
    from scipy import stats

    spec = spec_from_dict({"sensor": {"width_px": {"uniform": [4, 10]},
                                      "height_px": {"log_uniform": [2, 16]}}})
    rng = np.random.default_rng(39)
    width, height = spec.distributions["sensor.width_px"], spec.distributions["sensor.height_px"]
    draws = [width.sample(rng) for _ in range(7000)]
    assert all(isinstance(d, int) for d in draws)
    counts = np.bincount(draws, minlength=11)[4:]
    assert counts.sum() == 7000 and counts.min() > 0
    assert stats.chisquare(counts).pvalue > 1e-3, counts  # rounding gave ~500 at each end: p ~ 1e-80
    # log-uniform over whole numbers: each k with its rounding cell's log-width ln((k + ½)/(k − ½))
    k = np.arange(2, 17)
    expected = np.log((k + 0.5) / (k - 0.5))
    counts = np.bincount([height.sample(rng) for _ in range(7000)], minlength=17)[2:]
    assert stats.chisquare(counts, 7000 * expected / expected.sum()).pvalue > 1e-3, counts
    # bounds holding no whole number are refused at load
    with pytest.raises(ConfigError, match="holds none"):
        spec_from_dict({"sensor": {"width_px": {"uniform": [4.2, 4.8]}}})


def test_every_choice_and_bound_is_checked_by_the_scene_at_load():
    """Issue 39 #14: ``light = {choice = ["sun", "overcast"]}`` loaded, and the dry run said
    "1 invalid" without the item or the reason. Each value now goes through the scene's own
    checks at load: the error names the key, the value, which entry it is and the scene's reason
    (the list of valid lights, as ``scene_from_dict`` gives it for that value alone)."""
    from spectral_cam.scene import scene_from_dict

    with pytest.raises(ConfigError) as direct:
        scene_from_dict({"scene": {"preset": "tabletop", "light": "sun"}})
    with pytest.raises(ConfigError) as caught:
        spec_from_dict({"scene": {"preset": "tabletop", "light": {"choice": ["sun", "overcast"]}}})
    message = str(caught.value)
    assert message.startswith("scene.light: choice value 1 of 2, \"sun\"") and str(direct.value) in message
    for data, expect in (
            ({"sensor": {"model": {"choice": ["nikon_d850", "nikon_d851"]}}}, "choice value 2 of 2, \"nikon_d851\""),
            ({"exposure": {"iso": {"choice": [100, "x"]}}}, "exposure.iso: choice value 2 of 2, \"x\""),
            ({"lens": {"f_number": {"uniform": [0.1, 2.0]}}}, "lens.f_number: uniform low bound 0.1"),
            ({"lens": {"f_number": 2.0}}, None)):
        if expect is None:
            spec_from_dict(data, sweeps=["lens.focus_distance_m=[1.0, 2.0]"])
            with pytest.raises(ConfigError, match="sweep value 2 of 2, -1.0"):
                spec_from_dict(data, sweeps=["lens.focus_distance_m=[1.0, -1.0]"])
            continue
        with pytest.raises(ConfigError, match=expect):
            spec_from_dict(data)
    # a value impossible only beside some draws of another key is the items' to report, not the spec's
    spec = spec_from_dict({"lens": {"focal_length_mm": {"choice": [25.0, 100.0]},
                                    "focus_distance_m": {"uniform": [0.05, 0.2]}}})
    errors = [spec.plan_item(i).error for i in range(8)]
    assert any(e and "focuses only beyond its focal length" in e for e in errors) and errors.count(None) >= 1


@pytest.mark.timeout(300)
def test_the_dry_run_names_each_invalid_item_and_its_reason():
    from spectral_cam.apps.dataset import plan_dataset

    spec = spec_from_dict({"sensor": {"width_px": 24, "height_px": 16}, "render": {"spp": 2},
                           "lens": {"focal_length_mm": {"choice": [25.0, 100.0], "weights": [1, 3]},
                                    "focus_distance_m": {"uniform": [0.05, 0.15]}}})
    plans = [spec.plan_item(i) for i in range(40)]
    third_valid = [p.index for p in plans if not p.error][2]  # the dry run plans up to the third valid item
    invalid = [p for p in plans[:third_valid] if p.error]
    text = plan_dataset(spec, n=40, scheduler="inline")
    assert invalid and f"invalid item {invalid[0].id}: ConfigError: lens.focus_distance_m = " in text
    assert "focuses only beyond its focal length" in text
