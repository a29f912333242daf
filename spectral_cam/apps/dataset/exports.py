"""A generated dataset in the files other tools train and evaluate with (issue 40 #4): COCO
instances (:func:`export_coco`), 16-bit depth PNGs (:func:`export_depth_png`, one frame:
:func:`write_depth_png`) and Middlebury ``.flo`` optical flow (:func:`export_flo`, one frame:
:func:`write_flo`). Each reads the labels through :func:`~.loader.read_item` and writes its
result whole or not at all (a JSON file through :func:`~spectral_cam.io.atomic_path`, a folder
through :func:`~spectral_cam.io.staged_directory`); :data:`EXPORTS` names them for
``spectral-cam export DATASET --format NAME -o OUT``, and a dataset run writes those its spec's
``[dataset] exports`` names into ``DIR/exports/`` (:func:`export_into_dataset`).

Surface normals need no export: the ``normals`` label is already the common form (camera-space
unit normals as float EXR, OpenCV axes, and an 8-bit PNG of (n + 1) / 2).

References
----------
.. [1] Lin, T.-Y., et al. (2014). Microsoft COCO: Common Objects in Context. ECCV; the data format,
   https://cocodataset.org/#format-data (object detection: ``images``, ``annotations`` with
   ``segmentation`` as polygons or RLE, ``area``, ``bbox`` [x, y, width, height], ``iscrowd``,
   ``categories``), and ``pycocotools/mask.py`` (RLE: run lengths of the column-major mask,
   starting with a run of zeros).
.. [2] Uhrig, J., et al. (2017). Sparsity Invariant CNNs. 3DV; the KITTI depth devkit: uint16
   PNG, depth = value / 256 m, 0 = no measurement.
.. [3] Silberman, N., et al. (2012). Indoor Segmentation and Support Inference from RGBD Images
   (NYU Depth v2). ECCV; its toolbox and most loaders store depth as uint16 millimetres.
.. [4] Baker, S., et al. (2011). A Database and Evaluation Methodology for Optical Flow. IJCV
   92(1), 1–31; the Middlebury ``.flo`` format (flow-code/README.txt): the float 202021.25
   ('PIEH' in little-endian bytes), int32 width, int32 height, then u, v float32 interleaved
   row by row; values over 1e9 are unknown flow.
"""

from __future__ import annotations

import datetime
import json
from fractions import Fraction
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import ConfigError, RawFormatError
from ...io import atomic_path, staged_directory
from ...registry import Registry
from .loader import SyntheticDataset, read_classes, read_item

__all__ = ["EXPORTS", "EXPORT_LABELS", "EXPORT_TARGETS", "EXPORTS_DIR", "export", "export_into_dataset",
           "check_exports", "exported", "export_coco", "export_depth_png", "export_flo", "write_depth_png",
           "read_depth_png", "write_flo", "read_flo", "mask_to_rle", "DEPTH_SCALES"]

#: Every export format: name → ``function(dataset_dir, out, *, force=False, **options)``.
EXPORTS = Registry("export format")
#: The label each format reads: format → ``[dataset] outputs`` name (filled by :func:`_export`).
EXPORT_LABELS: dict[str, str] = {}
#: Where a dataset run writes each format, relative to :data:`EXPORTS_DIR` (filled by :func:`_export`).
EXPORT_TARGETS: dict[str, str] = {}
#: The folder of a dataset holding the exports its spec names (``[dataset] exports``).
EXPORTS_DIR = "exports"


def _export(name: str, *, reads: str, target: str, options: tuple[str, ...] = (), description: str):
    """Register an export format in :data:`EXPORTS` with the label it reads and its place in a
    dataset folder."""
    def decorate(function):
        EXPORTS.add(name, function, options=options, description=description)
        EXPORT_LABELS[name], EXPORT_TARGETS[name] = reads, target
        return function

    return decorate

#: The two depth PNG conventions by name: metres per PNG unit.
DEPTH_SCALES = {"nyu_mm": 0.001, "kitti": 1.0 / 256.0}

#: The Middlebury .flo tag (202021.25 as a little-endian float32 is b"PIEH").
FLO_TAG = np.float32(202021.25)
#: Middlebury's "unknown flow" value (readers treat anything over 1e9 as unknown).
FLO_UNKNOWN = np.float32(1e10)


