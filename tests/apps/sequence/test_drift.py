"""Issue 17 #4: the drift study's measurements — plants found from the depth label, the noon
frame flagging 5 % by construction, locked settings held, the command writing its charts."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

pytestmark = pytest.mark.timeout(300)

SPEC = """
[scene]
preset = "vegetation"
object_count = 6
object_size = [0.2, 0.3]
dry_fraction = 0.0
distance_m = 3.0
view_pitch_deg = -40.0
[lens]
focal_length_mm = 8.0
f_number = 4.0
focus_distance_m = 3.0
[sensor]
width_px = 64
height_px = 48
[render]
spp = 4
[sequence]
frames = 3
start_hour = 9.0
end_hour = 17.0
[sequence.vary]
"sky.hour" = "hour"
"""


def test_the_drift_command_measures_auto_and_locked_frames(tmp_path):
    spec = tmp_path / "drift.toml"
    spec.write_text(SPEC)
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "spectral_cam.cli", "sequence", str(spec), "-o", str(out),
                           "--modes", "auto,locked", "--drift", "--scheduler", "inline", "-q"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    for name in ("drift.csv", "drift.png", "drift_strip.png", "drift_summary.json", "auto/frames.csv",
                 "locked/0002/raw.dng", "auto/0001/image.png", "auto/0001/depth.exr", "locked/0000/defocus.exr"):
        assert (out / name).is_file(), name
    from spectral_cam.apps.sequence.drift import drift_metrics

    result = drift_metrics(out, ["auto", "locked"])
    for mode, rows in result.items():
        assert rows[1]["flagged_percent"] == pytest.approx(5.0, abs=1.5)  # the noon (middle) frame: 5 % by construction
        assert rows[1]["delta_e_vs_noon"] == pytest.approx(0.0, abs=1e-9)
    locked = result["locked"]
    assert len({r["exposure_s"] for r in locked}) == 1 and len({r["white_b"] for r in locked}) == 1
    summary = json.loads((out / "drift_summary.json").read_text())
    assert set(summary) == {"auto", "locked"} and summary["auto"]["flagged_percent_max"] >= 5.0 - 1.5
    # the health study (PROSPECT-D plants): a classifier fitted on one frame, scored against the labels
    assert 0.0 <= summary["auto"]["health_accuracy_percent_min"] <= summary["auto"]["health_accuracy_percent_max"] <= 100


def test_plants_are_the_pixels_in_front_of_the_ground(make_scene):
    """The plant mask is empty for a field without plants and holds the plants' pixels with them."""
    import numpy as np

    from spectral_cam import render
    from spectral_cam.apps.sequence.drift import plant_mask

    bare = make_scene(scene={"preset": "vegetation", "object_count": 0, "distance_m": 3.0, "view_pitch_deg": -40.0},
                      sensor={"width_px": 48, "height_px": 32}, lens={"model": "pinhole"}, render={"spp": 1})
    assert not plant_mask(bare, render(bare).depth_m).any()
    planted = bare.replace(**{"scene.object_count": 6, "scene.object_size": [0.2, 0.3]})
    mask = plant_mask(planted, render(planted).depth_m)
    assert 0.02 < mask.mean() < 0.8 and np.isfinite(render(planted).depth_m[mask]).all()


def test_the_health_threshold_is_the_best_split_of_the_labelled_plants():
    """On labelled values the fitted ExG threshold separates separable classes perfectly, and
    on overlapping ones reaches the balanced accuracy of the best split found by brute force."""
    import numpy as np

    from spectral_cam.apps.sequence.drift import _classify, fit_threshold

    rng = np.random.default_rng(0)
    healthy, sick = rng.normal(0.4, 0.02, 40), rng.normal(0.2, 0.02, 20)
    exg = np.concatenate([healthy, sick, [np.nan]])
    unhealthy = np.concatenate([np.zeros(40, bool), np.ones(20, bool), [True]])
    t = fit_threshold(exg, unhealthy)
    assert _classify(exg, unhealthy, t) == (pytest.approx(100 * 20 / 60), pytest.approx(100.0))
    sick = rng.normal(0.35, 0.05, 20)
    exg = np.concatenate([healthy, sick])
    unhealthy = np.concatenate([np.zeros(40, bool), np.ones(20, bool)])
    t = fit_threshold(exg, unhealthy)

    def balanced(threshold):
        flagged = exg <= threshold
        return 0.5 * flagged[unhealthy].mean() + 0.5 * (~flagged[~unhealthy]).mean()

    assert balanced(t) == pytest.approx(max(balanced(v) for v in exg))
