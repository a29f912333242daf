"""Issue 27 #6: a dataset in layouts loaders read — metadata.jsonl (Hugging Face ImageFolder's
``file_name`` column), the dataset card, and the package's loader — checked against the files
read independently (OpenCV, OpenEXR, tifffile, the manifest) and against Hugging Face
``datasets`` itself."""

from __future__ import annotations

import json

import numpy as np
import pytest

from spectral_cam.apps.dataset import LOADABLE_LABELS, SyntheticDataset, generate_dataset, read_item, spec_from_dict
from spectral_cam.errors import RawFormatError

from .reading import read_exr, read_manifest, read_png

pytestmark = pytest.mark.timeout(300)

SPEC = {
    "dataset": {"seed": 3, "outputs": ["raw", "image", "depth", "camera", "illuminant", "defocus", "clean_rgb",
                                      "all_in_focus", "albedo"]},
    "scene": {"preset": "dof_targets", "depths_m": [1.0, 2.0, 4.0]},
    "sensor": {"width_px": 24, "height_px": 16},
    "render": {"spp": 2},
    "lens": {"focal_length_mm": 25.0, "f_number": {"log_uniform": [2.0, 8.0]}},
    "illuminant": {"spd": {"choice": ["D65", "A"]}},
}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("loader") / "data"
    generate_dataset(spec_from_dict(SPEC), out, n=3, scheduler="inline", progress=False)
    return out


def test_metadata_jsonl_has_a_row_per_item_with_its_image_parameters_and_labels(dataset):
    rows = [json.loads(line) for line in (dataset / "metadata.jsonl").read_text().splitlines()]
    manifest = read_manifest(dataset)
    assert [r["id"] for r in rows] == [m["id"] for m in manifest if m["status"] == "done"] and len(rows) == 3
    for row, entry in zip(rows, manifest):
        assert row["file_name"] == f"items/{entry['id']}/image.png" and (dataset / row["file_name"]).is_file()
        assert row["seed"] == entry["seed"]
        assert row["lens.f_number"] == entry["params"]["lens.f_number"]
        assert row["illuminant.spd"] == entry["params"]["illuminant.spd"]
        for label in ("raw", "depth", "camera", "illuminant", "defocus", "clean_rgb", "all_in_focus", "meta"):
            assert (dataset / row[f"{label}_file"]).is_file(), label


def test_the_dataset_card_names_every_label_its_units_and_the_sources(dataset):
    card = (dataset / "README.md").read_text()
    assert card.startswith("---\n") and "drop_labels: true" in card.split("---")[1]
    for label in SPEC["dataset"]["outputs"]:
        assert f"| `{label}` |" in card
    assert "camera-space z, metres" in card and "Apache-2.0" in card and "BSD-3-Clause" in card
    assert "3 items rendered" in card and "lens.f_number" in card


def test_the_loader_reads_each_label_as_the_files_hold_it(dataset):
    import tifffile

    data = SyntheticDataset(dataset)
    assert len(data) == 3
    for index in range(len(data)):
        item = data[index]
        folder = dataset / "items" / data.rows[index]["id"]
        np.testing.assert_array_equal(item["image"], read_png(folder / "image.png")[..., ::-1])  # OpenCV is BGR
        np.testing.assert_array_equal(item["raw"], tifffile.imread(folder / "raw.dng"))
        np.testing.assert_array_equal(item["depth"], read_exr(folder / "depth.exr")["Z"])
        np.testing.assert_array_equal(item["defocus"], read_exr(folder / "defocus.exr")["CoC"])
        clean = read_exr(folder / "clean_rgb.exr")
        np.testing.assert_array_equal(item["clean_rgb"], np.stack([clean[c] for c in "RGB"], axis=-1))
        albedo = read_exr(folder / "albedo.exr")
        np.testing.assert_array_equal(item["albedo"], np.stack([albedo[c] for c in "RGB"], axis=-1))
        np.testing.assert_array_equal(item["shading"], read_exr(folder / "shading.exr")["S"])
        camera = json.loads((folder / "camera.json").read_text())
        np.testing.assert_array_equal(item["camera"]["K"], camera["K"])
        assert item["illuminant"]["spd"] == data.params(index)["illuminant.spd"] == item["params"]["illuminant.spd"]
        assert item["meta"]["dataset"]["id"] == data.rows[index]["id"]
        assert item["image"].shape == (16, 24, 3) and item["depth"].dtype == np.float32


def test_the_loader_serves_chosen_labels_through_a_transform_as_pytorch_takes_it(dataset):
    data = SyntheticDataset(dataset, labels=("image", "depth"), transform=lambda item: (item["image"], item["depth"]))
    image, depth = data[-1]
    assert image.shape == (16, 24, 3) and depth.shape == (16, 24)
    assert set(read_item(dataset / "items" / data.rows[0]["id"], ["depth"])) == {"meta", "depth"}
    with pytest.raises(IndexError, match="3 finished items"):
        data[3]
    with pytest.raises(RawFormatError, match="no 'radiance' label"):
        read_item(dataset / "items" / data.rows[0]["id"], ["radiance"])
    with pytest.raises(RawFormatError, match="unknown label.*valid: " + ", ".join(LOADABLE_LABELS[:2])):
        read_item(dataset / "items" / data.rows[0]["id"], ["segmentation_map"])
    with pytest.raises(RawFormatError, match="not a dataset folder"):
        SyntheticDataset(dataset / "items")


def test_hugging_face_imagefolder_reads_the_dataset(dataset, tmp_path):
    """The reference reader: ``datasets.load_dataset("imagefolder", data_dir=...)``."""
    import datasets  # in the test extras (not a dependency of the package)
    assert (dataset / "contact_sheet.png").is_file()  # images without a metadata row are not items
    loaded = datasets.load_dataset("imagefolder", data_dir=str(dataset), split="train", cache_dir=str(tmp_path))
    assert len(loaded) == 3
    rows = [json.loads(line) for line in (dataset / "metadata.jsonl").read_text().splitlines()]
    assert sorted(loaded["seed"]) == sorted(r["seed"] for r in rows)
    first = loaded[int(np.argmin(loaded["index"]))]
    np.testing.assert_array_equal(np.asarray(first["image"]), read_png(dataset / rows[0]["file_name"])[..., ::-1])
    assert first["depth_file"] == rows[0]["depth_file"]
