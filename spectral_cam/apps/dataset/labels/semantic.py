"""The ``semantic`` label: 16-bit class ids of the pinhole view (classes.json names them).

References
----------
.. [1] Cordts, M., et al. (2016). The Cityscapes dataset. CVPR (class-id PNGs, 0 unlabelled).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .classes import sky_visible
from .files import read_image, write_png16
from .item import Item
from .registry import LABELS


@LABELS.register("semantic", options=("semantic",),
                 description="semantic.png: per pixel, the 16-bit class id (classes.json at the dataset root) of "
                             "the object its ray meets through an ideal pinhole (the segmentation's view): the "
                             "segmentation's instance ids looked up in their classes; 0: unlabelled (no surface; "
                             "under a sun and sky or overcast sky those rays are class sky)",
                 files=("semantic.png",), reader=lambda p: {"semantic": read_image(p)}, bytes_per_pixel=2.0)
def _semantic(item: Item, folder: Path) -> list[Path]:
    t0 = time.perf_counter()
    ids, objects = item.instances
    classes = objects.class_of[ids]
    sky = next(entry["id"] for entry in item.class_map if entry["name"] == "sky")
    if sky_visible(item.config):
        classes[ids == 0] = sky
    path = write_png16(classes, folder / "semantic.png")
    counts = np.bincount(classes.ravel())
    item.records["semantic"] = {
        "file": "semantic.png", "dtype": "uint16", "unlabelled_id": 0, "classes_file": "classes.json",
        "sky": "rays that leave the scene are class sky" if sky_visible(item.config) else
               "rays that leave the scene are 0 (no sky in this scene)",
        "class_pixels": {str(k): int(n) for k, n in enumerate(counts) if n and k}}
    item.timings["semantic"] = time.perf_counter() - t0
    return [path]
