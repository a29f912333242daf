"""Issue 40 #3: classes and instances. The parts of one object are one instance (checked against the
tabletop preset's own object list and the renderer's per-shape map, and by OpenCV's connected
components), boxes and areas are the masks' extents and pixel counts, visibility is the share of the
amodal mask that shows (against the ColorChecker's layering), the semantic map is the class
lookup of the instance map (sky where the depth label has no surface), and classes.json's ids come
from the declared class list whatever order the items finish in or whether the run resumed."""

from __future__ import annotations

import json

import numpy as np
import pytest

from spectral_cam.apps.dataset import SyntheticDataset, generate_dataset, spec_from_dict, write_item
from spectral_cam.apps.dataset.labels import PRESET_CLASSES, USER_CLASS_BASE, _merge_ranks

from .reading import read_exr, read_manifest, read_png

pytestmark = pytest.mark.timeout(300)

#: A tabletop whose layout holds a cylinder (a tube and a top disc: two shapes, one object), seen
#: wide (±9° vertically) and 5° down, so the sky shows above the distant hills.
TABLETOP = {"scene": {"preset": "tabletop", "object_count": 3, "ground": "flat", "layout_seed": 9,
                      "view_pitch_deg": -5.0},
            "sensor": {"width_px": 48, "height_px": 32, "pixel_pitch_um": 40.0}, "lens": {"focal_length_mm": 4.0},
            "render": {"spp": 2, "max_depth": 2}}


@pytest.fixture(scope="module")
def tabletop(tmp_path_factory):
    from spectral_cam import scene_from_dict

    config = scene_from_dict(TABLETOP)
    folder = tmp_path_factory.mktemp("classes") / "item"
    meta = write_item(config, folder, outputs=["depth", "segmentation", "semantic", "coverage"])
    return config, folder, meta


def _per_shape_map(config):
    """The renderer's own shape map (one id per Mitsuba shape, unmerged) and the preset's object list."""
    from spectral_cam.optics import ThinLens
    from spectral_cam.presets.tabletop import tabletop_layout
    from spectral_cam.reflectance_sets import reflectance_set
    from spectral_cam.render import render_shape_map

    lens = ThinLens.from_config(config.lens, config.sensor)
    index, names = render_shape_map(config, lens=lens)
    layout = tabletop_layout(config, lens, len(reflectance_set(config.scene.object_reflectances).sds))
    return index, names, layout


def test_an_objects_parts_are_one_instance_of_its_shape_kind(tabletop):
    """Each tabletop object_N (and object_N_top, a cylinder's lid) is one instance whose mask is the
    union of its shapes' pixels in the renderer's per-shape map, classed by the preset's layout
    (sphere, box, cylinder, torus, vase); the far ground strips are the ground's parts, and no
    listed instance is empty."""
    import cv2

    config, folder, meta = tabletop
    ids = read_png(folder / "segmentation.png")
    index, names, layout = _per_shape_map(config)
    table = {row["name"]: row for row in meta["segmentation"]["instances"]}
    assert not any(name.startswith("ground_far") or name.endswith("_top") for name in table)
    assert all((row["pixels"] > 0) == (row["bbox"] is not None) for row in table.values())
    assert {"ground_far_north", "ground_far_south", "ground_far_east", "ground_far_west"} <= set(table["ground"]["parts"])
    assert "cylinder" in [item.shape for item in layout]
    shown = 0
    for n, item in enumerate(layout):
        shapes = [k for k, name in enumerate(names) if name in (f"object_{n}", f"object_{n}_top")]
        expected = np.isin(index, shapes)
        if not expected.any():
            assert table[f"object_{n}"]["pixels"] == 0
            continue
        row = table[f"object_{n}"]
        np.testing.assert_array_equal(ids == row["id"], expected)
        assert row["class"] == item.shape and row["category"] == "object"
        assert row["class_id"] == [c.name for c in PRESET_CLASSES].index(item.shape) + 1
        if item.shape == "cylinder":
            assert sorted(row["parts"]) == [f"object_{n}", f"object_{n}_top"]
            tube, top = (index == names.index(f"object_{n}")), (index == names.index(f"object_{n}_top"))
            if tube.any() and top.any():  # the lid sits on the tube: one connected object
                count, _ = cv2.connectedComponents((ids == row["id"]).astype(np.uint8), connectivity=8)
                assert count - 1 == 1
        shown += 1
    assert shown == sum(1 for row in table.values() if row["category"] == "object" and row["pixels"]) == 3


