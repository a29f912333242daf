"""What a pipeline hands back, turned into linear sRGB: its output spaces, the image files a
command may write, and the checks every returned image passes.

A user pipeline returns (a callable) or writes (a command, :data:`OUTPUT_SUFFIXES`) an (H, W, 3)
image in the space ``output`` names (:data:`OUTPUT_SPACES`); integer images are scaled by their
type's maximum (uint8 / 255, uint16 / 65535) so 1 is full scale whatever the type, an alpha
channel is dropped, and NaN or infinite values are refused.

References
----------
.. [1] IEC 61966-2-1:1999 (sRGB); ITU-R BT.709-6 (its OETF, inverted; the primaries are sRGB's).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ...errors import ConfigError
from .pipeline_base import check_choice

__all__ = ["OUTPUT_SPACES", "OUTPUT_SUFFIXES", "check_output_space", "to_linear_srgb", "unit_range", "check_output",
           "read_image_file"]

#: What a user pipeline returns: linear sRGB, CIE XYZ (D65-relative), sRGB-encoded values,
#: BT.709-encoded values (the same primaries, Rec. 709's OETF), ``"icc"`` (a command's file decoded
#: through the ICC profile it embeds, :mod:`~spectral_cam.apps.validate.icc`) or ``"gamma:<γ>"``
#: (sRGB primaries, a plain power law, e.g. ``"gamma:2.2"``).
OUTPUT_SPACES = ("linear_srgb", "xyz", "srgb", "bt709", "icc", "gamma:<γ>")
#: Files a command pipeline may write.
OUTPUT_SUFFIXES = (".npy", ".tif", ".tiff", ".png", ".exr")


def check_output_space(name: str, key: str, value: Any) -> str:
    """``output`` checked: one of :data:`OUTPUT_SPACES`, ``"gamma:<γ>"`` with 0.2 ≤ γ ≤ 5."""
    if isinstance(value, str) and value.lower().startswith("gamma:"):
        try:
            gamma = float(value.split(":", 1)[1])
        except ValueError:
            gamma = float("nan")
        if not 0.2 <= gamma <= 5.0:
            raise ConfigError(f"pipeline {name!r}: {key} = {value!r}; give the gamma as a number in 0.2..5, "
                              "e.g. 'gamma:2.2'")
        return f"gamma:{gamma:g}"
    return check_choice(name, key, value, OUTPUT_SPACES[:-1], after=", or 'gamma:<γ>' (e.g. 'gamma:2.2')")


def to_linear_srgb(image, space: str) -> np.ndarray:
    """(H, W, 3) values in ``space`` → linear sRGB (unclipped).

    References
    ----------
    .. [1] IEC 61966-2-1:1999 (sRGB); ITU-R BT.709-6 (its OETF, inverted; the primaries are sRGB's).
    """
    import colour

    from ...colour_ground_truth import xyz_to_linear_srgb

    if space == "xyz":
        return xyz_to_linear_srgb(image)
    if space == "srgb":
        return np.asarray(colour.cctf_decoding(image, function="sRGB"), dtype=np.float64)
    if space == "bt709":
        return np.asarray(colour.models.oetf_inverse_BT709(image), dtype=np.float64)
    if space.startswith("gamma:"):
        return np.sign(image) * np.abs(image) ** float(space.split(":", 1)[1])
    return image


def unit_range(array: np.ndarray) -> np.ndarray:
    """An image as float64 with integers scaled by their type's maximum (uint8 / 255, uint16 /
    65535), so 1 is full scale whatever the type a pipeline returns or writes."""
    if array.dtype == bool:
        raise ConfigError("a boolean image is not a developed image")
    if np.issubdtype(array.dtype, np.integer):
        return array.astype(np.float64) / float(np.iinfo(array.dtype).max)
    return array.astype(np.float64)


def check_output(image, name: str) -> np.ndarray:
    try:
        array = unit_range(np.asarray(image))
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"pipeline {name!r} returned something that is not a numeric array ({exc})") from None
    if array.ndim == 3 and array.shape[-1] == 4:
        array = array[..., :3]  # drop alpha
    if array.ndim != 3 or array.shape[-1] != 3:
        raise ConfigError(f"pipeline {name!r} returned shape {array.shape}; expected (H, W, 3)")
    if not np.all(np.isfinite(array)):
        raise ConfigError(f"pipeline {name!r} returned NaN or infinite values")
    return array



def read_image_file(path: Path) -> np.ndarray:
    """Read a command's output: .npy (as is), TIFF/PNG (integers scaled to [0, 1]), EXR."""
    suffix = path.suffix.lower()
    if suffix == ".npy":
        return np.load(path, allow_pickle=False)
    if suffix in (".tif", ".tiff"):
        import tifffile

        data = tifffile.imread(path)
    elif suffix == ".png":
        import cv2

        data = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if data is None:
            raise ConfigError(f"{path} is not a readable PNG")
        if data.ndim == 3:
            data = data[..., 2::-1] if data.shape[-1] in (3, 4) else data
    elif suffix == ".exr":
        import OpenEXR

        with OpenEXR.File(str(path)) as exr:
            channels = exr.channels()
            if "RGB" in channels or "RGBA" in channels:
                data = np.asarray(channels.get("RGB", channels.get("RGBA")).pixels)
            else:
                missing = [c for c in "RGB" if c not in channels]
                if missing:
                    raise ConfigError(f"{path}: EXR without channels {', '.join(missing)}")
                data = np.stack([np.asarray(channels[c].pixels) for c in "RGB"], axis=-1)
    else:
        raise ConfigError(f"cannot read {path.name}; valid output suffixes: {', '.join(OUTPUT_SUFFIXES)}")
    return unit_range(np.asarray(data))
