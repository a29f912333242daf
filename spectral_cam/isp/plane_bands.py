"""The machinery of the demosaicers written on the four CFA planes (``bilinear``, ``malvar2004``,
``menon2007``): :func:`by_planes` runs a per-site function on cache-sized row bands of the mirror-padded
mosaic on threads and interleaves its colours straight into the output; :func:`check_bayer_mosaic` is
the input check every Bayer method shares.
"""

from __future__ import annotations

import numpy as np

from ..cfa import check_cfa
from ..errors import ConfigError
from .scratch import Scratch as _Scratch, band_edges, run_bands

__all__ = ["BAND_ROWS", "by_planes", "check_bayer_mosaic"]

_F32 = np.float32

#: Output rows per band for the linear methods: a band's planes and intermediates stay in the
#: CPU cache, and the bands are shared among threads.
BAND_ROWS = 64


def by_planes(mosaic: np.ndarray, cfa: str, sites, *, pad: int, offset: int, band_rows: int = BAND_ROWS,
              workers: int | None = None) -> np.ndarray:
    """Run a demosaicer written on the four CFA planes over row bands on parallel threads.

    The mosaic is mirror-padded about its edge pixels (BORDER_REFLECT_101, which keeps the
    CFA phase) by ``pad`` pixels and shifted so that the padded mosaic starts on a red site;
    each band of output rows is cut from it with ``pad`` rows of context on either side (made
    only for the band: the padded frame is never formed), split into its R, G-in-red-rows,
    G-in-blue-rows and B planes, and handed to ``sites``, whose per-site colours are
    interleaved straight into the output with ``cv2.merge`` (no full-frame masks, no per-channel
    strided writes). Bands run in order on each thread and reuse that thread's buffers.

    Parameters
    ----------
    mosaic
        (H, W) float32 mosaic, C-contiguous.
    cfa
        Bayer tile at the top-left pixel (checked).
    sites
        ``sites(R, Gr, Gb, B, scratch) -> (at_R, at_Gr, at_Gb, at_B)``, each a triple of
        (r, g, b) arrays of the band's plane grid, whose element ``[i, j]`` is plane sample
        ``[i + offset, j + offset]``; ``scratch`` is :class:`_Scratch`.
    pad
        Context (pixels, even): the output at a pixel depends on the mosaic within ``pad``.
    offset
        Plane samples that ``sites`` leaves out at the band's top and left.
    band_rows
        Output rows per band, about (the frame is cut into equal bands, as many for each thread).
    workers
        Threads (default: the CPUs).
    """
    import os

    import cv2

    height, width = mosaic.shape
    ry, rx = divmod(cfa.index("R"), 2)
    top, left = pad + ry, pad + rx
    right = pad + (width + left) % 2
    wq = (width + left + right) // 2
    out = np.empty((height, width, 3), _F32)
    edges, workers = band_edges(height, band_rows, max(1, workers or os.cpu_count() or 1))
    pairs = width // 2
    # the output's pixel pairs (x, x + 1), x even, as sites (b, j) of the padded planes
    b0, j0 = left % 2, left // 2 - offset
    b1, j1 = (left + 1) % 2, (left + 1) // 2 - offset

    def band(y0: int, y1: int, scratch: _Scratch) -> None:
        p0 = (y0 + top - pad) // 2 * 2  # padded rows [p0, p1) around output rows [y0, y1)
        p1 = -(-(y1 + top + pad) // 2) * 2
        first, last = max(p0 - top, 0), min(p1 - top, height)
        hq = (p1 - p0) // 2
        padded = scratch("padded", (2 * hq, 2 * wq))
        # mirrored rows are added only at the frame's top and bottom (first = 0, last = H)
        cv2.copyMakeBorder(mosaic[first:last], first - (p0 - top), p1 - top - last, left, right,
                           cv2.BORDER_REFLECT_101, dst=padded)
        planes = [scratch(key, (hq, wq)) for key in ("R", "Gr", "Gb", "B")]
        cv2.split(padded[0::2].reshape(hq, wq, 2), planes[:2])
        cv2.split(padded[1::2].reshape(hq, wq, 2), planes[2:])
        values = sites(*planes, scratch)
        for ys in range(y0, min(y0 + 2, y1)):
            parity = (ys + top) % 2
            i = (ys + top - p0) // 2 - offset
            rows = slice(i, i + (y1 - ys + 1) // 2)
            first_site, second_site = values[2 * parity + b0], values[2 * parity + b1]
            if pairs:
                # every other row, each row's pixel pairs as 6 channels: a view of the output
                dst = out[ys:y1:2, :2 * pairs].reshape(-1, pairs, 6)
                src = ([c[rows, j0:j0 + pairs] for c in first_site]
                       + [c[rows, j1:j1 + pairs] for c in second_site])
                if not np.may_share_memory(dst, out) or cv2.merge(src, dst=dst) is not dst:  # pragma: no cover
                    raise RuntimeError("cv2.merge did not write into the output")
            if width % 2:
                x = width - 1
                site, j = values[2 * parity + (x + left) % 2], (x + left) // 2 - offset
                for c in range(3):
                    out[ys:y1:2, x, c] = site[c][rows, j]

    run_bands(band, edges, workers)
    return out


def check_bayer_mosaic(mosaic: np.ndarray, cfa: str) -> tuple[np.ndarray, str]:
    """``mosaic`` as C-contiguous float32 and ``cfa`` checked, for a Bayer method.

    Raises
    ------
    ConfigError
        For a mosaic that is not 2-D or smaller than 2 × 2 pixels, or a CFA that is not Bayer.
    """
    mosaic = np.ascontiguousarray(mosaic, dtype=_F32)
    if mosaic.ndim != 2:
        raise ConfigError(f"demosaicing needs a 2-D mosaic; got shape {mosaic.shape}")
    if min(mosaic.shape) < 2:
        raise ConfigError(f"a Bayer mosaic needs at least 2×2 pixels; got {mosaic.shape}")
    return mosaic, check_cfa(cfa)
