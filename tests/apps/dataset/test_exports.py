"""Issue 40 #4: a generated dataset exported in the files other tools read, each read back by an
independent reader: COCO instances by pycocotools (its RLE decoder, ``toBbox``, ``area`` and
``COCOeval``), 16-bit depth PNGs by OpenCV against the depth EXR read by OpenEXR, Middlebury
``.flo`` by OpenCV's ``readOpticalFlow`` against the flow EXR. Bad input leaves no output."""

from __future__ import annotations

import contextlib
import io
import json
import shutil

import numpy as np
import pytest

from spectral_cam.apps.dataset import generate_dataset, spec_from_dict
from spectral_cam.apps.dataset.exports import (export, export_coco, export_depth_png, export_flo, mask_to_rle,
                                               read_depth_png, read_flo, write_depth_png, write_flo)
from spectral_cam.cli import main
from spectral_cam.errors import ConfigError, RawFormatError

from .reading import read_exr, read_manifest, read_png

pytestmark = pytest.mark.timeout(300)

#: Two tabletop items (objects on a ground), the camera moving across the view during the
#: exposure so that the flow is not zero.
SPEC = {
    "dataset": {"seed": 5, "outputs": ["image", "depth", "segmentation", "flow"]},
    "scene": {"preset": "tabletop", "object_count": 3, "ground": "flat"},
    "sensor": {"width_px": 48, "height_px": 32},
    "render": {"spp": 4, "max_depth": 2},
    "exposure": {"time_s": 0.02},
    "motion": {"camera_velocity_mps": [0.2, 0.05, 0.0]},
}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("exports") / "data"
    summary = generate_dataset(spec_from_dict(SPEC), out, n=2, scheduler="inline", progress=False)
    assert (summary.rendered, summary.failed) == (2, 0)
    return out


def _items(dataset):
    return [dataset / row["path"] for row in read_manifest(dataset) if row["status"] == "done"]


def _quiet(function, *args, **kwargs):
    with contextlib.redirect_stdout(io.StringIO()):  # pycocotools prints its progress
        return function(*args, **kwargs)


# ----------------------------------------------------------------------------- COCO
@pytest.fixture(scope="module")
def coco(dataset, tmp_path_factory):
    from pycocotools.coco import COCO

    path = export_coco(dataset, tmp_path_factory.mktemp("coco") / "instances.json")
    return path, _quiet(COCO, str(path))


def test_coco_evaluates_against_itself_at_ap_one(coco):
    from pycocotools import mask as masks
    from pycocotools.cocoeval import COCOeval

    _, gt = coco
    assert len(gt.getImgIds()) == 2 and len(gt.getAnnIds()) >= 4
    detections = [{"image_id": a["image_id"], "category_id": a["category_id"], "score": 1.0,
                   "segmentation": gt.annToRLE(a), "bbox": a["bbox"]} for a in gt.loadAnns(gt.getAnnIds())]
    for kind in ("segm", "bbox"):
        results = _quiet(gt.loadRes, [{k: v for k, v in d.items() if kind == "segm" or k != "segmentation"}
                                      for d in detections])
        evaluation = COCOeval(gt, results, kind)
        _quiet(evaluation.evaluate)
        _quiet(evaluation.accumulate)
        _quiet(evaluation.summarize)
        assert evaluation.stats[0] == pytest.approx(1.0), kind  # AP @[.5:.95], all areas
        assert evaluation.stats[1] == pytest.approx(1.0), kind  # AP @ .5
    assert masks.area(gt.annToRLE(gt.loadAnns(gt.getAnnIds())[0])) > 0