# ----------------------------------------------------------------------------- the dataset's items
def _finished_items(dataset_dir: str | Path, needs: tuple[tuple[str, str], ...]) -> list[tuple[dict, Path]]:
    """The dataset's finished items (manifest row, folder) in index order, after checking each
    holds every ``(label, file)`` of ``needs``; refuses a folder that is not a dataset, one
    without finished items, and a missing label (naming the items and the remedy)."""
    data = SyntheticDataset(dataset_dir)  # reads manifest.jsonl, or says the folder is not a dataset
    if not data.rows:
        raise ConfigError(f"{data.root} holds no finished item (manifest.jsonl lists none as done); "
                          f"finish it with `spectral-cam dataset SPEC -o {data.root}` first")
    items = [(row, data.root / "items" / str(row["id"])) for row in data.rows]
    for label, file in needs:
        lacking = [str(row["id"]) for row, _ in items
                   if not any(Path(name).name == file for name in row.get("files") or [])]
        if lacking:
            shown = ", ".join(lacking[:5]) + (f" and {len(lacking) - 5} more" if len(lacking) > 5 else "")
            raise ConfigError(f"{data.root}: {len(lacking)} of {len(items)} items have no {label!r} label "
                              f"({file}): {shown}; generate the dataset with {label!r} in [dataset] outputs")
    return items


def _label(folder: Path, label: str) -> dict[str, Any]:
    """One label of an item (and its meta.json), read by the package's loader; a file it cannot
    read is a :class:`RawFormatError` naming the item, the label and the remedy."""
    try:
        return read_item(folder, [label])
    except Exception as exc:  # OpenEXR and OpenCV raise their own types on a damaged file
        raise RawFormatError(f"{folder}: its {label!r} label cannot be read ({type(exc).__name__}: {exc}); the "
                             f"file was damaged after it was written: rerun the same `spectral-cam dataset` command "
                             f"with -o {folder.parent.parent} to render the item again") from None


def _check_output(out: Path, force: bool) -> None:
    if out.exists() and not force:
        raise ConfigError(f"{out} exists; pass --force (force=True) to replace it")


# ----------------------------------------------------------------------------- COCO
def mask_to_rle(mask: np.ndarray) -> dict:
    """A binary mask as COCO's uncompressed run-length encoding.

    Parameters
    ----------
    mask : (H, W) array of bool
        True on the object.

    Returns
    -------
    dict
        ``{"size": [H, W], "counts": [n0, n1, ...]}``: lengths of alternating runs of 0 and 1
        over the mask read column by column (Fortran order), the first a run of zeros (0 where
        the first pixel is set); ``pycocotools.mask.frPyObjects`` reads it.

    References
    ----------
    .. [1] COCO data format, https://cocodataset.org/#format-data ("RLE"); ``pycocotools/mask.py``.
    """
    mask = np.asarray(mask, dtype=bool)
    flat = mask.ravel(order="F")
    edges = np.flatnonzero(flat[1:] != flat[:-1]) + 1
    counts = np.diff(np.concatenate(([0], edges, [flat.size]))).tolist()
    if flat.size and flat[0]:
        counts = [0] + counts
    return {"size": [int(mask.shape[0]), int(mask.shape[1])], "counts": counts}


