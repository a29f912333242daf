"""Mitsuba variant choice: CUDA, then LLVM (libLLVM >= 16, probed in a child process), then scalar.

An older libLLVM aborts the whole process inside drjit, so the LLVM variant is tried in a
child first (docs/design.md, "Pitfalls"). The CUDA backend is probed in a child too. Each
probe costs a child interpreter that imports drjit (and, for LLVM, Mitsuba and a 2×2
render): 0.3–0.7 s per command. Its answer is therefore cached on disk, per environment
(:func:`probe_key`): ``$SPECTRAL_CAM_CACHE_DIR``, else ``$XDG_CACHE_HOME/spectral_cam``, else
``~/.cache/spectral_cam``, file ``variant_probe.json``. A cached answer is used only when
its whole key (Python, Mitsuba and drjit versions, the probe itself, and the libraries
drjit would load) equals this environment's; anything else (no file, a corrupt file, another
key) probes again. Only a definite answer is stored (the probe passed, exited with "no
usable backend", or crashed in native code); a timeout or an interrupted probe is not. A
cache folder that cannot be written costs only the probe.

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3 renderer, https://mitsuba-renderer.org (variants).
.. [2] drjit-core, ``jitc_llvm_api_init`` and ``jitc_find_library`` (src/llvm_api.cpp,
   src/init.cpp): libLLVM is ``$DRJIT_LIBLLVM_PATH``, else ``dlopen("libLLVM.so")`` (the
   dynamic loader: ``LD_LIBRARY_PATH``, ``/etc/ld.so.cache``, the default folders), else the
   newest ``/usr/lib/{x86_64-linux-gnu,aarch64-linux-gnu,wsl/lib}/libLLVM*.so.*``; libcuda
   likewise with ``DRJIT_LIBCUDA_PATH`` and ``libcuda.so``.
.. [3] XDG Base Directory Specification 0.8, ``$XDG_CACHE_HOME``.
"""

from __future__ import annotations

import contextlib
import datetime
import functools
import glob
import hashlib
import json
import os
import platform
import signal
import subprocess
import sys
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

from ..errors import ConfigError, RenderError

__all__ = ["choose_variant", "choose_variant_record", "probe_cache_path", "probe_key",
           "set_render_threads", "deterministic_threads", "MIN_LLVM_MAJOR", "CACHE_DIR_ENV"]

#: Oldest libLLVM that drjit's LLVM backend works with (older ones abort the process).
MIN_LLVM_MAJOR = 16
#: Environment variable naming the folder of spectral_cam's caches (the variant probe's).
CACHE_DIR_ENV = "SPECTRAL_CAM_CACHE_DIR"
_CACHE_FILE = "variant_probe.json"
_CACHE_SCHEMA = 1
#: Environments remembered in one cache file (several virtual environments may share it).
_MAX_ENTRIES = 32
#: Folders the dynamic loader and drjit's own glob search for libLLVM / libcuda (Linux).
_LIBRARY_DIRS = ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib/wsl/lib",
                 "/lib/x86_64-linux-gnu", "/lib/aarch64-linux-gnu", "/usr/lib64", "/lib64",
                 "/usr/lib", "/lib", "/usr/local/lib")
#: Exit code of a probe that found no usable backend (a definite "no").
_NO_BACKEND = 3
#: A probe killed by one of these crashed in native code (drjit aborts with libLLVM < 16):
#: a definite "no". Any other signal (SIGINT, SIGTERM, SIGKILL) is an interruption.
_CRASH_SIGNALS = tuple(int(s) for s in (signal.SIGABRT, signal.SIGSEGV, signal.SIGILL,
                                        signal.SIGBUS, signal.SIGFPE))


# ----------------------------------------------------------------------------- probes
_LLVM_PROBE = r"""
import sys
import drjit as dr
version = dr.detail.llvm_version()
if version is None or version[0] < {min_major}:
    sys.exit({no_backend})
import mitsuba as mi
mi.set_variant("llvm_ad_spectral")
scene = mi.load_dict({{"type": "scene", "sensor": {{"type": "perspective",
    "film": {{"type": "specfilm", "width": 2, "height": 2,
              "b": {{"type": "spectrum", "value": [(500, 1.0), (510, 1.0)]}}}}}},
    "integrator": {{"type": "path"}}, "light": {{"type": "constant"}}}})
mi.render(scene, spp=4)
""".format(min_major=MIN_LLVM_MAJOR, no_backend=_NO_BACKEND)

