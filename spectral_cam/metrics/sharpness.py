"""Slanted-edge MTF (ISO 12233 e-SFR).

References
----------
.. [1] ISO 12233:2017, Photography — Electronic still picture imaging — Resolution and
   spatial frequency responses, Annex D (edge-based SFR).
.. [2] Burns, P. D. (2000). Slanted-edge MTF for digital camera and scanner analysis.
   Proc. IS&T PICS Conference, 135–138.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["slanted_edge_mtf"]


def _edge_positions(image: np.ndarray, half_window: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel edge position in each row: centroid of the |horizontal derivative| within
    ``half_window`` pixels of its maximum (noise in the flat parts would bias a centroid
    over the whole row towards the middle)."""
    derivative = np.abs(np.diff(image, axis=1))
    columns = np.arange(derivative.shape[1]) + 1.0  # derivative i sits between pixels i and i+1
    peak = np.argmax(derivative, axis=1)
    near = np.abs(np.arange(derivative.shape[1])[None, :] - peak[:, None]) <= half_window
    windowed = np.where(near, derivative, 0.0)
    weight = windowed.sum(axis=1)
    rows = np.nonzero(weight > 0)[0]
    centroid = (windowed[rows] * columns).sum(axis=1) / weight[rows]
    return rows.astype(float), centroid


def slanted_edge_mtf(image: np.ndarray, *, oversample: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """MTF from a near-vertical slanted edge (angle 2–10° from vertical).

    Steps of ISO 12233 Annex D: locate the edge in every row (derivative centroid), fit a
    straight line, project every pixel onto the edge normal into bins of 1/``oversample``
    pixel (the edge-spread function), differentiate (the line-spread function), apply a
    Hamming window, Fourier transform, normalise at zero frequency and divide by the
    transfer function of the discrete derivative.

    Parameters
    ----------
    image
        (H, W) linear image of one channel holding one edge crossing every row.
    oversample
        Bins per pixel for the edge-spread function (ISO uses 4).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        Frequencies in cycles per pixel (0 … 1, perpendicular to the edge) and the MTF.

    Raises
    ------
    ConfigError
        If the image has no usable edge (a flat image, or an edge too steep or too flat).

    References
    ----------
    .. [1] ISO 12233:2017, Annex D.
    """
    image = np.asarray(image, dtype=np.float64)
    if image.ndim != 2 or min(image.shape) < 8:
        raise ConfigError(f"slanted_edge_mtf needs a 2-D image of at least 8×8 pixels; got {image.shape}")
    rows, centroid = _edge_positions(image)
    if rows.size < 4:
        raise ConfigError("no edge found: the image is flat")
    slope, intercept = np.polyfit(rows + 0.5, centroid, 1)  # edge column x = intercept + slope·y
    angle = np.degrees(np.arctan(abs(slope)))
    if not 1.0 <= angle <= 20.0:
        raise ConfigError(f"the edge is {angle:.1f}° from vertical; the method needs about 2–10°")
    cos_theta = 1.0 / np.sqrt(1.0 + slope * slope)
    yy, xx = np.indices(image.shape) + 0.5
    distance = (xx - (intercept + slope * yy)) * cos_theta  # perpendicular, in pixels
    bins = np.round(distance * oversample).astype(int)
    bins -= bins.min()
    counts = np.bincount(bins.ravel())
    sums = np.bincount(bins.ravel(), weights=image.ravel())
    valid = counts > 0
    centres = np.arange(counts.size)
    esf = np.interp(centres, centres[valid], sums[valid] / counts[valid])
    # keep the well-populated middle of the ESF (the ends hold few samples)
    populated = np.nonzero(counts >= max(2, counts.max() // 4))[0]
    esf = esf[populated.min():populated.max() + 1]
    lsf = np.gradient(esf)
    peak = int(np.argmax(np.abs(lsf)))
    n = lsf.size
    window = 0.54 + 0.46 * np.cos(np.pi * (np.arange(n) - peak) / max(peak, n - 1 - peak, 1))
    spectrum = np.abs(np.fft.rfft(lsf * window))
    freqs = np.fft.rfftfreq(n, d=1.0 / oversample)  # cycles per pixel
    mtf = spectrum / spectrum[0]
    # np.gradient is a central difference over ±1 bin: transfer sin(2πfΔ)/(2πfΔ), Δ = 1/oversample
    correction = np.sinc(2.0 * freqs / oversample)
    keep = freqs <= 1.0
    return freqs[keep], mtf[keep] / np.maximum(correction[keep], 1e-6)