def _box(mask: np.ndarray) -> list[float]:
    """[x, y, width, height] of the pixels set, pixel (c, r) covering [c, c + 1) × [r, r + 1)."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    return [float(cols[0]), float(rows[0]), float(cols[-1] - cols[0] + 1), float(rows[-1] - rows[0] + 1)]


def _image_name(row: dict, dataset: Path) -> str:
    for name in row.get("files") or []:
        if Path(name).stem == "image":
            return Path(name).as_posix()
    raise ConfigError(f"{dataset}: item {row['id']} has no developed image (image.png); COCO annotations need one: "
                      f"generate the dataset with 'image' in [dataset] outputs")


def _segmentation(folder: Path) -> tuple[np.ndarray, dict[int, dict]]:
    """An item's segmentation ids (H, W) and its instance table by id, each id that shows checked
    to be named."""
    item = _label(folder, "segmentation")
    ids = np.asarray(item["segmentation"])
    table = {int(entry["id"]): entry for entry in (item["meta"].get("segmentation") or {}).get("instances", [])}
    unnamed = [int(k) for k in np.unique(ids) if k != 0 and int(k) not in table]
    if unnamed:
        raise RawFormatError(f"{folder / 'segmentation.png'} holds instance id(s) {unnamed} that meta.json's "
                             f"segmentation.instances does not name; the item is damaged: render it again")
    return ids, table


def _class_map(dataset: Path, tables: list[dict[int, dict]]) -> dict[int, dict] | None:
    """classes.json's classes by id where the dataset has it and every instance names its
    class_id; None for a dataset from before classes.json (its categories are the instances'
    class names)."""
    if not (dataset / "classes.json").is_file():
        return None
    classes = read_classes(dataset)
    entries = [entry for table in tables for entry in table.values()]
    if any("class_id" not in entry for entry in entries):
        return None
    unknown = sorted({int(entry["class_id"]) for entry in entries if entry.get("pixels")} - set(classes))
    if unknown:
        raise RawFormatError(f"{dataset / 'classes.json'} does not list class id(s) {unknown} that the items' "
                             f"segmentation names; rerun the same `spectral-cam dataset` command with -o {dataset} "
                             f"to write it again")
    return classes


def coco_instances(dataset_dir: str | Path) -> dict:
    """The dataset's segmentation as a COCO instances document (see :func:`export_coco`)."""
    items = _finished_items(dataset_dir, (("segmentation", "segmentation.png"),))
    dataset = Path(dataset_dir)
    labels = [(row, folder, *_segmentation(folder)) for row, folder in items]
    class_map = _class_map(dataset, [table for *_, table in labels])
    images, annotations, classes = [], [], {}  # classes: name -> supercategory
    for row, folder, ids, table in labels:
        image_id = int(row["index"]) + 1  # COCO's ids start at 1 (pycocotools' matching takes 0 as "none")
        file_name = _image_name(row, dataset)
        images.append({"id": image_id, "file_name": file_name, "width": int(ids.shape[1]),
                       "height": int(ids.shape[0]), "item_id": str(row["id"]), "dataset_index": int(row["index"])})
        for k in (int(k) for k in np.unique(ids) if k != 0):
            entry, mask = table[k], ids == k
            classes.setdefault(str(entry["class"]), str(entry.get("category") or "shape"))
            annotations.append({
                "id": len(annotations) + 1, "image_id": image_id,
                "category_id": str(entry["class"]) if class_map is None else int(entry["class_id"]),
                "segmentation": mask_to_rle(mask), "area": int(mask.sum()), "bbox": _box(mask), "iscrowd": 0,
                "instance_id": k, "name": str(entry["name"])})
    if class_map is None:  # a dataset from before classes.json: ids 1… in name order
        category_ids = {name: k for k, name in enumerate(sorted(classes), start=1)}
        for annotation in annotations:
            annotation["category_id"] = category_ids[annotation["category_id"]]
        categories = [{"id": category_ids[name], "name": name, "supercategory": classes[name]}
                      for name in sorted(classes)]
    else:  # classes.json's ids and categories: the semantic map's, the same in every item
        categories = [{"id": k, "name": entry["name"], "supercategory": entry["category"]}
                      for k, entry in sorted(class_map.items()) if entry.get("instances")]
    today = datetime.date.today()
    return {
        "info": {"description": f"spectral_cam synthetic dataset {dataset.resolve().name}: the instances of its "
                                f"segmentation label (each item's all-in-focus pinhole view)",
                 "version": "1.0", "year": today.year, "date_created": today.isoformat(),
                 "url": "https://cocodataset.org/#format-data"},
        "licenses": [],
        "images": images,
        "annotations": annotations,
        "categories": categories,
    }


@_export("coco", reads="segmentation", target="coco.json", description="COCO instances JSON (RLE masks, boxes, areas, categories) of the "
                                      "segmentation label; OUT is the .json file")
