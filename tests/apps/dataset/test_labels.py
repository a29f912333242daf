"""Dataset labels: the defocus map is the thin-lens CoC, clean RGB is the noise-free RAW,
and an item writes exactly the labels it is asked for."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from spectral_cam.apps.dataset import LABELS, clean_camera_rgb, write_item

from .reading import read_exr, read_manifest

pytestmark = pytest.mark.timeout(300)


def test_defocus_map_is_the_thin_lens_coc(first_run):
    checked = 0
    for row in read_manifest(first_run.out):
        item = first_run.out / row["path"]
        meta = json.loads((item / "meta.json").read_text())
        lens, sensor = meta["config"]["lens"], meta["config"]["sensor"]
        f = lens["focal_length_mm"] * 1e-3
        aperture = f / lens["f_number"]
        z_f = lens["focus_distance_m"]
        pitch = sensor["pixel_pitch_um"] * 1e-6
        depth = read_exr(item / "depth.exr")["Z"]
        defocus = read_exr(item / "defocus.exr")["CoC"]
        assert defocus.shape == depth.shape == (16, 24)
        for r, c in [(0, 0), (8, 12), (15, 23), (4, 3), (11, 20)]:
            z = float(depth[r, c])
            assert math.isfinite(z)
            expected = aperture * f * (z - z_f) / (z * (z_f - f)) / pitch  # signed, + behind focus
            assert defocus[r, c] == pytest.approx(expected, rel=1e-5, abs=1e-6)
            checked += 1
        assert np.abs(defocus).max() > 0.1
    assert checked == 30


def test_clean_rgb_is_the_noise_free_raw(make_scene):
    """With every noise term off, the RAW is the clean camera RGB through the CFA, quantised."""
    from spectral_cam import spectra
    from spectral_cam.image import SpectralImage
    from spectral_cam.sensor import expose

    config = make_scene(sensor={"shot_noise": False, "read_noise_e": 0.0, "dark_current_e_per_s": 0.0,
                                "dsnu_e": 0.0, "prnu": 0.0, "cfa": "GRBG"},
                        exposure={"time_s": 0.01}, lens={"f_number": 4.0})
    bands = spectra.parse_bands("400:700:10")
    rng = np.random.default_rng(1)
    cube = rng.uniform(0.0, 0.02, (16, 24, len(bands.centres_nm))).astype(np.float32)
    radiance = SpectralImage(cube, np.asarray(bands.centres_nm), np.asarray(bands.edges_nm))
    raw = expose(radiance, config)
    clean = clean_camera_rgb(radiance, config, exposure_s=0.01)
    assert clean.shape == (16, 24, 3) and 0.05 < clean.max() < 1.0
    layout = ((1, 0), (2, 1))  # GRBG
    through_cfa = np.empty((16, 24))
    for a in (0, 1):
        for b in (0, 1):
            through_cfa[a::2, b::2] = clean[a::2, b::2, layout[a][b]]
    span = raw.white_level - raw.black_level
    measured = (raw.mosaic.astype(float) - raw.black_level) / span
    np.testing.assert_allclose(measured, through_cfa, atol=0.5 / span + 1e-6)


def test_an_item_writes_the_labels_it_is_asked_for(make_scene, tmp_path):
    """Each output is one LABELS entry; the records of labels not written are None."""
    config = make_scene(scene={"preset": "dof_targets"}, render={"spp": 2}, lens={"model": "thin"})
    meta = write_item(config, tmp_path / "item", outputs=["raw", "defocus"], dataset={"id": "x"})
    assert {p.name for p in (tmp_path / "item").iterdir()} == {"raw.dng", "defocus.exr", "meta.json"}
    checks = meta["dataset"].pop("file_checks")
    assert meta["dataset"].pop("labels") == {"raw": ["raw.dng"], "defocus": ["defocus.exr"]}  # each output's files
    assert meta["files"] == ["defocus.exr", "raw.dng", "meta.json"] and meta["dataset"] == {"id": "x"}
    assert {name: check["bytes"] for name, check in checks.items()} == {
        name: (tmp_path / "item" / name).stat().st_size for name in ("defocus.exr", "raw.dng")}
    assert meta["defocus"]["channel"] == "CoC"
    recorded = {key for entry in LABELS.values() for key in entry.options}
    assert recorded == {"defocus", "all_in_focus", "blur", "clean_rgb", "undistortion", "health", "segmentation", "albedo",
                        "flow", "illuminant_map", "coverage", "semantic", "normals"}
    assert all(meta[key] is None for key in recorded - {"defocus"})
    assert json.loads((tmp_path / "item" / "meta.json").read_text())["files"] == meta["files"]


def test_blur_beyond_the_checker_period_is_reported_as_not_measurable():
    """Issue 25 #21: a dof_targets plane blurred past its checker period (the texture averaged
    away) reported 51.6 px "measured" against 26.7 predicted; it is now no measurement, with why."""
    import numpy as np

    from spectral_cam import scene_from_dict
    from spectral_cam.apps.dataset.labels import measure_scene_blur
    from spectral_cam.optics import ThinLens

    config = scene_from_dict({"scene": {"preset": "dof_targets", "depths_m": [0.5, 2.0, 8.0], "checker_px": 4},
                              "lens": {"focal_length_mm": 25.0, "f_number": 1.4, "focus_distance_m": 2.0},
                              "sensor": {"width_px": 96, "height_px": 64}})
    lens = ThinLens.from_config(config.lens, config.sensor)
    depth = np.full((64, 96), 0.5)
    depth[:, 32:64], depth[:, 64:] = 2.0, 8.0
    image = np.random.default_rng(0).random((64, 96))
    rows = {r["depth_m"]: r for r in measure_scene_blur(config, depth, image, image, lens=lens)}
    assert float(lens.coc_diameter_px(0.5)) > 8
    assert rows[0.5]["measured_coc_px"] is None and "exceeds the checker period 8 px" in rows[0.5]["note"]
    assert rows[2.0]["note"] is None or "exceeds" not in rows[2.0]["note"]


@pytest.mark.timeout(300)
def test_segmentation_instances_coincide_with_the_depth_labels_planes(make_scene, tmp_path):
    """dof_targets: three planes at 1, 2 and 4 m in vertical stripes. Each plane's instance mask
    and the mask of pixels whose depth label is that plane's depth agree (IoU ≥ 0.98); the table
    names each instance's shape, class, material and reflectance."""
    import cv2

    depths = [1.0, 2.0, 4.0]
    config = make_scene(scene={"preset": "dof_targets", "depths_m": depths}, sensor={"width_px": 48, "height_px": 32},
                        render={"spp": 2}, lens={"model": "pinhole"})
    meta = write_item(config, tmp_path / "item", outputs=["depth", "segmentation"])
    ids = cv2.imread(str(tmp_path / "item" / "segmentation.png"), cv2.IMREAD_UNCHANGED)
    depth = read_exr(tmp_path / "item" / "depth.exr")["Z"]
    assert ids.dtype == np.uint16 and ids.shape == depth.shape == (32, 48)
    table = {row["name"]: row for row in meta["segmentation"]["instances"]}
    for index, z in enumerate(depths):
        row = table[f"plane_{index}"]
        assert row["class"] == "depth_plane" and row["reflectance"] == "checkerboard of flat 0.1 and 0.8"
        assert "Diffuse" in row["material"]
        instance = ids == row["id"]
        geometric = np.abs(depth - z) < 1e-3 * z
        iou = (instance & geometric).sum() / (instance | geometric).sum()
        assert iou >= 0.98 and row["pixels"] == int(instance.sum()) > 0, (index, iou)
    assert meta["segmentation"]["pixels_unlabelled"] == int((ids == 0).sum())


