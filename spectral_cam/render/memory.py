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

#: The process before the frame: Python, NumPy, Mitsuba's JIT and scene, colour-science
#: (measured 0.45–0.55 GB after a small render).
BASE_BYTES = 0.6e9
#: Mitsuba's own memory per pixel of one render call (film, wavefront, result tensor), 31
#: bands, 16 spp: bare ``mi.render`` peaks at 420–470 MB/MP (docs/bench/bench_render.csv). A
#: call covers one tile (:data:`~spectral_cam.render.scene_dict.TILE_PIXELS`) at most.
MITSUBA_BYTES_PER_CALL_PIXEL = 480.0
#: Bytes per pixel of the frame besides its radiance cube: depth, the sensor's rates and
#: mosaic, the ISP's float images, diffraction's band planes. Measured whole jobs (31 bands,
#: 4 spp, peak RSS): 0.88 GB at 1.06 MP, 1.31 GB at 2.55 MP, 2.93 GB at 12.1 MP, 9.58 GB at
#: 45.7 MP, i.e. 192 B/px beyond the first tile, 124 of them the cube; 100 keeps a margin.
PIPELINE_BYTES_PER_PIXEL = 100.0
#: ``lens.model = "layered"`` holds more per pixel: the depth layers being blurred and
#: composited (measured: 1.83 GB at 1.2 MP, 31 bands, f/2.8 dof_targets, against 0.88 GB
#: thin lens at 1.06 MP: ~780 B/px more), counted as this many radiance cubes plus the
#: 4²-sample depth probe.
LAYERED_EXTRA_CUBES = 6
LAYERED_DEPTH_BYTES_PER_PIXEL = 64.0


def estimate_render_bytes(width_px: int, height_px: int, channels: int = 31, *, layered: bool = False,
                          robust_passes: int = 1) -> float:
    """Peak memory (bytes) of a render → expose → develop job on a ``width_px`` ×
    ``height_px`` frame whose radiance has ``channels`` float32 values per pixel (31 bands by
    default; 6 for ``render.bands = "camera"``); ``layered`` for ``lens.model = "layered"``;
    ``robust_passes`` K > 1 for the adaptive median of means, which holds K pass images of a tile.

    The frame renders in tiles of at most
    :data:`~spectral_cam.render.scene_dict.TILE_PIXELS` pixels, so Mitsuba's share is one
    tile's; the whole frame holds its radiance cube and the pipeline's per-pixel arrays.

    Examples
    --------
    >>> round(estimate_render_bytes(8256, 5504) / 1e9, 1)  # a 45 MP full-frame sensor
    11.3
    """
    from .scene_dict import TILE_PIXELS

    pixels = float(width_px) * float(height_px)
    per_pixel = 4.0 * channels + PIPELINE_BYTES_PER_PIXEL
    if layered:
        per_pixel += LAYERED_EXTRA_CUBES * 4.0 * channels + LAYERED_DEPTH_BYTES_PER_PIXEL
    tile = min(pixels, TILE_PIXELS)
    robust = tile * 4.0 * channels * (robust_passes + 1) if robust_passes > 1 else 0.0
    return BASE_BYTES + pixels * per_pixel + tile * MITSUBA_BYTES_PER_CALL_PIXEL + robust


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


def check_render_memory(width_px: int, height_px: int, *, channels: int = 31, layered: bool = False,
                        what: str = "this frame", robust_passes: int = 1) -> None:
    """Refuse a frame whose job would not fit in memory (:func:`estimate_render_bytes`).

    Raises
    ------
    ConfigError
        With the estimate, what is available and what to change.
    """
    def need(width, height, channels=channels, layered=layered):
        return estimate_render_bytes(width, height, channels, layered=layered, robust_passes=robust_passes)

    have = available_bytes()
    if need(width_px, height_px) > have:
        side = 2
        while need(2 * side, 2 * side) <= have:
            side *= 2
        while need(side + 64, side + 64) <= have:
            side += 64
        remedies = [f"lower sensor.width_px/height_px (about {side} × {side} px fits)"]
        if layered:
            remedies.append(f"lens.model = \"thin\" (path-traced defocus: about "
                            f"{need(width_px, height_px, layered=False) / 1e9:.1f} GB)")
        if channels > 6:
            remedies.append(f"render.bands = \"camera\" (6 values a pixel instead of {channels}: about "
                            f"{need(width_px, height_px, 6) / 1e9:.1f} GB)")
        raise ConfigError(
            f"{what} ({width_px} × {height_px} px) needs about {need(width_px, height_px) / 1e9:.1f} GB of memory "
            f"and {have / 1e9:.1f} GB are available; {', or '.join(remedies)}; or free memory")
