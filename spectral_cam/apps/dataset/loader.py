"""Reading a generated dataset back: an item's files as NumPy arrays (:func:`read_item`), and
the dataset as a map-style sequence (:class:`SyntheticDataset`) whose items PyTorch's
``DataLoader`` batches with its default collate (a map-style dataset is anything with
``__len__`` and ``__getitem__``).

Each label becomes one or more keys of :func:`read_item`'s item, read by the label's own reader
(its :data:`~spectral_cam.apps.dataset.labels.LABELS` entry; units as the dataset card and
docs/design.md, "Dataset layouts", state them):

==================  ==========================================================================
key                 value
==================  ==========================================================================
``raw``             (H + 2m, W + 2m) uint16 CFA mosaic of raw.dng (m: the crop margin)
``image``           (H, W, 3) uint8 (or uint16) sRGB of image.png, RGB order
``all_in_focus``    the same for all_in_focus.png
``depth``           (H, W) float32 camera-space z, m (inf where nothing was hit)
``defocus``         (H, W) float32 signed thin-lens CoC diameter, px (+ behind focus)
``clean_rgb``       (H, W, 3) float32 noise-free linear camera RGB, 1 = white − black level (1 channel: mono)
``radiance``        (H, W, B) float32 spectral radiance per nm; ``radiance_nm``: the B wavelengths
``undistortion``    (H, W, 2) float32 cv2.remap maps (map_x, map_y)
``health``          (H, W, 2) float32 chlorophyll (µg/cm²) and health state
``segmentation``    (H, W) uint16 instance ids, one per object (0: nothing; meta["segmentation"] lists
                    each with its class_id, bbox and pixels)
``semantic``        (H, W) uint16 class ids (0: unlabelled; classes.json names them: :func:`read_classes`)
``coverage``        (H, W, 3) int32 ranked instance ids under defocus (0: none); ``coverage_fraction``
                    (H, W, 3) float32 their shares of the pixel's rays
``flow``            (H, W, 2) float32 forward flow over the exposure, px (x right, y down)
``normals``         (H, W, 3) float32 unit surface normals, camera space, OpenCV axes (x right, y down,
                    z forward), facing the camera; (0, 0, 0) where no surface
``albedo``          (H, W, 3) float32 reflectance as camera RGB under the light's white (white = 1);
                    ``albedo_srgb`` the same as linear sRGB (D65); ``shading`` (H, W) irradiance
                    relative to the reference white's; ``illuminance_lux`` (H, W) the illuminance
``illuminant_map``  (H, W, 3) float32 camera RGB (green 1) of the light at each pixel;
                    ``light_shares`` (H, W, N) each light's share (meta["illuminant_map"] names them)
``camera``          camera.json as a dict, ``K`` and the poses as NumPy arrays
``illuminant``      illuminant.json as a dict
``meta``            meta.json (sampled parameters under ``dataset.params``)
==================  ==========================================================================

:class:`SyntheticDataset` serves each item in a form PyTorch's default collate batches as it is
(:func:`batchable`): the label arrays (16-bit ones widened to int32, as torchvision decodes
16-bit PNGs: PyTorch's uint16 is a shell dtype that few operations take), ``camera`` as numbers
only (``K``, ``distortion``, the three poses, ``image_size``, focus, f-number, aperture, pitch,
exposure, ISO; NaN where an item has none), ``illuminant`` as numbers only (``camera_rgb``,
``xy``, ``cct_k``, ``duv``, ``illuminance_lux``), ``params`` (the sampled parameters: numbers,
strings, numeric lists as float64 arrays), ``index`` and ``id``. Nothing is None and every item of
one dataset has the same keys, so ``torch.utils.data.DataLoader(SyntheticDataset(DIR),
batch_size=4)`` batches items of one size without a ``collate_fn``; the records that do not
batch (meta.json, the whole camera.json and illuminant.json) are :meth:`SyntheticDataset.records`.
:class:`Crop` and :class:`Resize` make items of one size from any, and keep ``camera["K"]``
and the pixel-valued labels (defocus, flow, undistortion) consistent with the new pixels::

    import torch
    from torch.utils.data import DataLoader
    from spectral_cam.apps.dataset import Crop, Resize, SyntheticDataset

    data = SyntheticDataset("out/", labels=("image", "depth", "camera"), transform=[Resize(64, 96), Crop(64, 64)])
    for batch in DataLoader(data, batch_size=8, shuffle=True, num_workers=2):
        image = batch["image"].permute(0, 3, 1, 2).float() / 255     # (8, 3, 64, 64)
        depth, K = batch["depth"], batch["camera"]["K"]              # (8, 64, 64) m, (8, 3, 3) px

Nothing here imports torch (examples/dataset_pytorch.py trains a few steps of a small model).

References
----------
.. [1] PyTorch documentation, ``torch.utils.data``: map-style datasets.
.. [2] Hugging Face ``datasets``, "Create an image dataset" (ImageFolder with metadata.jsonl):
   the dataset folder's ``metadata.jsonl`` (:func:`spectral_cam.apps.dataset.card.write_metadata`).
.. [3] PyTorch ``torch/utils/data/_utils/collate.py``, ``default_collate``: NumPy arrays are stacked
   (equal shapes; no string or object dtypes), numbers become tensors, strings lists, dicts are
   collated key by key from the first item's keys; None is refused.
.. [4] Hartley, R. & Zisserman, A. (2004). Multiple View Geometry, 2nd ed., §6.1 (K under a change
   of image coordinates: a crop shifts the principal point, a scaling scales f and c).
.. [5] torchvision ``io.decode_png``: 16-bit PNGs decoded as int32.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np

from ...errors import RawFormatError
from .labels import LABELS

__all__ = ["SyntheticDataset", "read_item", "read_classes", "batchable", "Crop", "Resize", "LOADABLE_LABELS",
           "FRAME_LABELS"]

#: Labels :func:`read_item` reads (every dataset output with a reader, :data:`~.labels.LABELS`;
#: the images in whichever format was written). A label registered later is read too.
LOADABLE_LABELS = LABELS.loadable()


def _read(path: Path, reader: Callable[[Path], Any]) -> Any:
    """``reader(path)``, any failure (a corrupt JSON, EXR, PNG or DNG; a missing file) as one
    :class:`RawFormatError` naming the file."""
    try:
        return reader(path)
    except Exception as exc:  # json, OpenEXR, OpenCV and tifffile each raise their own types
        detail = str(exc).removeprefix(f"{path} ")
        raise RawFormatError(f"{path} cannot be read ({type(exc).__name__}: {detail})") from None


def read_item(folder: str | Path, labels: Iterable[str] | None = None) -> dict[str, Any]:
    """The arrays and records of one dataset item (see the module's table of keys).

    Parameters
    ----------
    folder : str or path-like
        An item folder (``DIR/items/000042``).
    labels : iterable of str, optional
        The labels to read (those of :data:`~.labels.LABELS` with a reader, :data:`LOADABLE_LABELS`
        and any registered since); default every label the item holds.
        ``meta`` is always included.

    Returns
    -------
    dict
        Label name → NumPy array or dict.

    Raises
    ------
    RawFormatError
        For a folder without meta.json, a label the item lacks, or an unreadable file (named).
    """
    folder = Path(folder)
    try:
        meta = json.loads((folder / "meta.json").read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise RawFormatError(f"{folder} is not a dataset item: its meta.json cannot be read ({exc})") from None
    files = list(meta.get("files", []))
    wanted = list(labels) if labels is not None else None
    loadable = LABELS.loadable()
    unknown = [name for name in (wanted or []) if name not in loadable]
    if unknown:
        raise RawFormatError(f"unknown label(s) {', '.join(unknown)}; valid: {', '.join(loadable)}")
    item: dict[str, Any] = {"meta": meta}
    for label in loadable:
        if wanted is not None and label not in wanted:
            continue
        entry = LABELS[label]
        path = entry.locate(folder, files)
        if path is not None:
            item.update(_read(path, entry.reader))
        if wanted is not None and label not in item:
            raise RawFormatError(f"{folder} has no {label!r} label; it holds {', '.join(files)}")
    return item


def read_classes(root: str | Path) -> dict[int, dict]:
    """A dataset's class map, ``classes.json`` at its root: class id → ``{"id", "name",
    "category", "colour" (sRGB 0–255), "pixels", "items", "instances", "description"}``, for the
    ids in ``semantic.png`` and the segmentation's ``class_id`` (0, unlabelled, is not listed).

    Raises
    ------
    RawFormatError
        For a folder without a readable classes.json (a dataset without segmentation or semantic
        labels has none).
    """
    path = Path(root) / "classes.json"
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
        return {int(entry["id"]): entry for entry in document["classes"]}
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise RawFormatError(f"{path} cannot be read ({type(exc).__name__}: {exc}); a dataset has it when its "
                             f"outputs include 'segmentation' or 'semantic'") from None


# ----------------------------------------------------------------------------- batchable items
#: camera.json's arrays in an item's batchable ``camera`` (shape, dtype), NaN-filled where absent.
_CAMERA_ARRAYS = {"K": ((3, 3), np.float64), "distortion": ((5,), np.float64),
                  "world_to_camera_opencv": ((4, 4), np.float64), "world_to_camera_opengl": ((4, 4), np.float64),
                  "camera_to_world_opencv": ((4, 4), np.float64), "image_size": ((2,), np.int64)}
#: camera.json's numbers in an item's batchable ``camera`` (NaN where the item has none).
_CAMERA_NUMBERS = ("focal_length_mm", "image_distance_mm", "f_number", "aperture_diameter_mm", "focus_distance_m",
                   "pixel_pitch_um", "exposure_s", "iso", "distortion_residual_px")
#: illuminant.json's values in an item's batchable ``illuminant`` (shape; () a number), NaN where absent.
_ILLUMINANT_VALUES = {"camera_rgb": (3,), "xy": (2,), "cct_k": (), "duv": (), "illuminance_lux": ()}


def _numbers(value: Any, shape: tuple, dtype=np.float64) -> np.ndarray | float:
    """``value`` as an array of ``shape`` (a float for ``()``); NaN (or −1 for whole numbers)
    where it is None, missing or of another shape, so every item has the same keys and shapes."""
    try:
        array = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError):
        array = None
    if array is None or array.shape != shape or value is None:
        array = np.full(shape, -1 if np.issubdtype(dtype, np.integer) else np.nan, dtype=dtype)
    return float(array) if shape == () else array


def _param(value: Any) -> Any:
    """A sampled parameter in a form default collate takes: numbers and strings as they are, a
    list of numbers as a float64 array, anything else as its JSON text."""
    if isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        return np.asarray(value, dtype=np.float64)
    return json.dumps(value, sort_keys=True)


def batchable(item: dict[str, Any]) -> dict[str, Any]:
    """A :func:`read_item` item in the form PyTorch's default collate batches.

    Label arrays stay (16-bit unsigned ones widened to int32, 32-bit unsigned to int64);
    ``camera`` and ``illuminant`` keep their numbers only, each key present in every item
    (NaN, or −1 for ``image_size``, where an item has none); ``meta`` is dropped (it is
    :meth:`SyntheticDataset.records`); ``params`` (when present) becomes numbers, strings and
    float64 arrays.

    Parameters
    ----------
    item : dict
        From :func:`read_item`.

    Returns
    -------
    dict
        No None, no dict of varying keys, no string or object arrays.

    References
    ----------
    .. [1] PyTorch ``torch/utils/data/_utils/collate.py``, ``default_collate``.
    .. [2] torchvision ``io.decode_png`` (16-bit PNGs as int32).
    """
    out: dict[str, Any] = {}
    for key, value in item.items():
        if key == "meta":
            continue
        if key == "camera":
            value = {**{name: _numbers(value.get(name), shape, dtype) for name, (shape, dtype) in _CAMERA_ARRAYS.items()},
                     **{name: _numbers(value.get(name), ()) for name in _CAMERA_NUMBERS}}
        elif key == "illuminant":
            value = {name: _numbers(value.get(name), shape) for name, shape in _ILLUMINANT_VALUES.items()}
        elif key == "params":
            value = {name: _param(v) for name, v in value.items()}
        elif isinstance(value, np.ndarray) and value.dtype in (np.uint16, np.uint32):
            value = value.astype(np.int32 if value.dtype == np.uint16 else np.int64)
        out[key] = value
    return out


# ----------------------------------------------------------------------------- transforms
#: Labels on the frame's pixel grid and how a resize resamples each: "area" (radiometric values:
#: averaging is what a larger pixel would have collected; linear when enlarging) or "nearest"
#: (per-surface values: an average of two surfaces' depths, ids or flows belongs to neither).
FRAME_LABELS = {
    "image": "area", "all_in_focus": "area", "clean_rgb": "area", "radiance": "area", "albedo": "area",
    "albedo_srgb": "area", "shading": "area", "illuminance_lux": "area", "illuminant_map": "area",
    "light_shares": "area", "depth": "nearest", "defocus": "nearest", "segmentation": "nearest", "semantic": "nearest",
    "normals": "nearest", "coverage": "nearest", "coverage_fraction": "nearest", "health": "nearest", "flow": "nearest",
    "undistortion": "nearest",
}


def _frame_shape(item: Mapping[str, Any]) -> tuple[int, int]:
    if "raw" in item:
        raise ValueError("a crop or resize does not apply to the RAW mosaic (its CFA phase and crop margin); "
                         "leave 'raw' out of labels= when transforming, or transform it yourself")
    shapes = {tuple(np.shape(item[key])[:2]) for key in FRAME_LABELS if key in item}
    if len(shapes) != 1:
        raise ValueError(f"a crop or resize needs frame-shaped labels of one size; this item holds "
                         f"{sorted(shapes) or 'none'} (labels: {', '.join(sorted(item))})")
    return shapes.pop()


class Crop:
    """Cut a window out of every frame-shaped label of a :func:`batchable` item, keeping
    ``camera["K"]`` (principal point minus the window's corner), ``camera["image_size"]`` and
    the undistortion map's coordinates consistent with the window's pixels.

    Parameters
    ----------
    height, width : int
        The window, pixels (at most the frame's).
    position : {"centre", "random"}
        The frame's centre (odd margins: the extra pixel at the bottom and right), or a
        uniformly random corner per call.
    seed : int, optional
        Seed of the random corners (a fresh NumPy generator per :class:`Crop`).

    Raises
    ------
    ValueError
        For a window larger than the frame, or an item holding ``raw``.

    References
    ----------
    .. [1] Hartley, R. & Zisserman, A. (2004). Multiple View Geometry, 2nd ed., §6.1.
    """

    def __init__(self, height: int, width: int, *, position: str = "centre", seed: int | None = None):
        if not all(isinstance(v, int) and not isinstance(v, bool) and v >= 1 for v in (height, width)):
            raise ValueError(f"Crop({height!r}, {width!r}): height and width must be whole numbers >= 1 (pixels)")
        if position not in ("centre", "random"):
            raise ValueError(f"Crop position {position!r}: use 'centre' or 'random'")
        self.height, self.width, self.position = height, width, position
        self._rng = np.random.default_rng(seed)

    def __call__(self, item: dict[str, Any]) -> dict[str, Any]:
        rows, cols = _frame_shape(item)
        if self.height > rows or self.width > cols:
            raise ValueError(f"Crop({self.height}, {self.width}) is larger than the {rows} × {cols} px frame; "
                             f"resize first (Resize) or crop at most the frame")
        if self.position == "random":
            top = int(self._rng.integers(0, rows - self.height, endpoint=True))
            left = int(self._rng.integers(0, cols - self.width, endpoint=True))
        else:
            top, left = (rows - self.height) // 2, (cols - self.width) // 2
        out = dict(item)
        window = (slice(top, top + self.height), slice(left, left + self.width))
        for key in FRAME_LABELS:
            if key in out:
                out[key] = np.ascontiguousarray(out[key][window])
        if "undistortion" in out:  # source coordinates in the cropped image
            out["undistortion"] = out["undistortion"] - np.array([left, top], dtype=out["undistortion"].dtype)
        if "camera" in out:
            camera = dict(out["camera"])
            K = np.array(camera["K"], dtype=np.float64)
            K[0, 2] -= left
            K[1, 2] -= top
            camera["K"], camera["image_size"] = K, np.array([self.width, self.height], dtype=np.int64)
            out["camera"] = camera
        return out


class Resize:
    """Resample every frame-shaped label of a :func:`batchable` item to ``height`` × ``width``,
    keeping the intrinsics and the pixel-valued labels consistent with the new pixels.

    With scale factors s_x = width / W and s_y = height / H and pixel centres at integers (the
    camera.json convention), a point at column u moves to (u + ½)·s_x − ½: K's f_x and c_x
    follow (f_x s_x, (c_x + ½) s_x − ½), and the same for y. Flow (px) scales by (s_x, s_y),
    the undistortion map's coordinates move like u, the defocus CoC diameter (px) scales by
    s (an anisotropic resize is refused for it: a circle would become an ellipse), and
    ``pixel_pitch_um`` by 1/s. Radiometric labels are area-averaged when shrinking (linear when
    enlarging), per-surface ones (depth, defocus, ids, flow, shares of coverage, health) take
    the nearest pixel (:data:`FRAME_LABELS`), with OpenCV's ``resize``.

    Parameters
    ----------
    height, width : int
        The new frame, pixels.

    Raises
    ------
    ValueError
        For an item holding ``raw``, or ``defocus`` under an anisotropic resize.

    References
    ----------
    .. [1] Hartley, R. & Zisserman, A. (2004). Multiple View Geometry, 2nd ed., §6.1.
    .. [2] OpenCV ``cv::resize`` (INTER_AREA, INTER_LINEAR, INTER_NEAREST).
    """

    def __init__(self, height: int, width: int):
        if not all(isinstance(v, int) and not isinstance(v, bool) and v >= 1 for v in (height, width)):
            raise ValueError(f"Resize({height!r}, {width!r}): height and width must be whole numbers >= 1 (pixels)")
        self.height, self.width = height, width

    def __call__(self, item: dict[str, Any]) -> dict[str, Any]:
        import cv2

        rows, cols = _frame_shape(item)
        sx, sy = self.width / cols, self.height / rows
        isotropic = abs(sx - sy) <= 1e-9 * max(sx, sy)
        if "defocus" in item and not isotropic:
            raise ValueError(f"Resize({self.height}, {self.width}) of a {rows} × {cols} px frame scales x by {sx:.4g} "
                             f"and y by {sy:.4g}: the defocus label's circle would become an ellipse; crop to the "
                             f"aspect {self.width}:{self.height} first (Crop), or leave 'defocus' out")
        out = dict(item)
        for key, kind in FRAME_LABELS.items():
            if key in out:
                out[key] = _resample(np.asarray(out[key]), self.height, self.width,
                                     cv2.INTER_NEAREST if kind == "nearest" else
                                     cv2.INTER_AREA if sx * sy < 1 else cv2.INTER_LINEAR)
        scale = np.array([sx, sy], dtype=np.float32)
        if "flow" in out:
            out["flow"] = out["flow"] * scale
        if "undistortion" in out:
            out["undistortion"] = (out["undistortion"] + 0.5) * scale - 0.5
        if "defocus" in out:
            out["defocus"] = out["defocus"] * np.float32(sx)
        if "camera" in out:
            out["camera"] = _scaled_camera(out["camera"], sx, sy, self.width, self.height, isotropic)
        return out


def _resample(array: np.ndarray, height: int, width: int, interpolation: int) -> np.ndarray:
    """OpenCV's resize of an (H, W[, C]) array of any channel count and dtype (integer arrays
    interpolated in float32 and rounded back; a trailing single channel kept)."""
    import cv2

    dtype = array.dtype
    work = array.astype(np.float32) if interpolation != cv2.INTER_NEAREST and dtype.kind in "iub" else array
    resized = cv2.resize(work, (width, height), interpolation=interpolation)
    resized = resized.reshape((height, width) + array.shape[2:])
    return np.rint(resized).astype(dtype) if resized.dtype != dtype else resized


def _scaled_camera(camera: Mapping[str, Any], sx: float, sy: float, width: int, height: int,
                   isotropic: bool) -> dict:
    out = dict(camera)
    K = np.array(camera["K"], dtype=np.float64)
    K[0, 0], K[0, 1], K[0, 2] = K[0, 0] * sx, K[0, 1] * sx, (K[0, 2] + 0.5) * sx - 0.5
    K[1, 1], K[1, 2] = K[1, 1] * sy, (K[1, 2] + 0.5) * sy - 0.5
    out["K"], out["image_size"] = K, np.array([width, height], dtype=np.int64)
    if "pixel_pitch_um" in out:  # one pitch: the new pixel's, where the scale is one number
        out["pixel_pitch_um"] = float(out["pixel_pitch_um"]) / sx if isotropic else float("nan")
    return out


def _compose(transform: Callable | Sequence[Callable] | None) -> Callable | None:
    if transform is None or callable(transform):
        return transform
    steps = tuple(transform)
    if not all(callable(step) for step in steps):
        raise TypeError(f"transform must be a callable or a sequence of callables; got {transform!r}")

    def composed(item):
        for step in steps:
            item = step(item)
        return item

    return composed


class SyntheticDataset:
    """The finished items of a dataset folder, in index order, as a map-style dataset whose
    items PyTorch's default collate batches.

    Parameters
    ----------
    root : str or path-like
        The dataset folder (``spectral-cam dataset ... -o DIR``): its ``manifest.jsonl`` lists
        the items; those done are served.
    labels : iterable of str, optional
        What each item holds (:data:`LOADABLE_LABELS`); default everything written.
    transform : callable or sequence of callables, optional
        Applied to each :func:`batchable` item in order (e.g. ``[Resize(64, 96), Crop(64, 64)]``,
        then a function making tensors).

    Examples
    --------
    A dataset written by ``spectral-cam dataset spec.toml -n 100 -o out``::

        data = SyntheticDataset("out/", labels=("image", "depth", "camera"))
        item = data[0]     # item["image"]: (H, W, 3) uint8, item["depth"]: (H, W) float32 metres,
                           # item["camera"]["K"]: (3, 3) px; data.records(0)["meta"]: meta.json
        # torch.utils.data.DataLoader(data, batch_size=4): batch["image"] (4, H, W, 3) uint8 ...
    """

    def __init__(self, root: str | Path, *, labels: Iterable[str] | None = None,
                 transform: Callable | Sequence[Callable] | None = None):
        self.root = Path(root)
        manifest = self.root / "manifest.jsonl"
        try:
            rows = [json.loads(line) for line in manifest.read_text(encoding="utf-8").splitlines() if line.strip()]
        except (OSError, ValueError) as exc:
            raise RawFormatError(f"{self.root} is not a dataset folder: {manifest.name} cannot be read ({exc})") from None
        self.rows = [row for row in sorted(rows, key=lambda r: r["index"]) if row.get("status") == "done"]
        self.labels = None if labels is None else tuple(labels)
        self.transform = _compose(transform)

    def __len__(self) -> int:
        return len(self.rows)

    def _read(self, index: int, labels) -> dict[str, Any]:
        if not -len(self) <= index < len(self):
            raise IndexError(f"item {index} of a dataset of {len(self)} finished items")
        row = self.rows[index]
        try:
            return read_item(self.root / "items" / row["id"], labels)
        except RawFormatError as exc:
            raise RawFormatError(
                f"dataset {self.root}, item {row['id']} (index {index}): {exc}. The file was damaged or changed "
                f"after it was written: rerun the same `spectral-cam dataset` command with -o {self.root} (its "
                f"size and SHA-256 no longer match what meta.json records, so the item is rendered again), or "
                f"delete items/{row['id']} and rerun") from None

    def __getitem__(self, index: int):
        item = self._read(index, self.labels)
        row = self.rows[index]
        item["params"] = row.get("params") or {}
        item = batchable(item)
        item["index"], item["id"] = int(row["index"]), str(row["id"])
        return self.transform(item) if self.transform is not None else item

    def records(self, index: int) -> dict[str, Any]:
        """What does not batch: ``meta`` (meta.json), and the whole ``camera`` (camera.json)
        and ``illuminant`` (illuminant.json) where the item holds them."""
        wanted = ["camera", "illuminant"]
        files = set(self._read(index, []).get("meta", {}).get("files", []))
        present = [label for label in wanted if LABELS[label].locate(self.root, files) is not None]
        return self._read(index, present)

    @property
    def classes(self) -> dict[int, dict]:
        """The dataset's class map (:func:`read_classes`): class id → name, category, colour …"""
        return read_classes(self.root)

    def params(self, index: int) -> dict:
        """The parameters sampled for an item (its manifest row's ``params``), as the spec drew them."""
        return dict(self.rows[index].get("params") or {})