def test_coco_masks_areas_and_boxes_are_the_segmentation_label(coco, dataset):
    """pycocotools' RLE decoding of every annotation is the segmentation PNG (read by OpenCV) at
    its instance id, pixel for pixel; the masks of an image tile its labelled pixels; areas are
    the pixel counts (and meta.json's), boxes pycocotools' toBbox and the mask's extent."""
    from pycocotools import mask as masks

    _, gt = coco
    items = {image["item_id"]: image for image in gt.dataset["images"]}
    categories = {c["id"]: c["name"] for c in gt.loadCats(gt.getCatIds())}
    for folder in _items(dataset):
        image = items[folder.name]
        assert image["file_name"] == f"items/{folder.name}/image.png" and (dataset / image["file_name"]).is_file()
        ids = read_png(folder / "segmentation.png")
        table = {row["id"]: row for row in json.loads((folder / "meta.json").read_text())["segmentation"]["instances"]}
        assert (image["height"], image["width"]) == ids.shape
        covered = np.zeros(ids.shape, dtype=int)
        annotations = gt.loadAnns(gt.getAnnIds(imgIds=[image["id"]]))
        assert {a["instance_id"] for a in annotations} == set(np.unique(ids)) - {0}
        for annotation in annotations:
            mask = gt.annToMask(annotation).astype(bool)
            np.testing.assert_array_equal(mask, ids == annotation["instance_id"])
            covered += mask
            row = table[annotation["instance_id"]]
            assert annotation["area"] == mask.sum() == row["pixels"] == masks.area(gt.annToRLE(annotation))
            assert categories[annotation["category_id"]] == row["class"] and annotation["name"] == row["name"]
            np.testing.assert_array_equal(annotation["bbox"], masks.toBbox(gt.annToRLE(annotation)))
            x, y, w, h = (int(v) for v in annotation["bbox"])
            inside = np.zeros_like(mask)
            inside[y:y + h, x:x + w] = True
            assert mask[~inside].sum() == 0 and mask[y].any() and mask[y + h - 1].any() \
                and mask[:, x].any() and mask[:, x + w - 1].any()  # encloses the mask, tightly
        np.testing.assert_array_equal(covered, ids != 0)


@pytest.mark.parametrize("shape", [(5, 7), (1, 1), (4, 3)])
def test_rle_is_what_pycocotools_encodes(shape):
    from pycocotools import mask as masks

    rng = np.random.default_rng(shape[0] * 10 + shape[1])
    for mask in (rng.random(shape) < 0.5, np.ones(shape, bool), np.zeros(shape, bool)):
        ours = mask_to_rle(mask)
        theirs = masks.encode(np.asfortranarray(mask.astype(np.uint8)))
        np.testing.assert_array_equal(masks.decode(masks.frPyObjects(ours, *shape)), mask)
        assert masks.frPyObjects(ours, *shape)["counts"] == theirs["counts"]


# ----------------------------------------------------------------------------- depth PNG
def test_depth_png_read_by_opencv_is_the_exr_depth_within_half_a_millimetre(dataset, tmp_path):
    import cv2

    out = export_depth_png(dataset, tmp_path / "depth")
    record = json.loads((out / "depth_png.json").read_text())
    assert record["scale_m_per_unit"] == 0.001 and record["invalid_value"] == 0
    assert "value × 0.001" in (out / "README.md").read_text()
    for folder in _items(dataset):
        png = cv2.imread(str(out / f"{folder.name}.png"), cv2.IMREAD_UNCHANGED)
        depth = read_exr(folder / "depth.exr")["Z"]
        assert png.dtype == np.uint16 and png.shape == depth.shape
        hit = np.isfinite(depth)
        assert hit.sum() > 0.5 * depth.size
        assert np.abs(png[hit] * record["scale_m_per_unit"] - depth[hit]).max() <= 0.0005 + 1e-6
        assert (png[~hit] == 0).all()


@pytest.mark.parametrize("scale", [0.001, 1 / 256])
def test_a_depth_ramp_over_0_to_65_m_round_trips_within_half_a_step(tmp_path, scale):
    """NYU's millimetres and KITTI's 1/256 m, read by OpenCV; no depth (inf, NaN, ≤ 0) and depth
    beyond 65535 steps are 0, never a wrong depth."""
    import cv2

    ramp = np.linspace(0.002, 65.5, 48 * 64).reshape(48, 64).astype(np.float32)
    ramp[0, :4] = [np.inf, np.nan, 0.0, -1.0]
    ramp[1, 0] = 70.0
    counts = write_depth_png(ramp, tmp_path / "d.png", scale_m=scale)
    png = cv2.imread(str(tmp_path / "d.png"), cv2.IMREAD_UNCHANGED)
    valid = np.isfinite(ramp) & (ramp > 0) & (ramp <= 65535 * scale)
    assert np.abs(png[valid] * scale - ramp[valid]).max() <= scale / 2 + 1e-6
    assert (png[~valid] == 0).all() and png[valid].min() > 0
    assert counts["invalid"] == 4 and counts["out_of_range"] == int((~valid).sum()) - 4
    back = read_depth_png(tmp_path / "d.png", scale_m=scale)
    np.testing.assert_allclose(back[valid], png[valid] * scale, rtol=1e-6)
    assert np.isinf(back[~valid]).all()


# ----------------------------------------------------------------------------- .flo
def test_flo_read_by_opencv_is_the_flow_label(dataset, tmp_path):
    import cv2

    out = export_flo(dataset, tmp_path / "flo")
    assert json.loads((out / "flo.json").read_text())["items"].keys() == {f.name for f in _items(dataset)}
    for folder in _items(dataset):
        flow = cv2.readOpticalFlow(str(out / f"{folder.name}.flo"))
        exr = read_exr(folder / "flow.exr")
        assert flow.shape == exr["dx"].shape + (2,) and np.abs(exr["dx"]).max() > 0.1  # the camera moved
        np.testing.assert_array_equal(flow[..., 0], exr["dx"])
        np.testing.assert_array_equal(flow[..., 1], exr["dy"])