def export_coco(dataset_dir: str | Path, out_path: str | Path, *, force: bool = False) -> Path:
    """Write the dataset's segmentation as COCO instances (object detection and instance
    segmentation), one JSON file.

    One ``images`` entry per finished item: ``id`` = dataset index + 1, ``file_name`` the
    developed image relative to the dataset folder (the image root), ``width``, ``height``,
    and ``item_id``, ``dataset_index``. One ``annotations`` entry per instance id that shows
    in the item's segmentation.png (0, nothing, is not one): ``segmentation`` as uncompressed
    RLE (:func:`mask_to_rle`), ``area`` its pixel count, ``bbox`` [x, y, w, h] px enclosing it,
    ``iscrowd`` 0, ``instance_id`` (segmentation.png's id) and ``name`` (the object's). An
    instance is one object, its parts merged (a cylinder's tube and top: one annotation).
    Categories are classes.json's classes that have instances, with its ids (the ids of
    semantic.png and of each instance's ``class_id``) and its categories as ``supercategory``;
    a dataset from before classes.json gets its instance table's class names, ids 1… in name
    order.

    Parameters
    ----------
    dataset_dir : str or path-like
        A dataset folder (``spectral-cam dataset SPEC -o DIR``) whose items hold ``segmentation``
        and ``image``.
    out_path : str or path-like
        The JSON file to write.
    force : bool
        Replace an existing ``out_path``.

    Returns
    -------
    pathlib.Path
        ``out_path``.

    Raises
    ------
    ConfigError
        For a folder without finished items, items lacking the labels, or an existing output.
    RawFormatError
        For a folder that is not a dataset, or a damaged item.

    References
    ----------
    .. [1] Lin, T.-Y., et al. (2014). Microsoft COCO: Common Objects in Context. ECCV;
       https://cocodataset.org/#format-data.
    """
    out_path = Path(out_path)
    _check_output(out_path, force)
    document = coco_instances(dataset_dir)  # everything read and checked before a byte is written
    with atomic_path(out_path) as tmp:
        tmp.write_text(json.dumps(document, separators=(",", ":")) + "\n", encoding="utf-8")
    return out_path


# ----------------------------------------------------------------------------- depth PNG
def _check_scale(scale_m: Any) -> float:
    try:
        scale = float(Fraction(str(scale_m))) if isinstance(scale_m, str) else float(scale_m)
    except (TypeError, ValueError, ZeroDivisionError):
        scale = float("nan")
    if not np.isfinite(scale) or scale <= 0:
        raise ConfigError(f"depth scale {scale_m!r}: give metres per PNG unit, a number > 0 (0.001: millimetres, "
                          f"NYU; 1/256: KITTI)")
    return scale


def depth_to_uint16(depth_m: np.ndarray, *, scale_m: float = 0.001) -> tuple[np.ndarray, dict]:
    """Depth in metres as uint16 units of ``scale_m`` metres (rounded to the nearest), 0 where
    there is none: non-finite or ≤ 0 depth (nothing hit) and depth beyond 65535 units (not
    representable; saturating would state a wrong depth). Depth under half a unit becomes 1.

    Returns
    -------
    values : (H, W) uint16
    counts : dict
        ``invalid`` (no depth) and ``out_of_range`` (too far) pixels, both written as 0.
    """
    scale = _check_scale(scale_m)
    depth = np.asarray(depth_m, dtype=np.float64)
    valid = np.isfinite(depth) & (depth > 0)
    units = np.where(valid, np.rint(np.where(valid, depth, 0.0) / scale), 0.0)
    far = valid & (units > 65535)
    values = np.where(far, 0, np.clip(units, 1, 65535) * valid).astype(np.uint16)
    return values, {"invalid": int((~valid).sum()), "out_of_range": int(far.sum())}


def write_depth_png(depth_m: np.ndarray, path: str | Path, *, scale_m: float = 0.001) -> dict:
    """Write a depth map as a single-channel 16-bit PNG, depth = value × ``scale_m`` metres,
    0 = no depth.

    The depth is the label's: the camera-space z (distance along the optical axis, not along
    the ray), as KITTI and NYU store it. The default ``scale_m`` = 0.001 is NYU's millimetres
    (0.001–65.535 m, step 1 mm); KITTI's devkit uses 1/256 m (up to 256 m, step 3.9 mm). Values
    are rounded to the nearest unit, so a read-back is within ``scale_m / 2``.

    Parameters
    ----------
    depth_m : (H, W) array
        Depth, metres; inf, NaN or ≤ 0 where there is none.
    path : str or path-like
        The PNG file (written atomically).
    scale_m : float, keyword-only
        Metres per PNG unit (:data:`DEPTH_SCALES`).

    Returns
    -------
    dict
        ``scale_m``, ``invalid`` and ``out_of_range`` pixel counts (both written as 0).

    References
    ----------
    .. [1] Uhrig, J., et al. (2017). Sparsity Invariant CNNs. 3DV (KITTI depth devkit).
    .. [2] Silberman, N., et al. (2012). NYU Depth v2. ECCV.
    """
    import cv2

    values, counts = depth_to_uint16(depth_m, scale_m=scale_m)
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ValueError(f"{path}: a depth PNG's name must end in .png")
    with atomic_path(path) as tmp:  # the temporary name keeps the suffix, which tells OpenCV the format
        if not cv2.imwrite(str(tmp), values):
            raise OSError(f"could not write {path}")
    return {"scale_m": _check_scale(scale_m), **counts}


