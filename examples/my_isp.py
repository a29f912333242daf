"""A user's own raw developer, as a colour-validation plan scores it (examples/validate_my_isp.toml).

The textbook steps, written by hand, with rawpy (LibRaw) reading the mosaic and tifffile the DNG
tags: subtract the black level, scale to the white level, bilinear demosaicing (normalised
convolution of each colour's samples), the as-shot white balance (1 / AsShotNeutral), and the
camera → linear sRGB matrix made from the DNG's D65 ColorMatrix the way dcraw does (XYZ → camera
times sRGB → XYZ, rows normalised to 1 so that white stays white, inverted). No tone curve: the plan
reads the result as linear sRGB. Replace :func:`develop` with yours; the plan calls it with the
DNG's path (and the cell's context, where the function takes one) and scores what it returns.

References
----------
.. [1] Coffin, D. dcraw.c, ``convert_to_rgb`` and ``cam_xyz_coeff`` (the rgb_cam matrix).
.. [2] Adobe (2023). Digital Negative Specification 1.7, ColorMatrix, CalibrationIlluminant (21 = D65),
   AsShotNeutral.
.. [3] IEC 61966-2-1 (sRGB): the linear sRGB → XYZ matrix, D65.
.. [4] Knutsson, H., & Westin, C.-F. (1993). Normalized and differential convolution. CVPR.
"""

from __future__ import annotations

import numpy as np

#: Linear sRGB (D65) → CIE XYZ, IEC 61966-2-1.
SRGB_TO_XYZ = np.array([[0.4124, 0.3576, 0.1805],
                        [0.2126, 0.7152, 0.0722],
                        [0.0193, 0.1192, 0.9505]])


def _bilinear(mosaic: np.ndarray, colour: np.ndarray) -> np.ndarray:
    """(H, W, 3) from a CFA mosaic and each pixel's colour (0 R, 1 G, 2 B): each channel the
    weighted mean of its own samples in the 3 × 3 neighbourhood (bilinear for a Bayer tile)."""
    from scipy.ndimage import convolve

    kernel = np.array([[1.0, 2.0, 1.0], [2.0, 4.0, 2.0], [1.0, 2.0, 1.0]])
    planes = []
    for c in range(3):
        mask = (colour == c).astype(np.float64)
        planes.append(convolve(mosaic * mask, kernel, mode="mirror") / convolve(mask, kernel, mode="mirror"))
    return np.stack(planes, axis=-1)


def _dng_tags(path) -> tuple[np.ndarray, np.ndarray]:
    """The DNG's XYZ → camera matrix calibrated under D65 and its as-shot neutral (camera RGB)."""
    import tifffile

    def numbers(tag):
        pairs = np.asarray(tag.value, dtype=np.float64).reshape(-1, 2)  # (S)RATIONAL: numerator, denominator
        return pairs[:, 0] / pairs[:, 1]

    with tifffile.TiffFile(str(path)) as tiff:
        tags = tiff.pages[0].tags
        matrices = {tags[f"CalibrationIlluminant{k}"].value: numbers(tags[f"ColorMatrix{k}"]).reshape(3, 3)
                    for k in (1, 2) if f"ColorMatrix{k}" in tags}
        neutral = numbers(tags["AsShotNeutral"])
    return matrices.get(21, next(iter(matrices.values()))), neutral


def develop(path):
    """The DNG at ``path`` as (H, W, 3) linear sRGB (white = 1)."""
    import rawpy

    with rawpy.imread(str(path)) as raw:
        mosaic = raw.raw_image_visible.astype(np.float64)
        index = raw.raw_colors_visible
        names = raw.color_desc.decode()                       # e.g. "RGBG": index → colour letter
        colour = np.array(["RGB".index(letter) for letter in names])[index]
        black = np.asarray(raw.black_level_per_channel, dtype=np.float64)[index]
        scale = float(raw.white_level) - black
    xyz_to_camera, neutral = _dng_tags(path)
    signal = np.clip((mosaic - black) / scale, 0.0, None)
    camera = _bilinear(signal, colour) * (neutral[1] / neutral)  # the neutral becomes (1, 1, 1)
    srgb_to_camera = xyz_to_camera @ SRGB_TO_XYZ
    srgb_to_camera /= srgb_to_camera.sum(axis=1, keepdims=True)  # camera white (1, 1, 1) is sRGB white
    return camera @ np.linalg.inv(srgb_to_camera).T
