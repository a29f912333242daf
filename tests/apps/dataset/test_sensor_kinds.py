"""Issue 30 #3: a dataset draws its sensor kind like any other key: items of a CMOS, a QIS and an event
sensor side by side, each with its own files (photon_counts.npz only for the QIS, events.npz only for the
event sensor) and every other label (a RAW, an image and depth for all)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from spectral_cam.apps.dataset import generate_dataset, spec_from_dict

pytestmark = pytest.mark.timeout(300)

SPEC = {
    "dataset": {"seed": 5, "outputs": ["raw", "image", "depth", "camera", "photon_counts", "events"]},
    "scene": {"preset": "slanted_edge"},
    "sensor": {"width_px": 32, "height_px": 24, "kind": {"choice": ["cmos", "qis", "event"]}, "jot_frames": 32,
               "event_frames": 4},
    "exposure": {"time_s": 0.004},
    "motion": {"camera_velocity_mps": [0.5, 0.0, 0.0]},
    "render": {"spp": 8, "bands": "camera", "diffraction": "off"},
}


def test_a_dataset_draws_the_sensor_kind_and_writes_each_kinds_files(tmp_path):
    out = tmp_path / "data"
    generate_dataset(spec_from_dict(SPEC), out, n=9, scheduler="inline", progress=False)
    kinds = {}
    for item in sorted((out / "items").iterdir()):
        meta = json.loads((item / "meta.json").read_text())
        kind = meta["config"]["sensor"]["kind"]
        kinds.setdefault(kind, []).append(item)
        names = {p.name for p in item.iterdir()}
        assert {"raw.dng", "image.png", "depth.exr", "camera.json"} <= names
        assert ("photon_counts.npz" in names) == (kind == "qis")
        assert ("events.npz" in names) == (kind == "event")
    assert set(kinds) == {"cmos", "qis", "event"}
    with np.load(kinds["qis"][0] / "photon_counts.npz") as npz:
        assert json.loads(str(npz["meta"]))["frames"] == 32
