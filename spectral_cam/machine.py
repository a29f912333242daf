"""What this machine leaves the process: available memory (the least of the system's, the
cgroup's and the address-space limit). Below every stage, so the render's plan and the sensor's
own checks read one answer.

References
----------
.. [1] Linux kernel documentation, ``/proc/meminfo`` (MemAvailable) and cgroup v2
   ``memory.max``/``memory.current``; POSIX ``getrlimit(RLIMIT_AS)``.
"""

from __future__ import annotations

import math
import resource
from pathlib import Path

__all__ = ["available_bytes"]


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
