"""Natural-image statistics: does a developed image look like a camera's photograph?

Each statistic is measured the same way on our developed images and on real photographs (8-bit
display sRGB), and on RAWs as fractions of full scale:

- :func:`median_lightness`: median CIE 1976 L* of the pixels (sRGB decoded, Y of IEC 61966-2-1);
- :func:`clipped_share`: share of pixels with a channel at 255 (or ≥ 254.5/255);
- :func:`spectrum_slope`: slope α of the radially averaged power spectrum of luminance,
  P(f) ∝ f^α, over 1/64–1/4 cycles per pixel (natural images: α ≈ −2, van der Schaaf &
  van Hateren 1996);
- :func:`flat_share`: share of 8 × 8 blocks whose display luminance varies by less than one
  8-bit level (σ < 1/255): texture-free area, which renders of flat primitives are full of;
- :func:`colourfulness`: Hasler & Süsstrunk's M = σ_rgyb + 0.3·μ_rgyb on 8-bit RGB;
- :func:`firefly_share`: share of pixels brighter than 4× the median of their 5 × 5
  neighbourhood, than the frame's median and than twice each of their 8 neighbours (isolated
  bright outliers; dark noise and the corners of bright areas excluded);
- :func:`raw_levels`: median and 99th percentile of a RAW, (DN − black)/(white − black).

References
----------
.. [1] CIE 15:2004 §8.2.1 (L*); IEC 61966-2-1:1999 (sRGB).
.. [2] van der Schaaf, A., & van Hateren, J. H. (1996). Modelling the power spectra of natural
   images. Vision Research 36(17), 2759–2770.
.. [3] Hasler, D., & Süsstrunk, S. (2003). Measuring colourfulness in natural images. Proc. SPIE
   5007, Human Vision and Electronic Imaging VIII, 87–95.
.. [4] Buisine, J., Delepoulle, S., & Renaud, C. (2021). Firefly removal in Monte Carlo
   rendering with adaptive Median of meaNs. EGSR 2021 (fireflies as outliers of their
   neighbourhood).
"""

from __future__ import annotations

import numpy as np

__all__ = ["display_luminance", "median_lightness", "clipped_share", "spectrum_slope", "flat_share",
           "colourfulness", "firefly_share", "raw_levels", "image_statistics"]


def _display(image: np.ndarray) -> np.ndarray:
    """Display sRGB in [0, 1] from a uint8/uint16 or float array."""
    x = np.asarray(image)
    if x.dtype == np.uint8:
        return x.astype(np.float64) / 255.0
    if x.dtype == np.uint16:
        return x.astype(np.float64) / 65535.0
    return np.clip(x.astype(np.float64), 0.0, 1.0)


def display_luminance(image: np.ndarray) -> np.ndarray:
    """Relative luminance Y of display sRGB (decoded, IEC 61966-2-1 eq. 4–5; BT.709 weights)."""
    v = _display(image)
    linear = np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)
    return linear @ np.array([0.2126, 0.7152, 0.0722])


def median_lightness(image: np.ndarray) -> float:
    """Median CIE 1976 L* (white Y = 1) of a display sRGB image (CIE 15:2004 §8.2.1)."""
    y = np.median(display_luminance(image))
    f = np.cbrt(y) if y > (6 / 29) ** 3 else y / (3 * (6 / 29) ** 2) + 4 / 29
    return float(116 * f - 16)


def clipped_share(image: np.ndarray) -> float:
    """Share of pixels with any channel at display white (≥ 254.5/255)."""
    return float(np.mean(np.any(_display(image) >= 254.5 / 255, axis=-1)))