_CUDA_PROBE = ("import drjit as dr, sys; "
               f"sys.exit(0 if dr.has_backend(dr.JitBackend.CUDA) else {_NO_BACKEND})")

_PROBES = {"llvm": _LLVM_PROBE, "cuda": _CUDA_PROBE}


@dataclass(frozen=True)
class Probe:
    """The answer of one backend probe.

    Attributes
    ----------
    usable : bool
        Whether the backend works in this environment.
    source : str
        ``"cache"`` (read from the probe cache), ``"probe"`` (a child process ran now) or
        ``"probe (not cached)"`` (the child timed out, could not start or was interrupted,
        taken as unusable for this process only; or the environment could not be read
        into a key).
    detail : str
        The child's outcome, e.g. ``"exit 0"``, ``"exit 3 (no usable backend)"``,
        ``"signal 6 (crashed)"``.
    """

    usable: bool
    source: str
    detail: str


def _run_probe(backend: str) -> tuple[bool, bool, str]:
    """Run the ``backend`` probe in a child interpreter: (usable, definite, detail).

    A child, because drjit with libLLVM < 16 aborts the whole process ("Cannot select
    fminimum"), which must not take this one down.
    """
    env = dict(os.environ)
    loader_path = _loader_library_path()
    if loader_path is None:  # the dynamic loader's path as this process started (see there)
        env.pop("LD_LIBRARY_PATH", None)
    else:
        env["LD_LIBRARY_PATH"] = loader_path
    try:
        done = subprocess.run([sys.executable, "-c", _PROBES[backend]], capture_output=True, timeout=120,
                              env=env, check=False)
    except subprocess.TimeoutExpired:
        return False, False, "timed out after 120 s"
    except OSError as exc:
        return False, False, f"could not start: {exc}"
    code = done.returncode
    if code == 0:
        return True, True, "exit 0"
    if code == _NO_BACKEND:
        return False, True, f"exit {code} (no usable backend)"
    if code < 0 and -code in _CRASH_SIGNALS:
        return False, True, f"signal {-code} (crashed)"
    return False, False, f"exit {code}"


@functools.lru_cache(maxsize=None)
def _probe(backend: str) -> Probe:
    """Whether ``backend`` ("llvm" or "cuda") works: the disk cache's answer when its key
    matches this environment, else a child-process probe (stored when definite)."""
    try:
        key = probe_key(backend)
    except (OSError, ValueError):  # an unreadable environment: probe, and store nothing
        key = None
    cached = _read_cached(key) if key is not None else None
    if cached is not None:
        return Probe(cached[0], "cache", cached[1])
    usable, definite, detail = _run_probe(backend)
    if definite and key is not None:
        _write_cached(key, usable, detail)
        return Probe(usable, "probe", detail)
    return Probe(usable, "probe (not cached)", detail)


def _llvm_usable() -> bool:
    """Whether the LLVM backend works (libLLVM >= 16 renders a 2×2 spectral scene)."""
    return _probe("llvm").usable


def _cuda_usable() -> bool:
    """Whether drjit has a CUDA device."""
    return _probe("cuda").usable


# ----------------------------------------------------------------------------- cache key
def _version(distribution: str) -> str | None:
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return None


def _loader_library_path() -> str | None:
    """``LD_LIBRARY_PATH`` as this process started: what its dynamic loader searches.

    glibc reads it once at start-up; a later change to ``os.environ`` (OpenCV's ``cv2``
    adds its own folder when imported) does not move this process's search, so it must not
    change the cache key, nor the probe's child. Linux keeps the initial environment in
    ``/proc/self/environ``; elsewhere ``os.environ`` is read.
    """
    try:
        initial = Path("/proc/self/environ").read_bytes()
    except OSError:
        return os.environ.get("LD_LIBRARY_PATH")
    for item in initial.split(b"\0"):
        if item.startswith(b"LD_LIBRARY_PATH="):
            return os.fsdecode(item[len(b"LD_LIBRARY_PATH="):])
    return None


