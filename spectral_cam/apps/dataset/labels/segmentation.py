"""The ``segmentation`` label: 16-bit instance ids of the pinhole view, the instance table in meta.json.

References
----------
.. [1] COCO data format, https://cocodataset.org/#format-data (``bbox``, ``area``).
"""

from __future__ import annotations

import time
from pathlib import Path

from .files import read_image, write_png16
from .instances import VISIBILITY_NOTE, instance_boxes
from .item import Item
from .registry import LABELS


@LABELS.register("segmentation", options=("segmentation",),
                 description="segmentation.png: per pixel, the 16-bit instance id of the object its ray meets "
                             "through an ideal pinhole (the all-in-focus view; 0: nothing); the parts of one object "
                             "(a cylinder's tube and top, a table's legs) are one instance, each dead_leaves disc its "
                             "own; meta.json lists each object that shows with its class and class_id (classes.json), "
                             "category, parts, material, reflectance source, pixels, bbox [x, y, w, h] px, truncation, "
                             "amodal pixels and visible fraction",
                 files=("segmentation.png",), reader=lambda p: {"segmentation": read_image(p)}, bytes_per_pixel=2.0)
def _segmentation(item: Item, folder: Path) -> list[Path]:
    t0 = time.perf_counter()
    ids, objects = item.instances
    path = write_png16(ids, folder / "segmentation.png")
    boxes = instance_boxes(ids, len(objects.records))
    hidden = {"pixels": 0, "bbox": None, "truncated": None}
    amodal = item.amodal
    table = []
    for k, record in enumerate(objects.records, start=1):
        if k not in boxes and record.get("leaf"):
            continue  # a dead-leaves disc is listed where it shows
        shown = boxes.get(k, hidden)
        behind = None if amodal is None else int(max(amodal[k], shown["pixels"]))
        table.append({"id": k, **record, "pixels": shown["pixels"], "area": shown["pixels"], "bbox": shown["bbox"],
                      "truncated": shown["truncated"], "amodal_pixels": behind,
                      "visible_fraction": shown["pixels"] / behind if behind else None})
    item.records["segmentation"] = {
        "file": "segmentation.png", "dtype": "uint16", "background_id": 0, "pixels_unlabelled": int((ids == 0).sum()),
        "view": "ideal pinhole through the frame (the all-in-focus view), one ray per pixel through a random "
                "point of it (as the depth label's)",
        "classes": "classes.json at the dataset root (class_id: its id)", "visibility": VISIBILITY_NOTE,
        "bbox": "[x, y, width, height] px, pixel (c, r) covering [c, c + 1) x [r, r + 1) (COCO)",
        "instances": table}
    item.timings["segmentation"] = time.perf_counter() - t0
    return [path]
