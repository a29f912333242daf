"""Mitsuba variant choice: CUDA, then LLVM (libLLVM >= 16, probed in a child process), then scalar.

An older libLLVM aborts the whole process inside drjit, so the LLVM variant is tried in a
child first (docs/design.md, "Pitfalls").

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3 renderer, https://mitsuba-renderer.org (variants).
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys

from ..errors import ConfigError, RenderError

#: Oldest libLLVM that drjit's LLVM backend works with (older ones abort the process).
MIN_LLVM_MAJOR = 16


# ----------------------------------------------------------------------------- variants
_PROBE = r"""
import sys
import drjit as dr
version = dr.detail.llvm_version()
if version is None or version[0] < {min_major}:
    sys.exit(3)
import mitsuba as mi
mi.set_variant("llvm_ad_spectral")
scene = mi.load_dict({{"type": "scene", "sensor": {{"type": "perspective",
    "film": {{"type": "specfilm", "width": 2, "height": 2,
              "b": {{"type": "spectrum", "value": [(500, 1.0), (510, 1.0)]}}}}}},
    "integrator": {{"type": "path"}}, "light": {{"type": "constant"}}}})
mi.render(scene, spp=4)
"""


@functools.lru_cache(maxsize=None)
def _llvm_usable() -> bool:
    """Try the LLVM backend in a child process: with libLLVM < 16 drjit aborts the whole
    process ("Cannot select fminimum"), which must not take this one down."""
    try:
        result = subprocess.run(
            [sys.executable, "-c", _PROBE.format(min_major=MIN_LLVM_MAJOR)],
            capture_output=True, timeout=120,
        )
    except (OSError, subprocess.TimeoutExpired):
        return False
    return result.returncode == 0


@functools.lru_cache(maxsize=None)
def _cuda_usable() -> bool:
    code = "import drjit as dr, sys; sys.exit(0 if dr.has_backend(dr.JitBackend.CUDA) else 3)"
    try:
        return subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=120).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


def choose_variant(requested: str = "auto") -> str:
    """The Mitsuba variant to render with.

    ``"auto"`` picks ``cuda_ad_spectral`` where a CUDA device works, else
    ``llvm_ad_spectral`` where libLLVM ≥ 16 works, else ``scalar_spectral``. The
    environment variable ``SPECTRAL_CAM_VARIANT`` overrides ``"auto"``.
    """
    import mitsuba as mi

    requested = os.environ.get("SPECTRAL_CAM_VARIANT", requested) if requested == "auto" else requested
    if requested != "auto" and "spectral" not in requested:
        raise ConfigError(f"Mitsuba variant {requested!r} (render.variant or SPECTRAL_CAM_VARIANT) must be "
                          "a spectral one, e.g. 'llvm_ad_spectral' or 'scalar_spectral'")
    available = mi.variants()
    if requested != "auto":
        if requested not in available:
            raise ConfigError(
                f"render.variant = {requested!r} is not in this Mitsuba build; valid: auto, "
                + ", ".join(v for v in available if "spectral" in v)
            )
        if requested.startswith("llvm") and not _llvm_usable():
            raise RenderError(
                f"{requested} needs libLLVM >= {MIN_LLVM_MAJOR} (apt-get install libllvm19); "
                "use render.variant = 'scalar_spectral' or 'auto'"
            )
        return requested
    if "cuda_ad_spectral" in available and _cuda_usable():
        return "cuda_ad_spectral"
    if "llvm_ad_spectral" in available and _llvm_usable():
        return "llvm_ad_spectral"
    return "scalar_spectral"


def set_render_threads(threads: int | None) -> None:
    """Limit the renderer's worker threads (drjit's thread pool) to ``threads``; None or 0
    leaves them as they are. A dataset worker process sets it to its share of the cores.

    References
    ----------
    .. [1] drjit documentation, ``drjit.set_thread_count``.
    """
    if threads:
        import drjit

        if drjit.thread_count() != threads:
            drjit.set_thread_count(int(threads))
