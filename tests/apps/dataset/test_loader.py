"""Issue 27 #6: a dataset in layouts loaders read — metadata.jsonl (Hugging Face ImageFolder's
``file_name`` column), the dataset card, and the package's loader — checked against the files
read independently (OpenCV, OpenEXR, tifffile, the manifest) and against Hugging Face
``datasets`` itself."""

from __future__ import annotations

import json

import numpy as np
import pytest

from spectral_cam.apps.dataset import (LOADABLE_LABELS, Crop, Resize, SyntheticDataset, generate_dataset, read_item,
                                       spec_from_dict)
from spectral_cam.errors import RawFormatError

from .collate_reference import default_collate
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
    assert card.startswith("---\n") and "path: data/split=train/*.parquet" in card.split("---")[1]  # typed rows (test_hf)
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
        assert item["camera"]["f_number"] == camera["f_number"]
        illuminant = json.loads((folder / "illuminant.json").read_text())
        np.testing.assert_array_equal(item["illuminant"]["camera_rgb"], illuminant["camera_rgb"])
        records = data.records(index)
        assert records["illuminant"]["spd"] == data.params(index)["illuminant.spd"] == item["params"]["illuminant.spd"]
        assert records["meta"]["dataset"]["id"] == data.rows[index]["id"] == item["id"]
        assert records["camera"]["conventions"] == camera["conventions"]
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


def test_items_batch_with_pytorchs_default_collate(dataset):
    """Issue 39 #3 / issue 40 #1: ``DataLoader(SyntheticDataset(DIR), batch_size=4)`` failed in the
    default collate (each item's meta and camera dicts differ in keys and sizes). Batched by
    PyTorch's default_collate rules (tests/apps/dataset/collate_reference.py: the structure of
    torch/utils/data/_utils/collate.py with NumPy's stack), every array's batch is the items'
    arrays stacked, the numbers and strings one per item."""
    data = SyntheticDataset(dataset)
    items = [data[i] for i in range(len(data))]
    batch = default_collate(items)
    for key, value in items[0].items():
        if isinstance(value, np.ndarray):
            assert batch[key].shape == (3, *value.shape), key
            np.testing.assert_array_equal(batch[key][1], items[1][key])
    assert batch["raw"].dtype == np.int32  # the DNG's uint16, widened as torchvision widens 16-bit PNGs
    np.testing.assert_array_equal(batch["raw"][2], read_item(dataset / "items" / items[2]["id"], ["raw"])["raw"])
    assert batch["camera"]["K"].shape == (3, 3, 3) and batch["camera"]["f_number"].shape == (3,)
    assert batch["illuminant"]["xy"].shape == (3, 2)
    assert batch["params"]["illuminant.spd"] == [data.params(i)["illuminant.spd"] for i in range(3)]
    assert list(batch["index"]) == [row["index"] for row in data.rows]
    # read_item's records (meta.json, camera.json as written) are what the default collate refuses
    with pytest.raises((TypeError, RuntimeError, KeyError)):
        default_collate([read_item(dataset / "items" / row["id"]) for row in data.rows])


def test_pytorch_dataloader_batches_the_dataset_where_torch_is_installed(dataset):
    """The same with PyTorch itself (an optional extra: this runs where it is installed)."""
    torch = pytest.importorskip("torch")
    data = SyntheticDataset(dataset, labels=("image", "depth", "camera"))
    batch = next(iter(torch.utils.data.DataLoader(data, batch_size=3)))
    assert tuple(batch["image"].shape) == (3, 16, 24, 3) and tuple(batch["camera"]["K"].shape) == (3, 3, 3)
    np.testing.assert_array_equal(batch["depth"][0].numpy(), data[0]["depth"])