def spectrum_slope(image: np.ndarray, *, band=(1 / 64, 1 / 4)) -> float:
    """Slope α of the radially averaged power spectrum of display luminance, P ∝ f^α, fitted in
    log–log over ``band`` (cycles per pixel) on the largest centred square, Hann-windowed."""
    y = display_luminance(image)
    side = min(y.shape)
    top, left = (y.shape[0] - side) // 2, (y.shape[1] - side) // 2
    y = y[top:top + side, left:left + side]
    window = np.outer(np.hanning(side), np.hanning(side))
    power = np.abs(np.fft.fftshift(np.fft.fft2((y - y.mean()) * window))) ** 2
    f = np.fft.fftshift(np.fft.fftfreq(side))
    radius = np.hypot(*np.meshgrid(f, f, indexing="ij"))
    edges = np.geomspace(band[0], band[1], 16)
    centres, means = [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        ring = (radius >= lo) & (radius < hi)
        if ring.any():
            centres.append(np.sqrt(lo * hi))
            means.append(power[ring].mean())
    means = np.maximum(np.asarray(means), 1e-30)
    return float(np.polyfit(np.log(centres), np.log(means), 1)[0])


def flat_share(image: np.ndarray, *, block: int = 8) -> float:
    """Share of ``block`` × ``block`` tiles whose display luminance has σ < 1/255."""
    v = _display(image) @ np.array([0.2126, 0.7152, 0.0722])
    h, w = (v.shape[0] // block) * block, (v.shape[1] // block) * block
    tiles = v[:h, :w].reshape(h // block, block, w // block, block)
    return float(np.mean(tiles.std(axis=(1, 3)) < 1.0 / 255))


def colourfulness(image: np.ndarray) -> float:
    """Hasler & Süsstrunk's colourfulness M = √(σ_rg² + σ_yb²) + 0.3·√(μ_rg² + μ_yb²), rg = R − G,
    yb = ½(R + G) − B, on 8-bit display values (M ≈ 0 grey, 33 "moderately", 59 "quite",
    82 "highly", 109 "extremely colourful")."""
    rgb = _display(image) * 255.0
    rg = rgb[..., 0] - rgb[..., 1]
    yb = 0.5 * (rgb[..., 0] + rgb[..., 1]) - rgb[..., 2]
    return float(np.hypot(rg.std(), yb.std()) + 0.3 * np.hypot(rg.mean(), yb.mean()))


def firefly_share(luminance: np.ndarray) -> float:
    """Share of pixels above 4× the median of their 5 × 5 neighbourhood, above the frame's
    median and above twice the brightest of their 8 neighbours: isolated bright outliers (a
    firefly), not the noise of dark areas nor the corner of a bright patch or lamp (whose
    5 × 5 median is dark too, but whose neighbours are as bright).

    Parameters
    ----------
    luminance : numpy.ndarray
        (H, W) linear luminance (any unit): a render's radiance summed over bands, or
        :func:`display_luminance` of a photograph.

    Examples
    --------
    >>> import numpy as np
    >>> frame = np.ones((20, 20)); frame[10, 10] = 50.0
    >>> firefly_share(frame)
    0.0025
    """
    import cv2

    lum = np.ascontiguousarray(luminance, dtype=np.float32)
    local = cv2.medianBlur(lum, 5)
    ring = np.ones((3, 3), np.uint8)
    ring[1, 1] = 0
    neighbours = cv2.dilate(lum, ring, borderType=cv2.BORDER_REFLECT)  # the brightest of the 8 around
    return float(np.mean((lum > 4 * local) & (lum > np.median(lum)) & (lum > 2 * neighbours)))


def raw_levels(mosaic: np.ndarray, black, white: float) -> tuple[float, float]:
    """Median and 99th percentile of a RAW as fractions of full scale, (DN − black)/(white − black)."""
    x = (np.asarray(mosaic, dtype=np.float64) - np.mean(black)) / (float(white) - float(np.mean(black)))
    return float(np.median(x)), float(np.percentile(x, 99))


def image_statistics(image: np.ndarray) -> dict:
    """Every display statistic of an image (8-bit or float display sRGB)."""
    return {"median_L": median_lightness(image), "clipped": clipped_share(image),
            "spectrum_slope": spectrum_slope(image), "flat": flat_share(image),
            "colourfulness": colourfulness(image), "fireflies": firefly_share(display_luminance(image))}
