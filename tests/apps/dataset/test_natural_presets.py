"""Issue 15 acceptance: a dataset spec mixing the natural-content presets (dead_leaves, tabletop,
vegetation) with their parameters drawn per item (sun time, object count, layout, materials)
runs on the local cluster, writes every label, and resumes."""

from __future__ import annotations

import json

import numpy as np
import pytest

from spectral_cam.apps.dataset import DEFAULT_OUTPUTS, SyntheticDataset, generate_dataset, load_spec

from .reading import read_manifest

pytestmark = pytest.mark.timeout(300)

SPEC = """
[dataset]
seed = 11
outputs = ["raw", "image", "depth", "camera", "illuminant", "illuminant_map", "defocus", "all_in_focus", "clean_rgb",
           "segmentation", "coverage", "flow", "albedo", "health"]

[scene]
preset = { choice = ["dead_leaves", "tabletop", "vegetation"] }
object_count = { uniform = [2, 5] }
layout_seed = { uniform = [0, 1000] }
object_materials = { choice = [["diffuse", "plastic"], ["conductor", "glass"]] }
depths_m = [1.0, 4.0]
leaf_radius_px = [2.0, 12.0]
ground = "flat"  # the labels are the point here; the textured ground's fields and blend tree cost each item seconds

[sky]
hour = { uniform = [9.0, 17.0] }

[sensor]
width_px = 32
height_px = 24

[render]
spp = 4
max_depth = 3
"""


def test_a_dataset_mixing_the_natural_presets_writes_every_label_and_resumes(cluster, tmp_path):
    path = tmp_path / "spec.toml"
    path.write_text(SPEC)
    spec = load_spec(path)
    out = tmp_path / "out"
    summary = generate_dataset(spec, out, n=4, executor=cluster.executor, progress=False)
    assert (summary.rendered, summary.failed) == (4, 0)
    presets, hours = set(), []
    for row in read_manifest(out):
        folder = out / row["path"]
        meta = json.loads((folder / "meta.json").read_text())
        preset = meta["config"]["scene"]["preset"]
        presets.add(preset)
        names = {p.name for p in folder.iterdir()}
        for label in DEFAULT_OUTPUTS:  # every default label has its file
            stem = {"raw": "raw.dng", "depth": "depth.exr", "defocus": "defocus.exr", "clean_rgb": "clean_rgb.exr"}
            assert any(n.startswith(stem.get(label, label).split(".")[0]) for n in names), (label, names)
        if preset != "dead_leaves":  # the outdoor presets are lit by the sky at the drawn hour
            hours.append(meta["config"]["sky"]["hour"])
            assert meta["model_decisions"]["illuminant"]["emitter"] == "sky"
            assert 9.0 <= meta["config"]["sky"]["hour"] <= 17.0
            assert 2 <= meta["config"]["scene"]["object_count"] <= 5
    assert len(presets) >= 2 and len(set(hours)) == len(hours)
    again = generate_dataset(spec, out, n=4, executor=cluster.executor, progress=False)  # resume
    assert (again.rendered, again.resumed) == (0, 4)
    # every label loads, through the package's loader and Hugging Face's ImageFolder
    import datasets

    items = SyntheticDataset(out)
    for index in range(len(items)):
        item, meta = items[index], items.records(index)["meta"]
        assert {"image", "depth", "camera", "illuminant", "illuminant_map", "light_shares", "segmentation", "flow",
                "albedo", "shading"} <= set(item)
        if meta["config"]["scene"]["preset"] != "dead_leaves":  # lit by the sun and the sky apart
            assert [light["name"] for light in meta["illuminant_map"]["lights"]] == ["sky.sun", "sky.sky"]
        assert item["albedo"].shape == item["image"].shape and item["segmentation"].shape == item["depth"].shape
        if meta["config"]["scene"]["preset"] == "vegetation":
            assert "health" in item
    loaded = datasets.load_dataset("imagefolder", data_dir=str(out), split="train", cache_dir=str(tmp_path / "hf"))
    assert len(loaded) == 4 and set(loaded["id"]) == {row["id"] for row in read_manifest(out)}
    assert np.isfinite([row["params"]["sky.hour"] for row in read_manifest(out)]).all()