def test_flo_header_is_middleburys(tmp_path):
    import cv2

    flow = np.random.default_rng(1).normal(size=(5, 9, 2)).astype(np.float32)
    write_flo(flow, tmp_path / "f.flo")
    data = (tmp_path / "f.flo").read_bytes()
    assert data[:4] == b"PIEH" and np.frombuffer(data[4:12], "<i4").tolist() == [9, 5] and len(data) == 12 + 5 * 9 * 8
    np.testing.assert_array_equal(cv2.readOpticalFlow(str(tmp_path / "f.flo")), flow)
    cv2.writeOpticalFlow(str(tmp_path / "theirs.flo"), flow)  # and ours reads OpenCV's
    np.testing.assert_array_equal(read_flo(tmp_path / "theirs.flo"), flow)
    flow[2, 3] = np.nan  # unknown flow: Middlebury's 1e10
    assert write_flo(flow, tmp_path / "u.flo") == {"unknown": 1}
    assert cv2.readOpticalFlow(str(tmp_path / "u.flo"))[2, 3].tolist() == [1e10, 1e10]
    assert np.isnan(read_flo(tmp_path / "u.flo")[2, 3]).all()


# ----------------------------------------------------------------------------- bad input
def test_bad_input_is_refused_clearly_and_leaves_no_output(dataset, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(RawFormatError, match="is not a dataset folder"):
        export_coco(tmp_path, out / "c.json")
    with pytest.raises(ConfigError, match="unknown export format 'yolo'; valid: coco, depth_png, flo"):
        export(dataset, out / "x", format="yolo")
    with pytest.raises(ConfigError, match="depth scale"):
        export_depth_png(dataset, out / "d", scale_m=0)
    # a dataset generated without flow on one item: the label is named, with the remedy
    lacking = tmp_path / "lacking"
    shutil.copytree(dataset, lacking)
    rows = read_manifest(lacking)
    rows[1]["files"] = [name for name in rows[1]["files"] if not name.endswith("flow.exr")]
    (lacking / "manifest.jsonl").write_text("".join(json.dumps(row) + "\n" for row in rows))
    with pytest.raises(ConfigError, match=r"1 of 2 items have no 'flow' label .*\[dataset\] outputs"):
        export_flo(lacking, out / "f")
    # a damaged label halfway through: nothing is published, no staging folder is left
    damaged = tmp_path / "damaged"
    shutil.copytree(dataset, damaged)
    (damaged / rows[1]["path"] / "depth.exr").write_bytes(b"not an EXR")
    with pytest.raises(RawFormatError, match="depth.exr"):
        export_depth_png(damaged, out / "d")
    assert list(out.iterdir()) == []  # nothing published, no staging folder or temporary file left
    # an existing output is kept unless forced
    (out / "c.json").write_text("mine")
    with pytest.raises(ConfigError, match="exists"):
        export_coco(dataset, out / "c.json")
    assert (out / "c.json").read_text() == "mine"
    assert json.loads(export_coco(dataset, out / "c.json", force=True).read_text())["images"]


def test_the_command_line_exports_and_refuses(dataset, tmp_path, capsys):
    import cv2

    assert main(["export", str(dataset), "--format", "depth_png", "--depth-scale", "1/256", "-o",
                 str(tmp_path / "kitti")]) == 0
    assert json.loads((tmp_path / "kitti" / "depth_png.json").read_text())["scale_m_per_unit"] == 1 / 256
    first = _items(dataset)[0]
    png = cv2.imread(str(tmp_path / "kitti" / f"{first.name}.png"), cv2.IMREAD_UNCHANGED)
    depth = read_exr(first / "depth.exr")["Z"]
    assert np.abs(png / 256.0 - depth)[np.isfinite(depth)].max() <= 1 / 512 + 1e-6
    assert main(["export", str(dataset), "--format", "coco", "-o", str(tmp_path / "c.json")]) == 0
    assert main(["export", str(dataset), "--format", "gltf", "-o", str(tmp_path / "g")]) == 2
    assert "valid: coco, depth_png, flo" in capsys.readouterr().err
    assert main(["export", str(dataset), "--format", "coco", "--depth-scale", "0.001", "-o",
                 str(tmp_path / "c2.json")]) == 2
    assert "--depth-scale applies to --format depth_png, not coco" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json", "kitti"]
