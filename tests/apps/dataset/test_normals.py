"""Issue 40 #4: the ``normals`` label. Checked against what does not come from the normals' own
render: the depth label back-projected with camera.json's K (the cross product of its gradients,
their median over each plane), the tabletop camera's own pitch for the ground, and the depth
label's z for the ray each pixel was given."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage

from spectral_cam.apps.dataset import generate_dataset, spec_from_dict
from spectral_cam.apps.dataset.loader import read_item
from spectral_cam.apps.dataset.sheets import write_label_preview

from .reading import read_exr, read_manifest, read_png

pytestmark = pytest.mark.timeout(300)

PITCH_DEG = -25.0
#: A flat ground seen 25° down with three objects on it (boxes' faces: planes at other angles).
SPEC = {"dataset": {"seed": 3, "outputs": ["depth", "camera", "segmentation", "normals"]},
        "scene": {"preset": "tabletop", "object_count": 3, "ground": "flat", "layout_seed": 9,
                  "object_size": [0.25, 0.4], "view_pitch_deg": PITCH_DEG},
        "sensor": {"width_px": 96, "height_px": 72}, "render": {"spp": 1, "max_depth": 2}}


@pytest.fixture(scope="module")
def item(tmp_path_factory):
    out = tmp_path_factory.mktemp("normals") / "data"
    summary = generate_dataset(spec_from_dict(SPEC), out, n=1, scheduler="inline", progress=False)
    assert (summary.rendered, summary.failed) == (1, 0)
    row = read_manifest(out)[0]
    return out, out / row["path"]


def _depth_gradients(depth: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points back-projected from z with K (pixel centres) and their central differences along
    x and y (m per px)."""
    rows, cols = np.mgrid[:depth.shape[0], :depth.shape[1]]
    points = np.stack([(cols - K[0, 2]) / K[0, 0] * depth, (rows - K[1, 2]) / K[1, 1] * depth, depth], axis=-1)
    return points, np.gradient(points, axis=1), np.gradient(points, axis=0)


def _planes(normals: np.ndarray, ids: np.ndarray, *, min_pixels: int = 100):
    """Masks of the planar patches: connected pixels of one instance and one normal (to 0.05;
    a plane's pixels all within 0.1° of their mean, not a curved strip), less their 1-px rim
    (where the depth's differences straddle two surfaces)."""
    code = np.round(normals * 20).astype(np.int64) @ np.array([10_000, 100, 1])
    for instance in np.unique(ids[ids > 0]):
        for value in np.unique(code[ids == instance]):
            labels, count = ndimage.label((ids == instance) & (code == value))
            for k in range(1, count + 1):
                inner = ndimage.binary_erosion(labels == k, iterations=1)
                if inner.sum() < min_pixels:
                    continue
                mean = normals[inner].mean(axis=0)
                spread = np.degrees(np.arccos(np.clip(normals[inner] @ mean / np.linalg.norm(mean), -1, 1)))
                if spread.max() < 0.1:
                    yield inner


def test_normals_are_unit_face_the_camera_and_share_the_depth_labels_rays(item):
    _, folder = item
    data = read_item(folder, ("depth", "normals", "camera"))
    normals, depth = data["normals"], data["depth"]
    hit = np.isfinite(depth)
    assert hit.sum() > 0.9 * hit.size
    assert np.abs(np.linalg.norm(normals[hit], axis=-1) - 1).max() < 1e-5
    points, _, _ = _depth_gradients(depth, data["camera"]["K"])
    assert (np.sum(normals * points, axis=-1)[hit] < 0).all()
    channels = read_exr(folder / "normals.exr")
    assert sorted(channels) == ["X", "Y", "Z"]
    png = read_png(folder / "normals.png")[..., ::-1].astype(float)  # OpenCV reads BGR
    assert np.abs(png / 255 * 2 - 1 - normals).max() <= 1 / 255 + 1e-6


def test_normals_agree_with_the_depth_gradient_on_planes(item):
    _, folder = item
    data = read_item(folder, ("depth", "normals", "camera", "segmentation"))
    normals = data["normals"]
    _, along_x, along_y = _depth_gradients(data["depth"], data["camera"]["K"])
    angles = []
    for plane in _planes(normals, data["segmentation"]):
        label = normals[plane].mean(axis=0)
        # the depth's one ray per pixel passes a random point of it, back-projected here at the
        # centre: one pixel's gradient normal scatters by ~9° about the plane's; their median does not
        derived = np.cross(along_x[plane], along_y[plane])
        derived /= np.linalg.norm(derived, axis=-1, keepdims=True)
        geometry = np.median(derived * np.sign(derived @ label)[:, None], axis=0)
        cosine = label @ geometry / np.linalg.norm(label) / np.linalg.norm(geometry)
        angles.append(math.degrees(math.acos(min(1.0, cosine))))
    assert len(angles) >= 3, angles  # the ground and faces of the objects
    assert max(angles) < 2.0, angles


def test_the_ground_normal_is_the_cameras_pitch(item):
    """The flat ground's normal is world up: in OpenCV camera axes of a camera pitched θ down,
    (0, −cos θ, −sin θ)."""
    _, folder = item
    data = read_item(folder, ("normals", "segmentation"))
    ground_id = next(row["id"] for row in data["meta"]["segmentation"]["instances"] if row["class"] == "ground")
    # less its 1-px rim: the segmentation's one ray per pixel is not the normals' (at an object's
    # silhouette the two can meet different surfaces)
    ground = data["normals"][ndimage.binary_erosion(data["segmentation"] == ground_id)]
    assert ground.shape[0] > 1000
    theta = math.radians(-PITCH_DEG)
    expected = np.array([0.0, -math.cos(theta), -math.sin(theta)])
    assert np.degrees(np.arccos(np.clip(ground @ expected, -1, 1))).max() < 0.05


def test_normals_in_the_label_preview(item):
    out, _ = item
    path = write_label_preview(out)
    assert path is not None and path.stat().st_size > 0