def read_depth_png(path: str | Path, *, scale_m: float = 0.001) -> np.ndarray:
    """A depth PNG (:func:`write_depth_png`) as float32 metres, inf where it holds 0 (as the
    depth label: nothing hit)."""
    import cv2

    values = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if values is None or values.dtype != np.uint16 or values.ndim != 2:
        raise RawFormatError(f"{path} is not a single-channel 16-bit PNG")
    depth = values.astype(np.float64) * _check_scale(scale_m)
    return np.where(values == 0, np.inf, depth).astype(np.float32)


def _card(title: str, lines: list[str]) -> str:
    return "\n".join([f"# {title}", "", *lines, ""])


def _describe_depth_pngs(folder: Path, scale: float, records: dict, dataset_dir: str | Path) -> None:
    """depth_png.json and README.md: the scale, its convention and units, for programs and people."""
    convention = next((name for name, value in DEPTH_SCALES.items() if value == scale), "custom")
    record = {"format": "uint16 PNG, one channel", "scale_m_per_unit": scale, "convention": convention,
              "depth": "camera-space z (along the optical axis), metres = value × scale_m_per_unit",
              "invalid_value": 0, "invalid_means": "nothing hit, or farther than 65535 units",
              "max_depth_m": 65535 * scale, "step_m": scale, "rounding": "nearest",
              "source_dataset": str(Path(dataset_dir).resolve()), "items": records}
    (folder / "depth_png.json").write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
    (folder / "README.md").write_text(_card("Depth PNGs", [
        f"`<item id>.png`: each item's depth label (`items/<id>/depth.exr`, camera-space z) as a one-channel "
        f"uint16 PNG: **depth in metres = value × {scale:g}** ({convention} convention; step {scale:g} m, "
        f"up to {65535 * scale:g} m), rounded to the nearest unit. **0 = no depth** (nothing hit, or farther "
        f"than the largest value). `depth_png.json` holds the scale and each item's invalid pixel counts.",
        "", "```python", "import cv2", f"depth_m = cv2.imread('000000.png', cv2.IMREAD_UNCHANGED) * {scale!r}",
        "```"]), encoding="utf-8")


@_export("depth_png", reads="depth", target="depth_png", options=("scale_m",),
         description="16-bit depth PNGs, one per item (OUT/<id>.png; value × scale m, 0 = none; default "
                              "scale 0.001: millimetres, NYU; 1/256: KITTI) with depth_png.json and README.md; "
                              "OUT is a folder")
def export_depth_png(dataset_dir: str | Path, out_dir: str | Path, *, scale_m: float = 0.001,
                     force: bool = False) -> Path:
    """Write every finished item's depth label as a 16-bit PNG (:func:`write_depth_png`).

    ``OUT/<item id>.png`` per item, ``OUT/depth_png.json`` (the scale, its units and convention,
    and per item its source file and the pixels written as 0) and ``OUT/README.md`` saying the
    same for people. The folder appears whole or not at all.

    Parameters
    ----------
    dataset_dir : str or path-like
        A dataset folder whose items hold ``depth``.
    out_dir : str or path-like
        The folder to write.
    scale_m : float or str, keyword-only
        Metres per PNG unit: 0.001 (millimetres, NYU; the default) or 1/256 (KITTI); a string
        such as ``"1/256"`` is read as a fraction.
    force : bool, keyword-only
        Replace an existing ``out_dir``.

    Returns
    -------
    pathlib.Path
        ``out_dir``.

    References
    ----------
    .. [1] Uhrig, J., et al. (2017). Sparsity Invariant CNNs. 3DV (KITTI depth devkit).
    .. [2] Silberman, N., et al. (2012). NYU Depth v2. ECCV.
    """
    scale = _check_scale(scale_m)
    items = _finished_items(dataset_dir, (("depth", "depth.exr"),))
    records = {}
    with staged_directory(out_dir, force=force) as stage:
        for row, folder in items:
            counts = write_depth_png(_label(folder, "depth")["depth"], stage / f"{row['id']}.png", scale_m=scale)
            records[str(row["id"])] = {"file": f"{row['id']}.png", "source": f"items/{row['id']}/depth.exr",
                                       "pixels_invalid": counts["invalid"],
                                       "pixels_out_of_range": counts["out_of_range"]}
        _describe_depth_pngs(stage, scale, records, dataset_dir)
    return Path(out_dir)