def _file_state(path: str) -> list:
    """[path, resolved path, size, mtime_ns] of a file (size and mtime None if missing)."""
    real = os.path.realpath(path)
    try:
        stat = os.stat(real)
    except OSError:
        return [path, real, None, None]
    return [path, real, stat.st_size, stat.st_mtime_ns]


def _library_states(stem: str) -> list[list]:
    """Every ``<stem>*.so*`` the dynamic loader or drjit's glob could pick, with its state."""
    folders = [*(_loader_library_path() or "").split(os.pathsep), *_LIBRARY_DIRS]
    seen: dict[str, None] = {}
    for folder in folders:
        if folder and os.path.isdir(folder):
            seen.setdefault(os.path.realpath(folder))
    states = []
    for folder in seen:
        for path in sorted(glob.glob(os.path.join(glob.escape(folder), f"{stem}*.so*"))):
            states.append(_file_state(path))
    return states


def _env_library(variable: str) -> list | None:
    value = os.environ.get(variable, "")
    return _file_state(value) if value else None


def probe_key(backend: str) -> dict:
    """What a probe's answer depends on, read without importing drjit or Mitsuba.

    Parameters
    ----------
    backend
        ``"llvm"`` or ``"cuda"``.

    Returns
    -------
    dict
        JSON-ready: the probe's source (hashed), this interpreter (``sys.prefix``, the
        resolved ``sys.executable``, version, machine), the Mitsuba and drjit versions
        (package metadata), the loader's ``LD_LIBRARY_PATH`` (as the process started, see
        :func:`_loader_library_path`) and ``/etc/ld.so.cache`` state, and the libraries drjit could
        load ([2]_): ``$DRJIT_LIB<LLVM|CUDA>_PATH`` and every ``libLLVM*.so*`` /
        ``libcuda*.so*`` in the loader's and drjit's folders, each with its resolved path,
        size and modification time. For CUDA also ``CUDA_VISIBLE_DEVICES``, the NVIDIA
        driver version (``/proc/driver/nvidia/version``) and the GPU device nodes.

    References
    ----------
    .. [2] drjit-core, ``jitc_find_library`` (the search for libLLVM and libcuda).
    """
    if backend not in _PROBES:
        raise ValueError(f"backend {backend!r}: valid: {', '.join(_PROBES)}")
    key = {
        "schema": _CACHE_SCHEMA,
        "backend": backend,
        "probe": hashlib.sha256(_PROBES[backend].encode()).hexdigest()[:16],
        "python": [sys.prefix, os.path.realpath(sys.executable), sys.version, platform.machine()],
        "mitsuba": _version("mitsuba"),
        "drjit": _version("drjit"),
        "ld_library_path": _loader_library_path(),
        "ld_so_cache": _file_state("/etc/ld.so.cache"),
    }
    if backend == "llvm":
        key["env_library"] = _env_library("DRJIT_LIBLLVM_PATH")
        key["libraries"] = _library_states("libLLVM")
    else:
        key["env_library"] = _env_library("DRJIT_LIBCUDA_PATH")
        key["libraries"] = _library_states("libcuda")
        key["cuda_visible_devices"] = os.environ.get("CUDA_VISIBLE_DEVICES")
        try:
            key["driver"] = Path("/proc/driver/nvidia/version").read_text(errors="replace").strip()
        except OSError:
            key["driver"] = None
        key["devices"] = sorted(glob.glob("/dev/nvidia*") + glob.glob("/dev/dxg"))
    return key


def _digest(key: dict) -> str:
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()


