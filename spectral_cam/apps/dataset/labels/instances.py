"""The objects of an item's scene: shapes merged per object (:class:`Instances`), their boxes
(:func:`instance_boxes`), amodal masks (:func:`amodal_pixels`) and the coverage label's ranks
merged per object (:func:`merge_ranks`).

References
----------
.. [1] COCO data format, https://cocodataset.org/#format-data (``bbox``).
.. [2] Geiger, A., et al. (2013). Vision meets robotics: the KITTI dataset. IJRR ("truncated").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ....render.depth import AMODAL_LAYERS
from ....scene import SceneConfig
from .classes import _shape_class_and_instance, _tabletop_kinds, _user_classes, shape_reflectance

__all__ = ["Instances", "shape_layers", "amodal_pixels", "instance_boxes", "merge_ranks", "VISIBILITY_NOTE"]


@dataclass
class Instances:
    """The objects of an item's scene: the shapes merged per object (:data:`SHAPE_RULES`).

    Attributes
    ----------
    of_shape : numpy.ndarray
        (S + 1,) instance id of each shape index, the last for −1 (no shape): 0.
    records : list of dict
        Per instance id 1…: ``name`` (the object's), ``class``, ``class_id``, ``category``,
        ``parts`` (its shapes' names) and the first part's ``material``, ``reflectance``.
    class_of : numpy.ndarray
        (M + 1,) class id of each instance id (0: 0).
    """

    of_shape: np.ndarray
    records: list
    class_of: np.ndarray

    @classmethod
    def of(cls, config: SceneConfig, lens, shapes: Sequence[Mapping], table: Sequence[Mapping]) -> "Instances":
        """Group ``shapes`` (:func:`spectral_cam.render.render_shape_map`'s records) into objects,
        each classed by ``table`` (:func:`class_table`)."""
        by_name = {entry["name"]: entry for entry in table}
        user = {name: name for category, name in _user_classes(config) if name in by_name}
        kinds = _tabletop_kinds(config, lens)
        keys: dict[str, int] = {}
        records: list[dict] = []
        of_shape = np.zeros(len(shapes) + 1, np.int64)
        for k, shape in enumerate(shapes):
            name, key = _shape_class_and_instance(config, shape["name"], user, kinds)
            entry = by_name.get(name, by_name["other"])
            if key not in keys:
                keys[key] = len(records) + 1
                records.append({"name": key, "class": entry["name"], "class_id": entry["id"],
                                "category": entry["category"], "parts": [], "material": shape.get("material"),
                                "reflectance": shape.get("reflectance") or shape_reflectance(config, shape["name"]),
                                **{f: shape[f] for f in ("depth_m", "radius_px", "leaf") if f in shape}})
            records[keys[key] - 1]["parts"].append(shape["name"])
            of_shape[k] = keys[key]
        class_of = np.array([0] + [r["class_id"] for r in records], np.int64)
        return cls(of_shape=of_shape, records=records, class_of=class_of)

    def ids(self, shape_index: np.ndarray) -> np.ndarray:
        """Instance ids (0: none) of shape indices (−1: none)."""
        return self.of_shape[np.asarray(shape_index)]


def shape_layers(config: SceneConfig, lens) -> np.ndarray | None:
    """The shapes each pixel's pinhole ray passes through: (H, W, AMODAL_LAYERS) indices into
    :func:`spectral_cam.render.render_shape_map`'s shapes, nearest first (−1: none), on the
    segmentation's own rays (:func:`spectral_cam.render.render_shape_layer_map`); None in
    Mitsuba's scalar variants."""
    from ....render import render_shape_layer_map

    return render_shape_layer_map(config, lens=lens)


def amodal_pixels(layers: np.ndarray, objects: "Instances") -> np.ndarray:
    """Pixels of each instance id's amodal mask (0…M): those whose ray passes through any of its
    shapes, each pixel counted once per instance (a closed object is met twice)."""
    ids = np.sort(objects.ids(layers), axis=-1)
    first = np.ones(ids.shape, bool)
    first[..., 1:] = ids[..., 1:] != ids[..., :-1]
    return np.bincount(ids[first & (ids > 0)], minlength=len(objects.records) + 1)


def instance_boxes(ids: np.ndarray, count: int) -> dict[int, dict]:
    """Pixel count, box and truncation of each instance id 1…``count`` that shows in ``ids``.

    Returns
    -------
    dict
        id → ``{"pixels", "bbox": [x, y, width, height] (px; pixel (c, r) covers [c, c+1) ×
        [r, r+1), COCO's convention), "truncated": whether the mask touches the frame's edge}``.

    References
    ----------
    .. [1] COCO data format, https://cocodataset.org/#format-data (``bbox``).
    .. [2] Geiger, A., et al. (2013). Vision meets robotics: the KITTI dataset. IJRR ("truncated").
    """
    from scipy import ndimage

    counts = np.bincount(ids.ravel(), minlength=count + 1)
    height, width = ids.shape
    out = {}
    for k, window in enumerate(ndimage.find_objects(ids.astype(np.int64), max_label=count), start=1):
        if window is None:
            continue
        rows, cols = window
        out[k] = {"pixels": int(counts[k]),
                  "bbox": [float(cols.start), float(rows.start), float(cols.stop - cols.start),
                           float(rows.stop - rows.start)],
                  "truncated": bool(rows.start == 0 or cols.start == 0 or rows.stop == height or cols.stop == width)}
    return out


#: What the instance table's visibility fields mean.
VISIBILITY_NOTE = (f"amodal_pixels: the pixels whose pinhole ray passes through the object (its occlusion-free mask "
                   f"inside the frame; rays followed through their first {AMODAL_LAYERS} surfaces); visible_fraction = "
                   "pixels / amodal_pixels (0: wholly hidden behind others; null where no ray meets it, outside "
                   "the frame, or in Mitsuba's scalar variants, which trace no amodal masks); truncated: the mask "
                   "touches the frame's edge (the object may go on outside it, which no fraction counts); an object "
                   "that no pixel shows has pixels 0 and bbox null")


def merge_ranks(ids: np.ndarray, coverage: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ranked (ids, coverage) per pixel with the ranks of one instance summed (two parts of one
    object: one instance) and re-ranked, most coverage first; an emptied rank is id 0, coverage 0."""
    ranks = ids.shape[-1]
    merged = coverage.astype(np.float32).copy()
    for a in range(ranks):
        for b in range(a + 1, ranks):
            same = (ids[..., a] == ids[..., b]) & (ids[..., a] > 0)
            merged[..., a] += np.where(same, merged[..., b], 0.0)
            merged[..., b] = np.where(same, 0.0, merged[..., b])
    ids = np.where(merged > 0, ids, 0)
    order = np.argsort(-merged, axis=-1, kind="stable")
    return np.take_along_axis(ids, order, -1), np.take_along_axis(merged, order, -1)