# ----------------------------------------------------------------------------- Middlebury .flo
def write_flo(flow_px: np.ndarray, path: str | Path) -> dict:
    """Write optical flow in the Middlebury ``.flo`` format.

    The file is the tag 202021.25 (float32, the bytes ``PIEH``), the width and height (int32),
    then u, v per pixel as float32, row by row, all little-endian; u is to the right and v down,
    in pixels, as the flow label. Non-finite flow is written as 1e10 (Middlebury's unknown flow:
    readers treat values over 1e9 as unknown).

    Parameters
    ----------
    flow_px : (H, W, 2) array
        Flow (u, v), pixels.
    path : str or path-like
        The ``.flo`` file (written atomically).

    Returns
    -------
    dict
        ``unknown``: the pixels written as unknown flow.

    References
    ----------
    .. [1] Baker, S., et al. (2011). A Database and Evaluation Methodology for Optical Flow.
       IJCV 92(1), 1–31; Middlebury flow-code/README.txt and flowIO.cpp.
    """
    flow = np.asarray(flow_px, dtype=np.float32)
    if flow.ndim != 3 or flow.shape[2] != 2 or not flow.shape[0] or not flow.shape[1]:
        raise ValueError(f"flow of shape {flow.shape}: a .flo file holds (H, W, 2) flow (u, v) in pixels")
    unknown = ~np.isfinite(flow).all(axis=2)
    flow = np.where(unknown[..., None], FLO_UNKNOWN, flow)
    header = np.array([FLO_TAG], "<f4").tobytes() + np.array([flow.shape[1], flow.shape[0]], "<i4").tobytes()
    with atomic_path(path) as tmp:
        tmp.write_bytes(header + np.ascontiguousarray(flow, dtype="<f4").tobytes())
    return {"unknown": int(unknown.sum())}


def read_flo(path: str | Path) -> np.ndarray:
    """A Middlebury ``.flo`` file as (H, W, 2) float32 flow, pixels (unknown flow as NaN)."""
    data = Path(path).read_bytes()
    if len(data) < 12 or np.frombuffer(data[:4], "<f4")[0] != FLO_TAG:
        raise RawFormatError(f"{path} is not a Middlebury .flo file (no 'PIEH' tag)")
    width, height = (int(v) for v in np.frombuffer(data[4:12], "<i4"))
    if width <= 0 or height <= 0 or len(data) != 12 + 8 * width * height:
        raise RawFormatError(f"{path}: a {width} × {height} .flo file should hold {12 + 8 * max(width * height, 0)} "
                             f"bytes, not {len(data)}")
    flow = np.frombuffer(data[12:], "<f4").reshape(height, width, 2).astype(np.float32)
    return np.where(np.abs(flow) > 1e9, np.nan, flow).astype(np.float32)


@_export("flo", reads="flow", target="flo", description="Middlebury .flo optical flow, one per item (OUT/<id>.flo; u right, v down, "
                                     "px over the exposure) with flo.json and README.md; OUT is a folder")
