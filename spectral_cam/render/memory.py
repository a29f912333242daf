"""Memory a render needs, estimated before Mitsuba starts, against what the machine has.

A frame too large for memory crashes Mitsuba's process (measured: 20000 × 20000 px segfaults;
4000 × 3000 at 1 spp under a 6 GB limit too), so :func:`check_render_memory` refuses it
first, with the estimate and the remedy.

References
----------
.. [1] Linux kernel documentation, ``/proc/meminfo`` (MemAvailable) and cgroup v2
   ``memory.max``/``memory.current``; POSIX ``getrlimit(RLIMIT_AS)``.
"""

from __future__ import annotations

import math
import resource
from pathlib import Path

from ..errors import ConfigError

__all__ = ["estimate_render_bytes", "available_bytes", "check_render_memory"]

#: Peak resident memory per megapixel of a render → expose → develop job, measured on the
#: 31-band default (1.36 GB/MP at 1 and 2 MP, 4 spp), rounded up.
BYTES_PER_MEGAPIXEL = 1.5e9
#: The process before the frame: Python, NumPy, Mitsuba's JIT, colour-science (measured ≈ 0.3 GB).
BASE_BYTES = 0.5e9


def estimate_render_bytes(width_px: int, height_px: int) -> float:
    """Peak memory (bytes) of a job on a ``width_px`` × ``height_px`` frame."""
    return BASE_BYTES + BYTES_PER_MEGAPIXEL * width_px * height_px / 1e6


def _cgroup_bytes() -> float:
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        used = float(Path("/sys/fs/cgroup/memory.current").read_text())
    except (OSError, ValueError):
        return math.inf
    return math.inf if limit == "max" else float(limit) - used


def _meminfo_bytes() -> float:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return float(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return math.inf


def available_bytes() -> float:
    """Memory this process may still use: the least of the system's available memory, the
    cgroup's headroom and the address-space limit (``ulimit -v``); inf where none is known."""
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    rlimit = math.inf if soft == resource.RLIM_INFINITY else float(soft)
    return min(_meminfo_bytes(), _cgroup_bytes(), rlimit)


def check_render_memory(width_px: int, height_px: int, *, what: str = "this frame") -> None:
    """Refuse a frame whose job would not fit in memory.

    Raises
    ------
    ConfigError
        With the estimate, what is available and what to change.
    """
    need, have = estimate_render_bytes(width_px, height_px), available_bytes()
    if need > have:
        side = max(2, int(math.sqrt(max(have - BASE_BYTES, 0.0) / BYTES_PER_MEGAPIXEL * 1e6)))
        raise ConfigError(
            f"{what} ({width_px} × {height_px} px) needs about {need / 1e9:.1f} GB of memory and "
            f"{have / 1e9:.1f} GB are available; lower sensor.width_px/height_px (about {side} × {side} px "
            f"fits) or free memory")
