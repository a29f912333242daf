"""Reading a generated dataset back: an item's files as NumPy arrays (:func:`read_item`), and
the dataset as a map-style sequence (:class:`SyntheticDataset`) that PyTorch's ``DataLoader``
takes as it is (a map-style dataset is anything with ``__len__`` and ``__getitem__``).

Each label becomes one or more keys of an item (units as the dataset card and
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
``segmentation``    (H, W) uint16 instance ids (0: nothing; meta["segmentation"] names them)
``coverage``        (H, W, 3) int32 ranked instance ids under defocus (0: none); ``coverage_fraction``
                    (H, W, 3) float32 their shares of the pixel's rays
``flow``            (H, W, 2) float32 forward flow over the exposure, px (x right, y down)
``albedo``          (H, W, 3) float32 reflectance as camera RGB under the light's white (white = 1);
                    ``albedo_srgb`` the same as linear sRGB (D65); ``shading`` (H, W) irradiance
                    relative to the reference white's; ``illuminance_lux`` (H, W) the illuminance
``illuminant_map``  (H, W, 3) float32 camera RGB (green 1) of the light at each pixel;
                    ``light_shares`` (H, W, N) each light's share (meta["illuminant_map"] names them)
``camera``          camera.json as a dict, ``K`` and the poses as NumPy arrays
``illuminant``      illuminant.json as a dict
``meta``            meta.json (sampled parameters under ``dataset.params``)
==================  ==========================================================================

With PyTorch installed (it is not a dependency)::

    import torch
    from torch.utils.data import DataLoader
    from spectral_cam.apps.dataset import SyntheticDataset

    def to_tensors(item):
        image = torch.from_numpy(item["image"]).permute(2, 0, 1).float() / 255
        return image, torch.from_numpy(item["depth"])

    loader = DataLoader(SyntheticDataset("out/", labels=("image", "depth"), transform=to_tensors),
                        batch_size=8, shuffle=True, num_workers=2)

References
----------
.. [1] PyTorch documentation, ``torch.utils.data``: map-style datasets.
.. [2] Hugging Face ``datasets``, "Create an image dataset" (ImageFolder with metadata.jsonl):
   the dataset folder's ``metadata.jsonl`` (:func:`spectral_cam.apps.dataset.card.write_metadata`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np

from ...errors import RawFormatError

__all__ = ["SyntheticDataset", "read_item", "LOADABLE_LABELS"]

#: Image formats read as images (the developed image and the all-in-focus view).
_IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff")


def _exr_channels(path: Path) -> dict[str, np.ndarray]:
    from ...spectral_exr import read_exr

    return read_exr(path)[1]


def _image(path: Path) -> np.ndarray:
    import cv2

    pixels = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if pixels is None:
        raise RawFormatError(f"{path} is not a readable image")
    return pixels[..., ::-1].copy() if pixels.ndim == 3 else pixels  # OpenCV's BGR -> RGB


def _stack(path: Path, names: tuple[str, ...]) -> np.ndarray:
    channels = _exr_channels(path)
    missing = [n for n in names if n not in channels]
    if missing:
        raise RawFormatError(f"{path} lacks channel(s) {', '.join(missing)}; it holds {', '.join(sorted(channels))}")
    return np.stack([channels[n] for n in names], axis=-1).astype(np.float32)


def _clean_rgb(path: Path) -> np.ndarray:
    """R, G, B (a monochrome sensor's single Y as (H, W, 1))."""
    names = ("Y",) if "Y" in _exr_channels(path) else ("R", "G", "B")
    return _stack(path, names)


def _shading(path: Path) -> dict[str, np.ndarray]:
    """S and, where written, the illuminance in lux."""
    channels = _exr_channels(path)
    found = {"shading": _stack(path, ("S",))[..., 0]}
    if "E_lux" in channels:
        found["illuminance_lux"] = _stack(path, ("E_lux",))[..., 0]
    return found


def _illuminant_map(path: Path) -> dict[str, np.ndarray]:
    """The per-pixel illuminant and the shares, share_0 … share_{N-1} in order."""
    channels = _exr_channels(path)
    count = sum(1 for name in channels if name.startswith("share_"))
    return {"illuminant_map": _stack(path, ("R", "G", "B")),
            "light_shares": _stack(path, tuple(f"share_{k}" for k in range(count)))}


def _coverage(path: Path) -> dict[str, np.ndarray]:
    channels = _exr_channels(path)
    ranks = sum(1 for name in channels if name.startswith("id_"))
    return {"coverage": _stack(path, tuple(f"id_{k}" for k in range(ranks))).astype(np.int32),
            "coverage_fraction": _stack(path, tuple(f"coverage_{k}" for k in range(ranks)))}


def _camera(path: Path) -> dict:
    record = json.loads(path.read_text(encoding="utf-8"))
    for key in ("K", "distortion", "world_to_camera_opencv", "world_to_camera_opengl", "camera_to_world_opencv"):
        if key in record:
            record[key] = np.asarray(record[key], dtype=np.float64)
    return record


def _raw(path: Path) -> np.ndarray:
    import tifffile

    try:
        return tifffile.imread(str(path))
    except Exception as exc:  # tifffile raises several types on corrupt files
        raise RawFormatError(f"{path} is not a readable DNG: {exc}") from None


def _radiance(path: Path) -> dict[str, np.ndarray]:
    from ...spectral_exr import read_spectral_exr

    image = read_spectral_exr(path)
    return {"radiance": np.asarray(image.data, dtype=np.float32),
            "radiance_nm": np.asarray(image.wavelengths_nm, dtype=np.float64)}


#: label → (file stem, reader of the file into the item's keys)
_READERS: dict[str, tuple[str, Callable[[Path], dict]]] = {
    "raw": ("raw.dng", lambda p: {"raw": _raw(p)}),
    "depth": ("depth.exr", lambda p: {"depth": _stack(p, ("Z",))[..., 0]}),
    "defocus": ("defocus.exr", lambda p: {"defocus": _stack(p, ("CoC",))[..., 0]}),
    "clean_rgb": ("clean_rgb.exr", lambda p: {"clean_rgb": _clean_rgb(p)}),
    "radiance": ("radiance.exr", _radiance),
    "undistortion": ("undistortion.exr", lambda p: {"undistortion": _stack(p, ("map_x", "map_y"))}),
    "health": ("health.exr", lambda p: {"health": _stack(p, ("cab", "state"))}),
    "segmentation": ("segmentation.png", lambda p: {"segmentation": _image(p)}),
    "coverage": ("coverage.exr", _coverage),
    "flow": ("flow.exr", lambda p: {"flow": _stack(p, ("dx", "dy"))}),
    "albedo": ("albedo.exr", lambda p: {"albedo": _clean_rgb(p), "albedo_srgb": _stack(p, ("sRGB_R", "sRGB_G", "sRGB_B")),
                                        **_shading(p.with_name("shading.exr"))}),
    "illuminant_map": ("illuminant_map.exr", _illuminant_map),
    "camera": ("camera.json", lambda p: {"camera": _camera(p)}),
    "illuminant": ("illuminant.json", lambda p: {"illuminant": json.loads(p.read_text(encoding="utf-8"))}),
}
#: Labels :func:`read_item` reads (every dataset output; the images in whichever format was written).
LOADABLE_LABELS = ("raw", "image", "all_in_focus", *[k for k in _READERS if k != "raw"])


def _image_file(folder: Path, stem: str, files: Iterable[str]) -> Path | None:
    for name in files:
        path = Path(name)
        if path.stem == stem and path.suffix.lower() in _IMAGE_SUFFIXES:
            return folder / name
    return None


def read_item(folder: str | Path, labels: Iterable[str] | None = None) -> dict[str, Any]:
    """The arrays and records of one dataset item (see the module's table of keys).

    Parameters
    ----------
    folder : str or path-like
        An item folder (``DIR/items/000042``).
    labels : iterable of str, optional
        The labels to read (:data:`LOADABLE_LABELS`); default every label the item holds.
        ``meta`` is always included.

    Returns
    -------
    dict
        Label name → NumPy array or dict.

    Raises
    ------
    RawFormatError
        For a folder without meta.json, a label the item lacks, or an unreadable file.
    """
    folder = Path(folder)
    try:
        meta = json.loads((folder / "meta.json").read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise RawFormatError(f"{folder} is not a dataset item: its meta.json cannot be read ({exc})") from None
    files = list(meta.get("files", []))
    wanted = list(labels) if labels is not None else None
    unknown = [name for name in (wanted or []) if name not in LOADABLE_LABELS]
    if unknown:
        raise RawFormatError(f"unknown label(s) {', '.join(unknown)}; valid: {', '.join(LOADABLE_LABELS)}")
    item: dict[str, Any] = {"meta": meta}
    for label in LOADABLE_LABELS:
        if wanted is not None and label not in wanted:
            continue
        if label in ("image", "all_in_focus"):
            path = _image_file(folder, label, files)
            if path is not None:
                item[label] = _image(path)
        else:
            name, reader = _READERS[label]
            if name in files:
                item.update(reader(folder / name))
        if wanted is not None and label not in item:
            raise RawFormatError(f"{folder} has no {label!r} label; it holds {', '.join(files)}")
    return item


class SyntheticDataset:
    """The finished items of a dataset folder, in index order, as a map-style dataset.

    Parameters
    ----------
    root : str or path-like
        The dataset folder (``spectral-cam dataset ... -o DIR``): its ``manifest.jsonl`` lists
        the items; those done are served.
    labels : iterable of str, optional
        What each item holds (:data:`LOADABLE_LABELS`); default everything written.
    transform : callable, optional
        Applied to each item's dict (e.g. to tensors).

    Examples
    --------
    A dataset written by ``spectral-cam dataset spec.toml -n 100 -o out``::

        data = SyntheticDataset("out/", labels=("image", "depth"))
        item = data[0]     # item["image"]: (H, W, 3) uint8, item["depth"]: (H, W) float32 metres
    """

    def __init__(self, root: str | Path, *, labels: Iterable[str] | None = None, transform: Callable | None = None):
        self.root = Path(root)
        manifest = self.root / "manifest.jsonl"
        try:
            rows = [json.loads(line) for line in manifest.read_text(encoding="utf-8").splitlines() if line.strip()]
        except (OSError, ValueError) as exc:
            raise RawFormatError(f"{self.root} is not a dataset folder: {manifest.name} cannot be read ({exc})") from None
        self.rows = [row for row in sorted(rows, key=lambda r: r["index"]) if row.get("status") == "done"]
        self.labels = None if labels is None else tuple(labels)
        self.transform = transform

    def __len__(self) -> int:
        return len(self.rows)

    def __getitem__(self, index: int):
        if not -len(self) <= index < len(self):
            raise IndexError(f"item {index} of a dataset of {len(self)} finished items")
        row = self.rows[index]
        item = read_item(self.root / "items" / row["id"], self.labels)
        item["params"] = row.get("params") or {}
        return self.transform(item) if self.transform is not None else item

    def params(self, index: int) -> dict:
        """The parameters sampled for an item (its manifest row's ``params``)."""
        return dict(self.rows[index].get("params") or {})