def test_boxes_and_areas_are_the_masks_extents(tabletop):
    _, folder, meta = tabletop
    ids = read_png(folder / "segmentation.png")
    height, width = ids.shape
    shown = [row for row in meta["segmentation"]["instances"] if row["pixels"]]
    assert set(np.unique(ids)) - {0} == {row["id"] for row in shown}
    for row in shown:
        rows, cols = np.nonzero(ids == row["id"])
        assert row["area"] == row["pixels"] == rows.size
        assert row["bbox"] == [cols.min(), rows.min(), cols.max() - cols.min() + 1, rows.max() - rows.min() + 1]
        touches = rows.min() == 0 or cols.min() == 0 or rows.max() == height - 1 or cols.max() == width - 1
        assert row["truncated"] == touches
        assert row["amodal_pixels"] >= row["pixels"] and row["visible_fraction"] == row["pixels"] / row["amodal_pixels"]
    assert "amodal" in meta["segmentation"]["visibility"]


def test_visibility_is_the_share_of_the_amodal_mask_that_shows(make_scene, tmp_path):
    """The colorchecker preset stacks its patches on the chart's frame and the frame on a surround
    that fills the view: the frame's amodal mask is its visible pixels and every patch's, the
    surround's the whole frame; each patch shows whole (visible_fraction 1)."""
    import cv2

    config = make_scene(scene={"preset": "colorchecker"}, sensor={"width_px": 48, "height_px": 32}, render={"spp": 1})
    meta = write_item(config, tmp_path / "item", outputs=["segmentation"])
    ids = cv2.imread(str(tmp_path / "item" / "segmentation.png"), cv2.IMREAD_UNCHANGED)
    rows = {row["name"]: row for row in meta["segmentation"]["instances"]}
    patches = [row for name, row in rows.items() if name.startswith("patch_")]
    patch_pixels = sum(int((ids == row["id"]).sum()) for row in patches)
    frame, surround = rows["chart_frame"], rows["surround"]
    assert len(patches) == 24 and all(row["visible_fraction"] == 1.0 for row in patches)
    assert frame["amodal_pixels"] == int((ids == frame["id"]).sum()) + patch_pixels
    assert surround["amodal_pixels"] == ids.size and (ids > 0).all()
    assert surround["visible_fraction"] == pytest.approx((ids == surround["id"]).sum() / ids.size)
    assert 0 < surround["visible_fraction"] < frame["visible_fraction"] < 1


def test_the_semantic_map_is_the_class_lookup_of_the_instance_map(tabletop):
    """semantic.png = class_id of the instance at each pixel; where the pinhole ray meets nothing
    (the depth label is infinite) it is the sky under the tabletop's sun and sky."""
    from spectral_cam.apps.dataset.labels import sky_visible

    _, folder, meta = tabletop
    ids = read_png(folder / "segmentation.png")
    semantic = read_png(folder / "semantic.png")
    depth = read_exr(folder / "depth.exr")["Z"]
    assert semantic.dtype == np.uint16 and semantic.shape == ids.shape
    lookup = np.zeros(max(row["id"] for row in meta["segmentation"]["instances"]) + 1, np.uint16)
    for row in meta["segmentation"]["instances"]:
        lookup[row["id"]] = row["class_id"]
    sky = [c.name for c in PRESET_CLASSES].index("sky") + 1
    nothing = ids == 0
    assert nothing.sum() > 50 and (~nothing).any()
    # the depth label's ray goes through its own random point of the pixel: the two may differ only
    # on the sky's edge (within a pixel of it)
    import cv2

    sky_in_depth = (~np.isfinite(depth)).astype(np.uint8)
    edge = cv2.dilate(sky_in_depth, np.ones((3, 3), np.uint8)) != cv2.erode(sky_in_depth, np.ones((3, 3), np.uint8))
    assert not (nothing != sky_in_depth.astype(bool))[~edge].any()
    np.testing.assert_array_equal(semantic[~nothing], lookup[ids[~nothing]])
    assert sky_visible(tabletop[0]) and (semantic[nothing] == sky).all()
    counts = np.bincount(semantic.ravel())
    assert meta["semantic"]["class_pixels"] == {str(k): int(n) for k, n in enumerate(counts) if n and k}


def test_ranks_of_one_object_are_merged_in_the_coverage():
    """Two ranks of one instance (a tube and its lid under one pixel's blur) add up; the rest
    re-rank, most coverage first, an emptied rank id 0."""
    ids = np.array([[[3, 3, 5], [2, 4, 0], [7, 1, 7]]])
    coverage = np.array([[[0.4, 0.3, 0.2], [0.5, 0.3, 0.0], [0.25, 0.3, 0.1]]], np.float32)
    merged_ids, merged = _merge_ranks(ids, coverage)
    np.testing.assert_array_equal(merged_ids, [[[3, 5, 0], [2, 4, 0], [7, 1, 0]]])
    np.testing.assert_allclose(merged, [[[0.7, 0.2, 0.0], [0.5, 0.3, 0.0], [0.35, 0.3, 0.0]]], atol=1e-6)