def test_a_corrupt_label_file_names_the_item_the_file_and_what_to_do(dataset, tmp_path):
    """Issue 39 #26: a corrupt camera.json raised JSONDecodeError from ``data[i]``."""
    import shutil

    out = tmp_path / "copy"
    shutil.copytree(dataset, out)
    data = SyntheticDataset(out)
    item_id = data.rows[1]["id"]
    (out / "items" / item_id / "camera.json").write_text('{"K": [[1, 0')
    with pytest.raises(RawFormatError) as caught:
        data[1]
    message = str(caught.value)
    assert f"item {item_id}" in message and "camera.json" in message and "rerun the same" in message
    assert "JSONDecodeError" in message  # what was wrong, after where
    # the remedy it names works: the rerun finds the file's checksum changed and renders the item again
    summary = generate_dataset(spec_from_dict(SPEC), out, n=3, scheduler="inline", progress=False)
    assert (summary.rendered, summary.resumed) == (1, 2)
    written = json.loads((dataset / "items" / item_id / "camera.json").read_text())
    assert SyntheticDataset(out).records(1)["camera"]["K"].tolist() == written["K"]


def _one_item(tmp_path, name: str, **sensor) -> dict:
    """One item of a pinhole view of the depth targets (so depth and defocus are sharp-edged planes)."""
    spec = {"dataset": {"seed": 5, "outputs": ["image", "depth", "defocus", "camera"]},
            "scene": {"preset": "dof_targets", "depths_m": [1.0, 2.0, 4.0]},
            "sensor": {"crop_margin_px": 0, **sensor}, "render": {"spp": 2},
            "lens": {"focal_length_mm": 25.0, "f_number": 4.0, "focus_distance_m": 2.0}}
    generate_dataset(spec_from_dict(spec), tmp_path / name, n=1, scheduler="inline", progress=False)
    return SyntheticDataset(tmp_path / name)[0]


def test_crop_and_resize_keep_the_intrinsics_and_pixel_labels_of_a_real_smaller_sensor(tmp_path):
    """Issue 40 #1 check: K after a transform is the K the renderer writes for the sensor the
    transformed frame stands for: a centre crop of a 48 × 32 frame is a 24 × 16 sensor of the
    same pitch; halving it is a 24 × 16 sensor of twice the pitch (same field of view), whose
    depth and defocus diameter (px) agree with the halved labels where the planes are (not at
    the targets' edges, which one pixel of the coarse sensor straddles)."""
    big = _one_item(tmp_path, "big", width_px=48, height_px=32, pixel_pitch_um=6.0)
    same_pitch = _one_item(tmp_path, "crop", width_px=24, height_px=16, pixel_pitch_um=6.0)
    coarse = _one_item(tmp_path, "coarse", width_px=24, height_px=16, pixel_pitch_um=12.0)

    cropped = Crop(16, 24)(big)
    np.testing.assert_allclose(cropped["camera"]["K"], same_pitch["camera"]["K"], rtol=1e-12, atol=1e-9)
    assert cropped["camera"]["image_size"].tolist() == [24, 16] and cropped["image"].shape == (16, 24, 3)
    resized = Resize(16, 24)(big)
    np.testing.assert_allclose(resized["camera"]["K"], coarse["camera"]["K"], rtol=1e-12, atol=1e-9)
    assert resized["camera"]["pixel_pitch_um"] == pytest.approx(12.0)
    for key, tolerance in (("depth", 1e-4), ("defocus", 0.02)):  # the preset frames its targets by the view,
        agree = np.isclose(resized[key], coarse[key], rtol=tolerance, atol=tolerance)  # so only the same view
        assert agree.mean() > 0.9, (key, agree.mean())
    with pytest.raises(ValueError, match="ellipse"):
        Resize(16, 16)(big)
    with pytest.raises(ValueError, match="larger than"):
        Crop(40, 24)(big)
    random = Crop(8, 8, position="random", seed=1)
    corners = {tuple(random(big)["camera"]["K"][:2, 2]) for _ in range(20)}
    assert len(corners) > 5  # the window moves; K's principal point follows it