@pytest.mark.timeout(300)
def test_segmentation_names_colorchecker_patches_by_their_reflectance(make_scene, tmp_path):
    config = make_scene(scene={"preset": "colorchecker"}, sensor={"width_px": 60, "height_px": 40},
                        render={"spp": 2})
    meta = write_item(config, tmp_path / "item", outputs=["segmentation"])
    table = {row["name"]: row for row in meta["segmentation"]["instances"]}
    assert table["patch_00"]["reflectance"] == "ColorChecker 'dark skin' (BabelColor average)"
    assert table["patch_18"]["reflectance"].startswith("ColorChecker 'white 9.5")
    assert all(table[f"patch_{k:02d}"]["pixels"] > 0 for k in range(24))


@pytest.mark.timeout(300)
def test_the_card_lists_only_the_labels_the_items_wrote(tmp_path):
    """Issue 39 #31: ``outputs = ["health"]`` on a ColorChecker writes no file, yet the card listed
    it. The card's label table is what the item folders hold; an output no item could write is
    named apart with what it needs."""
    from spectral_cam.apps.dataset import generate_dataset, spec_from_dict

    spec = spec_from_dict({"dataset": {"outputs": ["image", "depth", "health"]}, "scene": {"preset": "colorchecker"},
                           "sensor": {"width_px": 24, "height_px": 16}, "render": {"spp": 2}})
    generate_dataset(spec, tmp_path / "out", n=1, scheduler="inline", progress=False)
    held = {p.name for p in (tmp_path / "out" / "items" / "000000").iterdir()}
    assert "health.exr" not in held and {"image.png", "depth.exr"} <= held
    card = (tmp_path / "out" / "README.md").read_text()
    table = card.split("## Labels")[1].split("Asked for but written by no item")[0]
    assert "| `image` |" in table and "| `depth` |" in table and "`health`" not in table
    assert "Asked for but written by no item" in card and "- `health`: health.exr" in card
    row = json.loads((tmp_path / "out" / "manifest.jsonl").read_text().splitlines()[0])
    assert row["labels"]["health"] == [] and row["labels"]["depth"] == ["depth.exr"]
