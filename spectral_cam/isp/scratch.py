"""One thread's reusable float32 buffers, shared by the demosaicers that work in row bands on
threads (:mod:`spectral_cam.isp.demosaic`, :mod:`spectral_cam.isp.rcd`): a module of its own so
that neither imports the other for it."""

from __future__ import annotations

import numpy as np

__all__ = ["Scratch", "band_edges", "run_bands"]

_F32 = np.float32


class Scratch:
    """One thread's named buffers, reused from band to band: ``scratch(key, shape)`` is a
    C-contiguous float32 (or ``dtype``) array of that shape whose contents are undefined; a
    key asked for with a smaller shape gets a view of the same memory."""

    def __init__(self):
        self._buffers: dict[tuple, np.ndarray] = {}
        self._views: dict[tuple, np.ndarray] = {}

    def __call__(self, key: str, shape: tuple[int, ...], dtype=_F32) -> np.ndarray:
        view = self._views.get((key, shape, dtype))
        if view is None:
            size = int(np.prod(shape))
            buffer = self._buffers.get((key, dtype))
            if buffer is None or buffer.size < size:
                buffer = self._buffers[key, dtype] = np.empty(size, dtype)
            view = self._views[key, shape, dtype] = buffer[:size].reshape(shape)
        return view


def band_edges(height: int, band_rows: int, workers: int) -> tuple[list[int], int]:
    """Row edges of the bands a frame of ``height`` rows is cut into, and the threads to use:
    about ``band_rows`` rows a band, each thread the same number of bands; bands down to a
    quarter of that when there are fewer than threads; never under 2 rows."""
    n_bands = max(1, round(height / band_rows), min(workers, height // max(band_rows // 4, 1)))
    if n_bands > workers:
        n_bands = -(-n_bands // workers) * workers
    n_bands = min(n_bands, max(height // 2, 1))
    return [height * k // n_bands for k in range(n_bands + 1)], min(workers, n_bands)


def run_bands(band, edges, workers: int) -> None:
    """Call ``band(y0, y1, scratch)`` for each band between consecutive ``edges``, the bands split
    into ``workers`` runs of neighbours, each run on a thread with its own :class:`Scratch`
    (NumPy and OpenCV release the GIL)."""
    n_bands = len(edges) - 1

    def run(k: int) -> None:
        scratch = Scratch()
        for n in range(n_bands * k // workers, n_bands * (k + 1) // workers):
            band(edges[n], edges[n + 1], scratch)

    if workers == 1:
        run(0)
        return
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max_workers=workers) as pool:
        list(pool.map(run, range(workers)))
