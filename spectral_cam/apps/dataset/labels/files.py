"""File helpers the labels share: reading EXR channels and images back, writing 16-bit PNGs.

Readers raise whatever their library raises; :func:`spectral_cam.apps.dataset.read_item` turns
any failure into one :class:`~spectral_cam.errors.RawFormatError` naming the file.

References
----------
.. [1] OpenEXR file layout (named channels); OpenCV ``imread``/``imwrite`` (BGR order, 16-bit PNG).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ....errors import RawFormatError

__all__ = ["exr_channels", "stack", "camera_rgb", "read_image", "write_png16", "IMAGE_SUFFIXES"]

#: Image formats read as images (the developed image and the all-in-focus view).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff")


def exr_channels(path: Path) -> dict[str, np.ndarray]:
    """Every channel of an EXR file by name."""
    from ....spectral_exr import read_exr

    return read_exr(path)[1]


def stack(path: Path, names: tuple[str, ...]) -> np.ndarray:
    """(H, W, len(names)) float32 of the named EXR channels, in that order."""
    channels = exr_channels(path)
    missing = [n for n in names if n not in channels]
    if missing:
        raise RawFormatError(f"{path} lacks channel(s) {', '.join(missing)}; it holds {', '.join(sorted(channels))}")
    return np.stack([channels[n] for n in names], axis=-1).astype(np.float32)


def camera_rgb(path: Path) -> np.ndarray:
    """Channels R, G, B (a monochrome sensor's single Y as (H, W, 1))."""
    names = ("Y",) if "Y" in exr_channels(path) else ("R", "G", "B")
    return stack(path, names)


def read_image(path: Path) -> np.ndarray:
    """An image file's pixels as stored (8 or 16 bit), RGB order."""
    import cv2

    pixels = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if pixels is None:
        raise RawFormatError(f"{path} is not a readable image")
    return pixels[..., ::-1].copy() if pixels.ndim == 3 else pixels  # OpenCV's BGR -> RGB


def write_png16(values: np.ndarray, path: Path) -> Path:
    """A (H, W) array as a 16-bit greyscale PNG."""
    import cv2

    if not cv2.imwrite(str(path), values.astype(np.uint16)):
        raise OSError(f"could not write {path}")
    return path
