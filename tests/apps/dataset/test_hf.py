"""Issue 40 #2: typed Hugging Face columns. ``datasets.load_dataset(DIR)`` from another working
folder decodes every label an item holds: PNG labels as ``Image`` (checked against OpenCV's
reading of the file), EXR, DNG and JSON labels as arrays and numbers (checked against OpenEXR,
tifffile and json reading the files, and the package's loader for the rest)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from spectral_cam.apps.dataset import LOADABLE_LABELS, generate_dataset, read_item, spec_from_dict
from spectral_cam.apps.dataset.labels import LABELS

from .reading import read_exr, read_png

pytestmark = pytest.mark.timeout(400)

#: Every label the loader reads and the registry writes (health writes nothing on these targets).
OUTPUTS = [name for name in LOADABLE_LABELS if name in LABELS.names()]
SPEC = {
    "dataset": {"seed": 9, "outputs": OUTPUTS, "splits": {"train": 0.5, "val": 0.5}, "split_seed": 1},  # one each
    "scene": {"preset": "dof_targets", "depths_m": [1.0, 2.0, 4.0]},
    "sensor": {"width_px": 24, "height_px": 16},
    "render": {"spp": 2},
    "lens": {"focal_length_mm": 25.0, "f_number": {"log_uniform": [2.0, 8.0]}},
    "illuminant": {"spd": {"choice": ["D65", "A"]}},
}
#: EXR labels read independently: loader key → (file, channels).
EXR_CHANNELS = {"depth": ("depth.exr", ["Z"]), "defocus": ("defocus.exr", ["CoC"]),
                "clean_rgb": ("clean_rgb.exr", ["R", "G", "B"]), "flow": ("flow.exr", ["dx", "dy"]),
                "normals": ("normals.exr", ["X", "Y", "Z"]),
                "undistortion": ("undistortion.exr", ["map_x", "map_y"]), "albedo": ("albedo.exr", ["R", "G", "B"]),
                "shading": ("shading.exr", ["S"]), "illuminant_map": ("illuminant_map.exr", ["R", "G", "B"])}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("hf") / "data"
    generate_dataset(spec_from_dict(SPEC), out, n=2, scheduler="inline", progress=False)
    return out


@pytest.fixture(scope="module")
def loaded(dataset, tmp_path_factory):
    """The dataset as ``load_dataset`` returns it, called from an unrelated working folder."""
    import os

    import datasets

    elsewhere = tmp_path_factory.mktemp("elsewhere")
    previous = os.getcwd()
    os.chdir(elsewhere)
    try:
        splits = datasets.load_dataset(str(dataset), cache_dir=str(elsewhere / "cache"))
    finally:
        os.chdir(previous)
    return splits


def _rows(loaded):
    return {row["id"]: row for split in loaded.values() for row in split}


def test_every_label_is_a_typed_column(dataset, loaded):
    import datasets

    features = next(iter(loaded.values())).features
    for name in ("image", "all_in_focus", "segmentation"):
        assert isinstance(features[name], datasets.Image), name
    for name in ("depth", "defocus", "raw", "shading"):
        assert isinstance(features[name], datasets.Array2D), name
    for name in ("clean_rgb", "radiance", "flow", "albedo", "coverage", "illuminant_map", "undistortion",
                 "normals"):
        assert isinstance(features[name], datasets.Array3D), name
    assert isinstance(features["camera"]["K"], datasets.Array2D)
    folder = dataset / "items" / "000000"
    held = set(read_item(folder)) - {"meta"}
    assert held <= set(features), held - set(features)  # every key the loader reads has a column
    assert {"meta_json", "camera_json", "illuminant_json", "split", "lens.f_number", "illuminant.spd"} <= set(features)


def test_load_dataset_decodes_every_label_as_the_files_hold_it(dataset, loaded):
    import tifffile

    rows = _rows(loaded)
    metadata = [json.loads(line) for line in (dataset / "metadata.jsonl").read_text().splitlines()]
    assert sorted(rows) == sorted(r["id"] for r in metadata) and len(rows) == 2
    for entry in metadata:
        row, folder = rows[entry["id"]], dataset / "items" / entry["id"]
        assert row["split"] == entry["split"] and row["lens.f_number"] == entry["lens.f_number"]
        for name in ("image", "all_in_focus"):
            np.testing.assert_array_equal(np.asarray(row[name]), read_png(folder / f"{name}.png")[..., ::-1])
        np.testing.assert_array_equal(np.asarray(row["segmentation"]), read_png(folder / "segmentation.png"))
        np.testing.assert_array_equal(np.asarray(row["raw"]), tifffile.imread(folder / "raw.dng"))
        for key, (file, channels) in EXR_CHANNELS.items():
            exr = read_exr(folder / file)
            expected = np.stack([exr[c] for c in channels], axis=-1)
            np.testing.assert_array_equal(np.asarray(row[key], dtype=np.float32),
                                          expected[..., 0] if len(channels) == 1 else expected, err_msg=key)
        camera = json.loads((folder / "camera.json").read_text())
        np.testing.assert_array_equal(np.asarray(row["camera"]["K"]), camera["K"])
        assert json.loads(row["camera_json"]) == camera
        assert json.loads(row["illuminant_json"]) == json.loads((folder / "illuminant.json").read_text())
        assert json.loads(row["meta_json"]) == json.loads((folder / "meta.json").read_text())
        item = read_item(folder)  # the rest (spectral EXR, coverage ranks, light shares) as the loader reads them
        for key in ("radiance", "radiance_nm", "coverage", "coverage_fraction", "light_shares", "albedo_srgb",
                    "illuminance_lux"):
            np.testing.assert_array_equal(np.asarray(row[key]), item[key], err_msg=key)


def test_the_card_names_the_shards_for_load_dataset(dataset):
    card = (dataset / "README.md").read_text()
    header = card.split("---")[1]
    assert "data_files:" in header and all(f"path: data/split={s}/*.parquet" in header for s in ("train", "val"))
    assert "load_dataset('DATASET_DIR')" in card
