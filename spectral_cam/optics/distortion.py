"""Brown–Conrady lens distortion (radial k₁, k₂, k₃ and tangential p₁, p₂), in OpenCV's
convention: normalised image coordinates x = X/Z to the image's right, y = Y/Z down,

    x_d = x(1 + k₁r² + k₂r⁴ + k₃r⁶) + 2p₁xy + p₂(r² + 2x²)
    y_d = y(1 + k₁r² + k₂r⁴ + k₃r⁶) + p₁(r² + 2y²) + 2p₂xy,     r² = x² + y²,

and the undistortion map a dataset item carries: for each pixel of the undistorted (ideal
pinhole) image, where it lies in the rendered, distorted one — what ``cv2.remap`` takes.

References
----------
.. [1] Brown, D. C. (1966). Decentering distortion of lenses. Photogrammetric Engineering 32(3),
   444–462.
.. [2] OpenCV, "Camera calibration and 3D reconstruction" (``cv2.undistort``, ``cv2.remap``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["distort", "undistortion_map"]


def distort(x, y, coefficients):
    """Distorted normalised coordinates of undistorted ones (arrays), ``coefficients`` =
    (k1, k2, p1, p2, k3), OpenCV's order."""
    k1, k2, p1, p2, k3 = (float(c) for c in coefficients)
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    return (x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y)


def undistortion_map(lens, coefficients) -> tuple[np.ndarray, np.ndarray]:
    """(map_x, map_y), each (H, W) float32: the column and row (pixel centres at integers) of the
    rendered image that each pixel of the undistorted image shows, so
    ``cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR)`` undistorts ``image``.

    Parameters
    ----------
    lens : ThinLens
        The frame's lens (pixel pitch over image distance: the normalised size of a pixel).
    coefficients
        (k1, k2, p1, p2, k3).
    """
    scale = lens.pixel_pitch_m / lens.image_distance_m
    columns = (np.arange(lens.width_px) + 0.5 - lens.width_px / 2) * scale
    rows = (np.arange(lens.height_px) + 0.5 - lens.height_px / 2) * scale
    x, y = np.meshgrid(columns, rows)
    xd, yd = distort(x, y, coefficients)
    return ((xd / scale + lens.width_px / 2 - 0.5).astype(np.float32),
            (yd / scale + lens.height_px / 2 - 0.5).astype(np.float32))