def export_flo(dataset_dir: str | Path, out_dir: str | Path, *, force: bool = False) -> Path:
    """Write every finished item's flow label as a Middlebury ``.flo`` file (:func:`write_flo`).

    ``OUT/<item id>.flo`` per item, ``OUT/flo.json`` (units, convention, each item's source and
    unknown pixels) and ``OUT/README.md``. The folder appears whole or not at all.

    Parameters
    ----------
    dataset_dir : str or path-like
        A dataset folder whose items hold ``flow``.
    out_dir : str or path-like
        The folder to write.
    force : bool, keyword-only
        Replace an existing ``out_dir``.

    Returns
    -------
    pathlib.Path
        ``out_dir``.

    References
    ----------
    .. [1] Baker, S., et al. (2011). A Database and Evaluation Methodology for Optical Flow. IJCV.
    """
    items = _finished_items(dataset_dir, (("flow", "flow.exr"),))
    records = {}
    with staged_directory(out_dir, force=force) as stage:
        for row, folder in items:
            counts = write_flo(_label(folder, "flow")["flow"], stage / f"{row['id']}.flo")
            records[str(row["id"])] = {"file": f"{row['id']}.flo", "source": f"items/{row['id']}/flow.exr",
                                       "pixels_unknown": counts["unknown"]}
        record = {"format": "Middlebury .flo (tag 202021.25, int32 width, height, float32 u, v interleaved)",
                  "units": "px over the whole exposure; u right, v down (forward: exposure start to end)",
                  "unknown_value": float(FLO_UNKNOWN), "source_dataset": str(Path(dataset_dir).resolve()),
                  "items": records}
        (stage / "flo.json").write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
        (stage / "README.md").write_text(_card("Optical flow (.flo)", [
            "`<item id>.flo`: each item's flow label (`items/<id>/flow.exr`) in the Middlebury format: forward flow "
            "over the exposure in pixels, u to the right, v down; values over 1e9 are unknown flow.", "",
            "```python", "import cv2", "flow = cv2.readOpticalFlow('000000.flo')   # (H, W, 2) float32, px", "```"]),
            encoding="utf-8")
    return Path(out_dir)


# ----------------------------------------------------------------------------- one entry point
def export(dataset_dir: str | Path, out: str | Path, *, format: str, force: bool = False, **options) -> Path:
    """Export a dataset in one of :data:`EXPORTS`' formats (``options``: the format's own,
    e.g. ``scale_m`` for ``depth_png``).

    Raises
    ------
    ConfigError
        For an unknown format (listing the valid ones) or an option the format does not take.
    """
    EXPORTS.check(format, key="--format")
    EXPORTS.check_options(format, options, where=f"export format {format!r}")
    return EXPORTS[format](dataset_dir, out, force=force, **options)


def check_exports(exports: Mapping[str, Mapping[str, Any]], outputs: Sequence[str], *,
                  key: str = "dataset.exports") -> dict[str, dict]:
    """Check a dataset's exports before anything renders: known formats, their own options (a
    depth scale > 0) and the labels they read among ``outputs``.

    Returns
    -------
    dict
        format → options, the depth scale as a number.

    Raises
    ------
    ConfigError
        Naming the valid formats, options or the label to add to ``[dataset] outputs``.
    """
    checked = {}
    for name, options in exports.items():
        EXPORTS.check(name, key=key)
        if not isinstance(options, Mapping):
            raise ConfigError(f"{key}.{name} = {options!r}: give a table of the format's options "
                              f"({', '.join(EXPORTS[name].options) or 'none'}), e.g. {{ scale_m = 0.001 }}")
        EXPORTS.check_options(name, options, where=f"{key}.{name}")
        options = dict(options)
        if "scale_m" in options:
            options["scale_m"] = _check_scale(options["scale_m"])
        if EXPORT_LABELS[name] not in outputs:
            raise ConfigError(f"{key}: the {name!r} export reads the {EXPORT_LABELS[name]!r} label; add "
                              f"{EXPORT_LABELS[name]!r} to [dataset] outputs (now {', '.join(outputs)})")
        checked[name] = options
    return checked


def export_into_dataset(dataset_dir: str | Path, exports: Mapping[str, Mapping[str, Any]]) -> dict[str, Path]:
    """Write each of ``exports`` (format → options) into ``dataset_dir/exports/`` from the
    dataset's finished items, replacing the previous run's (each whole or not at all).

    Returns
    -------
    dict
        format → the file or folder written (:data:`EXPORT_TARGETS`).
    """
    folder = Path(dataset_dir) / EXPORTS_DIR
    folder.mkdir(parents=True, exist_ok=True)
    return {name: export(dataset_dir, folder / EXPORT_TARGETS[name], format=name, force=True, **options)
            for name, options in exports.items()}


def exported(dataset_dir: str | Path) -> dict[str, Path]:
    """The exports a dataset folder holds: format → its file or folder under ``exports/``."""
    folder = Path(dataset_dir) / EXPORTS_DIR
    return {name: folder / target for name, target in EXPORT_TARGETS.items() if (folder / target).exists()}