# ----------------------------------------------------------------------------- cache file
def probe_cache_path() -> Path:
    """The variant probe cache: ``variant_probe.json`` in ``$SPECTRAL_CAM_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/spectral_cam``, else ``~/.cache/spectral_cam`` ([3]_; an empty or
    relative ``XDG_CACHE_HOME`` is ignored, as the specification says).

    Delete the file to make the next render probe again.

    References
    ----------
    .. [3] XDG Base Directory Specification 0.8.
    """
    folder = os.environ.get(CACHE_DIR_ENV, "")
    if folder:
        return Path(folder).expanduser() / _CACHE_FILE
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    base = Path(xdg) if xdg and os.path.isabs(xdg) else Path.home() / ".cache"
    return base / "spectral_cam" / _CACHE_FILE


def _read_entries() -> dict:
    """The cache file's entries; {} when it is missing, unreadable or not ours."""
    try:
        data = json.loads(probe_cache_path().read_text())
    except (OSError, UnicodeDecodeError, ValueError, RuntimeError):
        return {}
    if not isinstance(data, dict) or data.get("schema") != _CACHE_SCHEMA or not isinstance(data.get("entries"), dict):
        return {}
    return data["entries"]


def _read_cached(key: dict) -> tuple[bool, str] | None:
    """(usable, detail) stored for exactly ``key``, or None."""
    entry = _read_entries().get(_digest(key))
    if (isinstance(entry, dict) and entry.get("key") == key and isinstance(entry.get("usable"), bool)
            and isinstance(entry.get("detail", ""), str)):
        return entry["usable"], entry.get("detail", "")
    return None


def _write_cached(key: dict, usable: bool, detail: str) -> None:
    """Store a definite answer, replacing the file atomically; never raises for the file
    system (a read-only or full cache folder only means probing again next time)."""
    from ..io import atomic_path

    entries = _read_entries()
    entries[_digest(key)] = {"key": key, "usable": usable, "detail": detail,
                             "probed_at": datetime.datetime.now(datetime.UTC).isoformat()}
    if len(entries) > _MAX_ENTRIES:  # keep the newest
        newest = sorted(entries.items(), key=lambda item: str(item[1].get("probed_at", "")
                                                              if isinstance(item[1], dict) else ""))
        entries = dict(newest[-_MAX_ENTRIES:])
    text = json.dumps({"schema": _CACHE_SCHEMA, "entries": entries}, indent=1, sort_keys=True)
    try:
        with atomic_path(probe_cache_path()) as tmp:
            tmp.write_text(text)
    except OSError:
        pass


# ----------------------------------------------------------------------------- variants
def choose_variant_record(requested: str = "auto") -> tuple[str, dict]:
    """The Mitsuba variant to render with, and how it was chosen.

    Parameters
    ----------
    requested
        ``"auto"`` or a spectral Mitsuba variant name (``render.variant``).

    Returns
    -------
    variant : str
        As :func:`choose_variant`.
    record : dict
        In the shape of ``model_decisions`` entries: ``choice``, ``reason``, ``requested``,
        ``probes`` (per backend consulted: ``usable``, ``source`` = ``"cache"`` |
        ``"probe"`` | ``"probe (not cached)"``, ``detail``) and ``from_cache`` (every probe
        consulted was answered by the cache; also true when none was needed).

    Raises
    ------
    ConfigError
        A non-spectral variant, or one this Mitsuba build lacks (the message lists the
        valid ones).
    RenderError
        ``llvm_*`` requested where libLLVM >= 16 does not work.
    """
    import mitsuba as mi

    via_env = requested == "auto" and bool(os.environ.get("SPECTRAL_CAM_VARIANT"))
    requested = os.environ.get("SPECTRAL_CAM_VARIANT", requested) if requested == "auto" else requested
    if requested != "auto" and "spectral" not in requested:
        raise ConfigError(f"Mitsuba variant {requested!r} (render.variant or SPECTRAL_CAM_VARIANT) must be "
                          "a spectral one, e.g. 'llvm_ad_spectral' or 'scalar_spectral'")
    available = mi.variants()
    probes: dict[str, Probe] = {}

    def usable(backend: str) -> bool:
        probes[backend] = _probe(backend)
        return probes[backend].usable

    if requested != "auto":
        if requested not in available:
            raise ConfigError(
                f"render.variant = {requested!r} is not in this Mitsuba build; valid: auto, "
                + ", ".join(v for v in available if "spectral" in v)
            )
        if requested.startswith("llvm") and not usable("llvm"):
            raise RenderError(
                f"{requested} needs libLLVM >= {MIN_LLVM_MAJOR} (apt-get install libllvm19); "
                "use render.variant = 'scalar_spectral' or 'auto'"
            )
        variant = requested
        reason = "set by SPECTRAL_CAM_VARIANT" if via_env else "set by render.variant"
    elif "cuda_ad_spectral" in available and usable("cuda"):
        variant, reason = "cuda_ad_spectral", "auto: a CUDA device works"
    elif "llvm_ad_spectral" in available and usable("llvm"):
        variant, reason = "llvm_ad_spectral", f"auto: no CUDA device; libLLVM >= {MIN_LLVM_MAJOR} works"
    else:
        missing = [f"{name} (not in this Mitsuba build)" if name not in available
                   else ("no CUDA device" if name.startswith("cuda") else f"no working libLLVM >= {MIN_LLVM_MAJOR}")
                   for name in ("cuda_ad_spectral", "llvm_ad_spectral")]
        variant, reason = "scalar_spectral", "auto: " + "; ".join(missing)
    record = {
        "choice": variant,
        "reason": reason,
        "requested": requested,
        "probes": {name: {"usable": p.usable, "source": p.source, "detail": p.detail} for name, p in probes.items()},
        "from_cache": all(p.source == "cache" for p in probes.values()),
    }
    return variant, record


