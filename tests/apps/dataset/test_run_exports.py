"""Issue 40, acceptance: one ``spectral-cam dataset`` command writes the dataset and its exports
(``[dataset] exports`` in the spec, ``--export`` on the command line) into ``DIR/exports/``, and
the card links each with its units. Every export is read back by an independent reader
(pycocotools, OpenCV's PNG reader and ``readOpticalFlow``) against the item files read by OpenCV
and OpenEXR; a spec whose exports cannot be made is refused before anything is written."""

from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest

from spectral_cam.apps.dataset import load_spec, spec_from_dict, with_exports
from spectral_cam.cli import main
from spectral_cam.errors import ConfigError

from .reading import read_exr, read_manifest, read_png

pytestmark = pytest.mark.timeout(300)

SPEC = """
[dataset]
seed = 5
outputs = ["image", "depth", "segmentation", "flow"]
exports = { depth_png = { scale_m = "1/256" } }

[scene]
preset = "tabletop"
object_count = 3
ground = "flat"

[sensor]
width_px = 48
height_px = 32

[render]
spp = 4
max_depth = 2

[exposure]
time_s = 0.02

[motion]
camera_velocity_mps = [0.2, 0.05, 0.0]
"""


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """Two items and their exports in one command: depth PNGs (KITTI scale) from the spec, COCO
    and .flo from the command line."""
    base = tmp_path_factory.mktemp("run_exports")
    (base / "spec.toml").write_text(SPEC)
    out = base / "data"
    with contextlib.redirect_stderr(io.StringIO()):
        code = main(["dataset", str(base / "spec.toml"), "-n", "2", "-o", str(out), "--scheduler", "inline", "-q",
                     "--export", "coco", "--export", "flo"])
    assert code == 0
    return out


def _items(out):
    return [out / row["path"] for row in read_manifest(out) if row["status"] == "done"]


def test_one_command_writes_every_export(dataset):
    assert sorted(p.name for p in (dataset / "exports").iterdir()) == ["coco.json", "depth_png", "flo"]
    recorded = json.loads((dataset / "dataset.json").read_text())["spec"]["exports"]
    assert recorded == {"depth_png": {"scale_m": 1 / 256}, "coco": {}, "flo": {}}


def test_the_coco_export_holds_the_segmentation(dataset):
    from pycocotools import mask as mask_utils
    from pycocotools.coco import COCO

    with contextlib.redirect_stdout(io.StringIO()):
        coco = COCO(str(dataset / "exports" / "coco.json"))
    assert len(coco.getImgIds()) == 2
    for image in coco.loadImgs(coco.getImgIds()):
        assert (dataset / image["file_name"]).is_file()  # relative to the dataset folder
        ids = read_png(dataset / "items" / image["item_id"] / "segmentation.png")
        for annotation in coco.loadAnns(coco.getAnnIds(imgIds=image["id"])):
            mask = coco.annToMask(annotation).astype(bool)
            assert (mask == (ids == annotation["instance_id"])).all()
            rle = mask_utils.frPyObjects(annotation["segmentation"], image["height"], image["width"])
            assert mask_utils.area(rle) == annotation["area"] == int((ids == annotation["instance_id"]).sum())


def test_the_depth_pngs_hold_the_depth_at_the_specs_scale(dataset):
    for item in _items(dataset):
        png = read_png(dataset / "exports" / "depth_png" / f"{item.name}.png")
        depth = read_exr(item / "depth.exr")["Z"]
        assert png.dtype == np.uint16
        finite = np.isfinite(depth)
        assert np.abs(png / 256.0 - depth)[finite].max() <= 1 / 512 + 1e-6
        assert (png[~finite] == 0).all()


def test_the_flo_files_hold_the_flow(dataset):
    import cv2

    for item in _items(dataset):
        flo = cv2.readOpticalFlow(str(dataset / "exports" / "flo" / f"{item.name}.flo"))
        exr = read_exr(item / "flow.exr")
        np.testing.assert_array_equal(flo, np.stack([exr["dx"], exr["dy"]], axis=-1))
        assert np.abs(flo).max() > 0.1  # the camera moved


def test_the_card_links_each_export_with_its_units(dataset):
    card = (dataset / "README.md").read_text()
    section = card[card.index("## Exports"):card.index("## Layout")]
    assert "(exports/coco.json)" in section and "(exports/depth_png/README.md)" in section
    assert "(exports/flo/README.md)" in section
    assert "depth in metres = value × 0.00390625" in section  # 1/256 m: KITTI's
    assert "kitti convention" in section


def test_a_rerun_rewrites_the_exports_from_every_finished_item(dataset, tmp_path):
    """Resuming with more items replaces the exports whole (three items, not the first two)."""
    import shutil

    copy = tmp_path / "data"
    shutil.copytree(dataset, copy)
    (copy.parent / "spec.toml").write_text(SPEC)
    with contextlib.redirect_stderr(io.StringIO()):
        assert main(["dataset", str(copy.parent / "spec.toml"), "-n", "3", "-o", str(copy), "--scheduler", "inline",
                     "-q", "--export", "coco"]) == 0
    assert len(json.loads((copy / "exports" / "coco.json").read_text())["images"]) == 3
    assert len(list((copy / "exports" / "depth_png").glob("*.png"))) == 3


@pytest.mark.parametrize("settings, message", [
    ({"outputs": ["image", "depth"], "exports": ["coco"]},
     "the 'coco' export reads the 'segmentation' label; add 'segmentation' to [dataset] outputs"),
    ({"outputs": ["image", "depth"], "exports": ["kitti"]}, "valid: coco, depth_png, flo"),
    ({"outputs": ["image", "depth"], "exports": {"depth_png": {"scale_m": -1}}}, "give metres per PNG unit"),
    ({"outputs": ["image", "depth"], "exports": {"depth_png": {"scale": 0.001}}}, "scale_m"),
    ({"outputs": ["image", "depth"], "exports": "depth_png"}, "exports = [\"coco\", \"depth_png\"]"),
])
def test_exports_that_cannot_be_made_are_refused_at_load(settings, message):
    with pytest.raises(ConfigError) as refused:
        spec_from_dict({"dataset": settings, "sensor": {"width_px": 24, "height_px": 16}})
    assert message in str(refused.value)


def test_the_command_line_export_is_checked_before_anything_is_written(tmp_path, capsys):
    spec_file = tmp_path / "spec.toml"
    spec_file.write_text(SPEC.replace('"segmentation", "flow"', '"flow"'))
    assert main(["dataset", str(spec_file), "-n", "1", "-o", str(tmp_path / "out"), "--scheduler", "inline",
                 "--export", "coco"]) == 2
    assert "add 'segmentation' to [dataset] outputs" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
    spec = with_exports(load_spec(spec_file), ["flo", "depth_png"])
    assert dict(spec.exports) == {"depth_png": {"scale_m": 1 / 256}, "flo": {}}  # the spec's options kept
