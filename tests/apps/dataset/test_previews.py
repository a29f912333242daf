"""Issue 40 #6: a label preview grid per dataset (image, depth, segmentation, defocus for the first
items), written with the card and linked from it; depth on matplotlib's viridis at the colour
bar's scale in metres, ids in distinct colours."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.apps.dataset import generate_dataset, spec_from_dict
from spectral_cam.apps.dataset.sheets import id_colours, write_label_preview

from .reading import read_png

pytestmark = pytest.mark.timeout(300)

DEPTHS_M = [1.0, 2.0, 4.0]
SPEC = {
    "dataset": {"seed": 4, "outputs": ["image", "depth", "segmentation", "defocus"]},
    "scene": {"preset": "dof_targets", "depths_m": DEPTHS_M},
    "sensor": {"width_px": 48, "height_px": 32},
    "render": {"spp": 2},
    "lens": {"focal_length_mm": 25.0, "f_number": 4.0, "focus_distance_m": {"uniform": [1.5, 3.0]}},
}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("previews") / "data"
    generate_dataset(spec_from_dict(SPEC), out, n=2, scheduler="inline", progress=False)
    return out


def _blocks_of(picture: np.ndarray, rgb: np.ndarray, *, tolerance: int = 2) -> int:
    """Pixels of ``picture`` (H, W, 3 uint8) within ``tolerance`` levels of the colour ``rgb`` (0–1)."""
    target = np.round(np.asarray(rgb) * 255).astype(int)
    return int(np.all(np.abs(picture.astype(int) - target) <= tolerance, axis=-1).sum())


def test_the_preview_is_written_with_the_card_and_linked_from_it(dataset):
    card = (dataset / "README.md").read_text()
    assert (dataset / "label_preview.png").is_file()
    assert "](label_preview.png)" in card and "## Previews" in card


def test_depth_planes_appear_in_viridis_at_their_metres(dataset):
    """The targets' planes at 1, 2 and 4 m, one scale for every row from 1 to 4 m: viridis at 0,
    1/3 and 1 (matplotlib's map, not ours), each a block of the two items' depth panels."""
    import matplotlib

    picture = read_png(dataset / "label_preview.png")[..., 2::-1]
    viridis = matplotlib.colormaps["viridis"]
    for depth in DEPTHS_M:
        colour = viridis((depth - DEPTHS_M[0]) / (DEPTHS_M[-1] - DEPTHS_M[0]))[:3]
        assert _blocks_of(picture, colour) > 400, depth  # the plane's band on both rows (48 × 32 px items, enlarged)


def test_segmentation_ids_take_distinct_colours_and_nothing_is_black():
    import colour

    ids = np.arange(0, 25)
    rgb = id_colours(ids)
    np.testing.assert_array_equal(rgb[0], 0.0)
    lab = colour.XYZ_to_Lab(colour.sRGB_to_XYZ(rgb[1:]))
    neighbours = colour.delta_E(lab[:-1], lab[1:], method="CIE 2000")  # ids side by side on a segmentation
    assert neighbours.min() > 15, neighbours.min()
    pairs = colour.delta_E(lab[:, None], lab[None, :], method="CIE 2000")[np.triu_indices(len(lab), 1)]
    assert pairs.min() > 2, pairs.min()  # no two of 24 ids alike
    table = {3: [10, 200, 30]}
    np.testing.assert_allclose(id_colours(np.array([[3, 0]]), table)[0, 0], np.array([10, 200, 30]) / 255)


def test_segmentation_panels_show_each_instance_in_its_colour(dataset):
    picture = read_png(dataset / "label_preview.png")[..., 2::-1]
    ids = np.unique(read_png(dataset / "items" / "000000" / "segmentation.png"))
    for value in ids[ids > 0]:
        assert _blocks_of(picture, id_colours(np.array([value]))[0]) > 100, value


def test_no_items_no_preview(tmp_path):
    (tmp_path / "manifest.jsonl").write_text('{"index": 0, "id": "000000", "status": "failed", "files": []}\n')
    assert write_label_preview(tmp_path) is None and not (tmp_path / "label_preview.png").exists()
