"""Row chunks and threads for the sensor's per-pixel stages.

Chunks have a fixed size (:data:`CHUNK_PIXELS`) so results never depend on the number of
threads; NumPy releases the GIL inside each chunk.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

#: Pixels per work unit of the chunked, threaded stages (fixed so results do not depend
#: on the number of threads).
CHUNK_PIXELS = 1 << 16


# ----------------------------------------------------------------------------- integration
def workers_for(workers: int | None) -> int:
    if workers is not None:
        return max(1, int(workers))
    try:
        return max(1, min(len(os.sched_getaffinity(0)), 8))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, min(os.cpu_count() or 1, 8))


def row_chunks(height: int, width: int) -> list[tuple[int, int]]:
    rows = max(2, (CHUNK_PIXELS // max(width, 1)) // 2 * 2)
    return [(r, min(r + rows, height)) for r in range(0, height, rows)]


def run_chunks(func, items, workers: int):
    if workers == 1 or len(items) == 1:
        return [func(item) for item in items]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(func, items))