def choose_variant(requested: str = "auto") -> str:
    """The Mitsuba variant to render with.

    ``"auto"`` picks ``cuda_ad_spectral`` where a CUDA device works, else
    ``llvm_ad_spectral`` where libLLVM ≥ 16 works, else ``scalar_spectral``. The
    environment variable ``SPECTRAL_CAM_VARIANT`` overrides ``"auto"``. The probes'
    answers are cached on disk per environment (:func:`probe_cache_path`);
    :func:`choose_variant_record` also says how the variant was chosen.
    """
    return choose_variant_record(requested)[0]


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


@contextlib.contextmanager
def deterministic_threads(enabled: bool):
    """Run the block on one renderer thread when ``enabled`` (``render.deterministic``), then
    restore the thread count.

    What Dr.Jit's threads sum in their own order can differ in its last bits from run to run
    under contention, and a path tracer turns a last bit into another path where a choice
    (a BSDF lobe, Russian roulette) sits on a threshold. Measured on the tabletop (96 × 64,
    16 spp, two busy processes, 8 renderer threads on 2 cores): Mitsuba's own vertex normals
    (``Mesh::recompute_vertex_normals``, an atomic scatter-add) changed in 6 % of a torus's
    values at each scene load, and ~1 % of the pixels by up to 50 % (up to 3 % after the
    adaptive median of means); the presets now give their own normals
    (:func:`spectral_cam.presets.meshes.vertex_normals`), and 8 of 8 renders per estimator,
    10 of 10 at 480 × 320 and 64 spp, and 3 re-renders of a job's scene.toml (DNG bytes) were
    identical; an XML scene's PLY or OBJ meshes without normals get the same
    (:func:`.scene_dict.fix_computed_normals`). The film's scatter-add does not move: a pass's
    2^k samples of a pixel stay in one of Dr.Jit's blocks with the box filter
    (:func:`.scene_dict.power_of_two_at_most`), and a moving mesh is handed its own normals back
    with each sub-frame's vertices (:class:`.motion.ObjectMotion`). What can still follow the
    threads' timing is what we do not build (a user's Python plugin): on one thread the blocks run
    in order, so the same scene.toml gives the same bytes under any load, at the cost of the other
    cores.

    References
    ----------
    .. [1] drjit documentation, ``drjit.ReduceMode`` and ``drjit.set_thread_count``;
       Mitsuba 3, ``ImageBlock::put`` and ``Mesh::recompute_vertex_normals``
       (``scatter_reduce(ReduceOp::Add, ...)``).
    """
    if not enabled:
        yield
        return
    import drjit

    threads = drjit.thread_count()
    drjit.set_thread_count(1)
    try:
        yield
    finally:
        drjit.set_thread_count(threads)