def test_the_coverage_names_the_segmentations_merged_instances(tabletop):
    """coverage.exr's ids are segmentation.png's (one per object): where one instance takes all of a
    pixel's rays through the aperture, it is the pinhole's instance there, and no cylinder lid
    shows up as an id of its own."""
    _, folder, meta = tabletop
    ids = read_png(folder / "segmentation.png")
    exr = read_exr(folder / "coverage.exr")
    names = {row["id"]: row["name"] for row in meta["segmentation"]["instances"]}
    seen = {int(k) for k in np.unique(exr["id_0"])} - {0}
    assert {int(k): name for k, name in meta["coverage"]["instances"].items()}.items() <= names.items()
    assert seen <= set(names)
    whole = exr["coverage_0"] == 1.0
    assert whole.mean() > 0.5 and np.mean(exr["id_0"][whole] == ids[whole]) > 0.99


# ----------------------------------------------------------------------------- dataset-wide ids
SPEC = {"dataset": {"seed": 3, "outputs": ["image", "segmentation", "semantic"]},
        "scene": {"preset": {"choice": ["colorchecker", "dof_targets"]}},
        "sensor": {"width_px": 24, "height_px": 16}, "render": {"spp": 2}}


@pytest.fixture(scope="module")
def two_datasets(tmp_path_factory):
    """One spec made twice: at once (3 items), and as 1 item then resumed to 3 (other items first)."""
    base = tmp_path_factory.mktemp("ids")
    spec = spec_from_dict(SPEC)
    whole = generate_dataset(spec, base / "whole", n=3, scheduler="inline", progress=False)
    first = generate_dataset(spec, base / "resumed", n=1, scheduler="inline", progress=False)
    resumed = generate_dataset(spec, base / "resumed", n=3, scheduler="inline", progress=False)
    assert (whole.rendered, first.rendered, resumed.rendered, resumed.resumed) == (3, 1, 2, 1)
    return base / "whole", base / "resumed"


def _ids_in_items(out):
    """class name → class ids its items' instance tables give it."""
    found: dict[str, set] = {}
    for row in read_manifest(out):
        meta = json.loads((out / row["path"] / "meta.json").read_text())
        for instance in meta["segmentation"]["instances"]:
            found.setdefault(instance["class"], set()).add(instance["class_id"])
    return found


def test_class_ids_are_the_declared_lists_in_every_item_and_resumed_run(two_datasets):
    declared = {c.name: k + 1 for k, c in enumerate(PRESET_CLASSES)}
    documents = [json.loads((out / "classes.json").read_text()) for out in two_datasets]
    assert documents[0]["classes"] == documents[1]["classes"]
    for out, document in zip(two_datasets, documents):
        listed = {entry["name"]: entry["id"] for entry in document["classes"]}
        assert listed and all(declared[name] == k for name, k in listed.items())
        assert all(entry["pixels"] > 0 and entry["items"] > 0 for entry in document["classes"])  # empty ones dropped
        assert all(ids == {declared[name]} for name, ids in _ids_in_items(out).items())
        assert {"chart_patch", "depth_plane"} <= set(listed) and max(listed.values()) < USER_CLASS_BASE
        card = (out / "README.md").read_text()
        assert "## Classes" in card and "(classes.json)" in card and f"| {listed['chart_patch']} | `chart_patch` |" in card


def test_the_loader_reads_the_semantic_label_and_the_class_map(two_datasets):
    import cv2

    out = two_datasets[0]
    data = SyntheticDataset(out, labels=("segmentation", "semantic"))
    classes = data.classes
    for k in range(len(data)):
        item = data[k]
        png = cv2.imread(str(out / data.rows[k]["path"] / "semantic.png"), cv2.IMREAD_UNCHANGED)
        np.testing.assert_array_equal(item["semantic"], png)
        assert item["semantic"].dtype == np.int32  # collate-safe, as the segmentation
        assert set(np.unique(png)) - {0} <= set(classes)


def test_coco_categories_are_classes_json(two_datasets, tmp_path):
    """COCO's categories are classes.json's (ids, names, categories as supercategories); every
    annotation's category is its instance's class_id."""
    from spectral_cam.apps.dataset.exports import export_coco

    out = two_datasets[1]
    coco = json.loads(export_coco(out, tmp_path / "instances.json").read_text())
    classes = {entry["id"]: entry for entry in json.loads((out / "classes.json").read_text())["classes"]}
    assert {c["id"]: (c["name"], c["supercategory"]) for c in coco["categories"]} == {
        k: (e["name"], e["category"]) for k, e in classes.items() if e["instances"]}
    for annotation in coco["annotations"]:
        image = next(i for i in coco["images"] if i["id"] == annotation["image_id"])
        meta = json.loads((out / "items" / image["item_id"] / "meta.json").read_text())
        row = next(r for r in meta["segmentation"]["instances"] if r["id"] == annotation["instance_id"])
        assert annotation["category_id"] == row["class_id"] and annotation["bbox"] == row["bbox"]
