"""The colourfulness of a developed region: CIELAB chroma (colour-science) of its mean display
sRGB — how far from neutral a surface that should be white or grey came out."""

from __future__ import annotations

import math

import numpy as np


def region_chroma(image: np.ndarray, rows: tuple[float, float], columns: tuple[float, float]) -> float:
    """C*ab of the mean of ``image`` (display sRGB in [0, 1]) over the fractions ``rows`` and
    ``columns`` of its height and width."""
    import colour

    h, w = image.shape[:2]
    patch = image[int(rows[0] * h):int(rows[1] * h), int(columns[0] * w):int(columns[1] * w)]
    srgb = np.clip(patch.reshape(-1, 3).astype(float).mean(axis=0), 0.0, 1.0)
    lab = colour.XYZ_to_Lab(colour.sRGB_to_XYZ(srgb))
    return math.hypot(lab[1], lab[2])
