"""Running a dataset: plan every item, skip finished ones, render the rest on an executor.

:func:`generate_dataset` holds the folder's lock, writes ``dataset.json``, plans each item
(:meth:`~spectral_cam.apps.dataset.spec.DatasetSpec.plan_item`), resumes complete items,
hands the others to a ``concurrent.futures.Executor`` (a Dask ``LocalCluster`` by default,
:func:`local_cluster`) as plain-data tasks (:func:`item_task`) run by :func:`render_item`,
resubmits an item whose worker died, keeps ``manifest.jsonl`` current and ends with the
contact sheet and blur chart (:mod:`spectral_cam.apps.dataset.sheets`). The cluster recipes
(SLURM, Kubernetes) are in the package docstring, :mod:`spectral_cam.apps.dataset`.

References
----------
.. [1] Rocklin, M. (2015). Dask: parallel computation with blocked algorithms and task
   scheduling. Proc. 14th Python in Science Conference, 130–136.
.. [2] Python ``concurrent.futures`` (PEP 3148); Dask ``Client.get_executor``.
"""

from __future__ import annotations

import collections
import concurrent.futures as cf
import contextlib
import itertools
import json
import os
import re
import shutil
import sys
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping, Sequence

from ...errors import ConfigError
from ...io import atomic_path
from ...job import RESULT_FILES
from ...progress import ProgressLine, duration
from ...records import json_ready, read_json, write_json
from ...render.variants import set_render_threads
from ...scene import scene_from_dict
from .labels import CLASS_LABELS, LABELS, file_check, spec_class_table, write_classes, write_item
from .card import metadata_rows, write_card, write_metadata
from .exports import export_into_dataset
from .hf import datasets_installed, write_parquet_shards, write_webdataset_shards
from .sheets import write_blur_chart, write_contact_sheet, write_label_preview
from .spec import DatasetSpec, ItemPlan

__all__ = ["DatasetSummary", "DatasetInterrupted", "generate_dataset", "item_task", "render_item", "local_cluster", "default_workers",
           "ProgressBar", "MANIFEST_EVERY_S", "open_executor", "plan_dataset", "PLANNED_SAMPLE"]

#: Seconds between manifest rewrites during a run (it is always written at the end).
MANIFEST_EVERY_S = 30.0
_MANIFEST_KEYS = ("index", "id", "split", "status", "resumed", "seed", "params", "files", "labels", "error", "attempts",
                  "seconds", "exposure_s", "variant", "file_checks", "path")


# ----------------------------------------------------------------------------- one item
def item_task(spec: DatasetSpec, plan: ItemPlan, output: str | Path, *,
              render_threads: int | None = None) -> dict:
    """The task :func:`render_item` takes for a planned item (plain data: it travels to the
    worker by pickling).

    Parameters
    ----------
    spec
        The dataset spec (its hash and outputs go into the item's meta.json).
    plan
        From :meth:`DatasetSpec.plan_item`; must have a scene (``plan.error`` None).
    output
        The dataset folder; the item goes to ``<output>/items/<id>``.
    render_threads
        Mitsuba threads on the worker (None: Mitsuba's default, all cores).

    Returns
    -------
    dict
        ``{"index", "id", "split", "seed", "params", "scene", "path", "outputs", "spec_hash",
        "render_threads", "measure_blur", "classes"}`` (``classes``: the spec's class map,
        :func:`~.labels.spec_class_table`, where an output names classes; else None).

    Raises
    ------
    ConfigError
        When the plan has no valid scene.
    """
    if plan.scene is None:
        raise ConfigError(f"item {plan.id} has no valid scene: {plan.error}")
    return {"index": plan.index, "id": plan.id, "split": spec.split_of(plan.index), "seed": plan.seed,
            "params": plan.params, "scene": plan.scene,
            "path": str(Path(output).resolve() / "items" / plan.id), "outputs": list(spec.outputs),
            "spec_hash": spec.hash, "render_threads": render_threads, "measure_blur": bool(spec.sweeps),
            "classes": _class_map(spec)}


def _class_map(spec: DatasetSpec) -> list[dict] | None:
    """The spec's class map (one per spec: its ids are the same for every item), where its outputs name classes."""
    if not set(spec.outputs) & set(CLASS_LABELS):
        return None
    if spec.hash not in _CLASS_MAPS:  # the hash holds everything the scenes come from
        _CLASS_MAPS[spec.hash] = spec_class_table(spec)
    return _CLASS_MAPS[spec.hash]


#: Class maps by spec hash (planning calls :func:`_class_map` once per item).
_CLASS_MAPS: dict[str, list[dict]] = {}


def render_item(task: Mapping[str, Any]) -> dict:
    """Render one dataset item on a worker; never raises for a bad item.

    Parameters
    ----------
    task
        From :func:`item_task`.

    Returns
    -------
    dict
        A manifest row: ``status`` "done" with ``files``, or "failed" with ``error`` (the
        exception and message) and ``traceback``; ``seconds`` on this worker.

    References
    ----------
    .. [1] Python ``concurrent.futures``: a task's return value travels back to the driver;
       catching here keeps one poison item from failing the whole run.
    """
    started = time.perf_counter()
    row = {"index": task["index"], "id": task["id"], "seed": task["seed"], "params": task["params"]}
    try:
        set_render_threads(task.get("render_threads"))
        config = scene_from_dict(task["scene"])
        record = {key: task[key] for key in ("index", "id", "seed", "spec_hash", "params")}
        meta = write_item(config, task["path"], outputs=task["outputs"], measure_blur=task.get("measure_blur", False),
                          dataset={**record, "outputs": list(task["outputs"])}, classes=task.get("classes"))
        row.update(status="done", files=meta["files"], error=None, exposure_s=meta["sensor"]["exposure_s"],
                   variant=meta["render"]["variant"], file_checks=meta["dataset"]["file_checks"],
                   labels=meta["dataset"]["labels"])
    except Exception as exc:  # a poison item: record it, never take the run down
        row.update(status="failed", files=[], error=f"{type(exc).__name__}: {exc}",
                   traceback=traceback.format_exc(limit=8))
    row["seconds"] = time.perf_counter() - started
    row["worker_pid"] = os.getpid()
    return row


# ----------------------------------------------------------------------------- executors
class _InlineExecutor(cf.Executor):
    """Runs each task at submission, in this process (``--scheduler inline``)."""

    _max_workers = 1

    def submit(self, fn, /, *args, **kwargs):
        future: cf.Future = cf.Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # noqa: BLE001 - handed to the future like any executor
            future.set_exception(exc)
        return future


def _usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


#: The interface a local cluster listens on: this machine only.
LOOPBACK = "127.0.0.1"


@contextlib.contextmanager
def local_cluster(workers: int | None = None, *, dashboard: bool = False, **worker_kwargs) -> Iterator[Any]:
    """A Dask ``LocalCluster`` for dataset items, yielding its ``Client``.

    Worker processes are spawned (not forked: Mitsuba's and drjit's thread pools do not
    survive a fork), one Dask thread each so each worker renders one item at a time, and
    the scheduler hands out one task per thread (``worker-saturation`` 1.0) and reports a
    worker's death at once (``allowed_failures`` 0), so :func:`generate_dataset` resubmits
    exactly the item that was running. The workers' numerical libraries get the worker's
    share of the cores (``OMP_NUM_THREADS`` …), and Dask's default
    ``MALLOC_TRIM_THRESHOLD_`` is not set: it turns off glibc's dynamic mmap threshold, so
    every large NumPy temporary is mapped and faulted in anew (measured: the per-band
    diffraction FFTs ran 3× slower).

    Every server (scheduler, nannies, workers) listens on the loopback interface only. The
    scheduler always opens an HTTP port (distributed starts one for its routes); without
    ``dashboard`` it has a random port and no routes, so it serves nothing; with
    ``dashboard`` it serves Dask's dashboard on http://127.0.0.1:8787.

    Parameters
    ----------
    workers
        Worker processes (default :func:`default_workers`: one per usable core).
    dashboard
        Serve Dask's dashboard on 127.0.0.1:8787 (``spectral-cam dataset --dashboard``).
    **worker_kwargs
        Passed to ``LocalCluster`` (e.g. ``env={...}``, ``memory_limit="8GB"``).

    Raises
    ------
    ConfigError
        Without dask.distributed, or for a worker count below 1.

    References
    ----------
    .. [1] Dask.distributed documentation: LocalCluster, Nanny, scheduler configuration
       (``distributed.scheduler.worker-saturation``, ``allowed-failures``,
       ``distributed.nanny.pre-spawn-environ``).
    .. [2] glibc manual, §3.2.3.7 "Memory Allocation Tunables" (setting M_TRIM_THRESHOLD
       disables the dynamic mmap threshold).
    """
    try:
        import dask
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise ConfigError("the Dask executor needs dask.distributed: pip install 'spectral_cam[dask]' "
                          "(or run with --scheduler inline)") from None
    workers = default_workers() if workers is None else workers
    if not isinstance(workers, int) or workers < 1:
        raise ConfigError(f"--workers {workers!r}: must be a whole number >= 1")
    share = str(max(1, _usable_cores() // workers))
    settings = {"distributed.worker.multiprocessing-method": "spawn",
                "distributed.scheduler.worker-saturation": 1.0,
                "distributed.nanny.pre-spawn-environ": {"MALLOC_TRIM_THRESHOLD_": None, "OMP_NUM_THREADS": share,
                                                        "MKL_NUM_THREADS": share, "OPENBLAS_NUM_THREADS": share}}
    if not dashboard:  # no pages: identity, worker, log and exception pages stay unserved
        settings.update({"distributed.scheduler.http.routes": [], "distributed.worker.http.routes": []})
    with dask.config.set(settings), _interrupts_ignored():
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host=LOOPBACK,
                               dashboard_address=f"{LOOPBACK}:{8787 if dashboard else 0}",
                               worker_dashboard_address=None,
                               scheduler_kwargs={"allowed_failures": 0, "dashboard": dashboard},
                               **worker_kwargs)
        try:
            client = Client(cluster)
        except BaseException:  # never leave spawned workers behind
            cluster.close()
            raise
    try:
        yield client
    except BaseException:  # an interrupt: stop the workers mid-item, before anything tells them so
        # quiet for the rest of the process, not only while closing: the client's event loop thread
        # logs the transfers the kill broke (CommClosedError tracebacks) after close returns (seen under load)
        _silence_dask()
        _kill_workers(cluster)
        client.close()
        cluster.close()
        raise
    client.close()
    cluster.close()


def _kill_workers(cluster) -> None:
    """SIGKILL a local cluster's worker processes now, their nannies told not to restart them.

    Closing the client first cancelled each running render (a warning from every worker) and
    closing the scheduler first broke their heartbeats (a traceback from every worker); a worker
    waited 4 s for a render to notice before its nanny killed it anyway. The items they were
    rendering are lost either way (their staging folders are removed after); finished items are
    on disk already.

    References
    ----------
    .. [1] Dask.distributed, ``Nanny`` (``_on_worker_exit``: a nanny closing gracefully does not
       restart its worker).
    """
    import signal

    from distributed.core import Status

    for nanny in list(getattr(cluster, "workers", {}).values()):
        try:
            pid = nanny.pid
            nanny.status = Status.closing_gracefully
            if pid:
                os.kill(pid, signal.SIGKILL)
        except (AttributeError, ValueError, TypeError, OSError):  # another distributed: it closes as it does
            continue


@contextlib.contextmanager
def _interrupts_ignored() -> Iterator[None]:
    """SIGINT ignored while a local cluster spawns its workers, which inherit the ignored
    disposition: a Ctrl-C at the terminal (sent to the whole process group) then reaches only
    this process, which keeps what is done and shuts the workers down. Without it each worker
    printed its own KeyboardInterrupt traceback and Dask its cancellations. A Ctrl-C in these
    seconds of start-up is lost (Python cannot defer an ignored signal). Main thread only.

    References
    ----------
    .. [1] POSIX ``execve``: signals set to be ignored stay ignored in the new image; Python
       installs its KeyboardInterrupt handler only where SIGINT is at its default.
    """
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _silence_dask() -> dict:
    """Silence Dask's, tornado's and asyncio's loggers (workers "still alive ..., killing", and the
    tracebacks of results in transfer when the scheduler closes, which its event loop logs through
    tornado); returns their levels before."""
    import logging

    loggers = [logging.getLogger(name) for name in ("distributed", "tornado", "asyncio")]
    levels = {logger: logger.level for logger in loggers}
    for logger in loggers:
        logger.setLevel(logging.CRITICAL + 1)
    return levels


def default_workers() -> int:
    """LocalCluster workers by default: one per usable core, each rendering with one Mitsuba
    thread. Measured on 2 cores at 256 × 256 px / 16 spp, two single-threaded workers
    rendered 115 items/min against 90 for one worker with two threads (the sensor, ISP and
    file stages run in parallel too); with large frames, fewer workers bound the memory
    (``--workers``)."""
    return max(1, _usable_cores())


@contextlib.contextmanager
def _executor(executor, scheduler, workers, dashboard: bool = False) -> Iterator[tuple[cf.Executor, int, int | None]]:
    """(executor, tasks kept in flight, Mitsuba threads per item) for the run."""
    if executor is not None:
        window = 2 * max(1, int(getattr(executor, "_max_workers", 0) or _dask_threads(executor) or 4))
        yield executor, window, None
        return
    if scheduler == "inline":
        yield _InlineExecutor(), 1, None
        return
    if scheduler:
        try:
            from dask.distributed import Client
        except ImportError:
            raise ConfigError("--scheduler needs dask.distributed: pip install 'spectral_cam[dask]'") from None
        try:
            client = Client(scheduler, timeout="30s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise ConfigError(f"cannot reach the Dask scheduler at {scheduler!r} ({exc}); give its address "
                              f"as tcp://HOST:PORT, or 'inline', or leave --scheduler out for a local "
                              f"cluster") from None
        try:
            yield client.get_executor(pure=False), 2 * max(1, sum(client.nthreads().values())), None
        finally:
            client.close()
        return
    workers = default_workers() if workers is None else workers
    with local_cluster(workers, dashboard=dashboard) as client:
        threads = max(1, _usable_cores() // workers)
        yield client.get_executor(pure=False), 2 * workers, threads


def open_executor(executor=None, scheduler: str | None = None, workers: int | None = None):
    """The executor a run submits to (the one given, ``"inline"``, a Dask scheduler's address,
    or a local cluster of ``workers``), as a context manager yielding (executor, tasks kept in
    flight, Mitsuba threads per task or None): what :func:`generate_dataset` and
    ``spectral-cam sequence`` share."""
    return _executor(executor, scheduler, workers)


def _require_dask() -> None:
    """Refuse a run that needs dask.distributed where it is not installed."""
    try:
        import dask.distributed  # noqa: F401
    except ImportError:
        raise ConfigError("the Dask executor needs dask.distributed: pip install 'spectral_cam[dask]' "
                          "(or run with --scheduler inline)") from None


def _dask_threads(executor) -> int:
    client = getattr(executor, "_client", None)
    try:
        return sum(client.nthreads().values()) if client is not None else 0
    except Exception:  # a closed client: fall back to the default window
        return 0


# ----------------------------------------------------------------------------- progress
class ProgressBar(ProgressLine):
    """Items done of a total, failures, rate and ETA, on one stderr line
    (:class:`spectral_cam.progress.ProgressLine`).

    The rate counts items processed by workers in this run (not resumed items, not items
    whose values were rejected before rendering).

    Parameters
    ----------
    total : int
        Items in the dataset.
    resumed, rejected : int
        Items found complete, and items whose values were rejected before rendering.
    enabled, stream, every_s
        As for :class:`~spectral_cam.progress.ProgressLine`.
    width : int
        Characters of the bar.
    """

    def __init__(self, total: int, *, resumed: int = 0, rejected: int = 0, enabled: bool = True,
                 stream=None, every_s: float = 10.0, width: int = 28):
        super().__init__(enabled=enabled, stream=stream, every_s=every_s)
        self.total, self.resumed, self.rejected, self.width = total, resumed, rejected, width
        self.done = self.failed = 0

    @property
    def finished(self) -> int:
        """Items finished: resumed, rejected, done and failed."""
        return self.resumed + self.rejected + self.done + self.failed

    def line(self) -> str:
        """The status line: bar, counts, items per minute and ETA."""
        elapsed = self.elapsed_s
        processed = self.done + self.failed
        rate = processed / elapsed * 60.0 if elapsed > 0 and processed else 0.0
        remaining = self.total - self.finished
        filled = int(round(self.width * self.finished / self.total)) if self.total else self.width
        parts = [f"dataset [{'#' * filled}{'-' * (self.width - filled)}] {self.finished}/{self.total} items"]
        if self.resumed:
            parts.append(f"{self.resumed} resumed")
        if self.failed + self.rejected:
            parts.append(f"{self.failed + self.rejected} failed")
        if rate:
            parts.append(f"{rate:.1f} items/min")
        if remaining:
            parts.append(f"ETA {duration(remaining / (rate / 60.0))}" if rate else "ETA ?")
        else:
            parts.append(duration(elapsed))
        return " · ".join(parts)

    def update(self, *, done: int = 0, failed: int = 0) -> None:
        """Count finished items and redraw (on a terminal) or log (every ``every_s``)."""
        self.done += done
        self.failed += failed
        self.show(self.line())

    def close(self) -> None:
        """Print the final line (ending the redrawn one on a terminal)."""
        self.show(self.line(), final=True)


# ----------------------------------------------------------------------------- the run
@dataclass
class DatasetSummary:
    """What a :func:`generate_dataset` run did.

    Attributes
    ----------
    output
        The dataset folder.
    items
        Items in the dataset.
    rendered, resumed, failed
        Items rendered in this run, found complete and skipped, and failed.
    retried
        Resubmissions after a worker died.
    seconds
        Wall time of the run.
    manifest
        The manifest file.
    errors
        ``{item id: error}`` of the failed items.
    """

    output: Path
    items: int
    rendered: int = 0
    resumed: int = 0
    failed: int = 0
    retried: int = 0
    seconds: float = 0.0
    manifest: Path | None = None
    errors: dict = field(default_factory=dict)

    @property
    def items_per_minute(self) -> float:
        """Items rendered in this run per minute of wall time."""
        return 60.0 * self.rendered / self.seconds if self.seconds > 0 else 0.0


def _plan_items(spec: DatasetSpec, total: int, per_point: int, output: Path, rows: dict, bar: ProgressBar, *,
                force: bool) -> Iterator[dict]:
    """Plan items one by one, lazily: record finished (resumed) and invalid items in ``rows``
    and yield a task for every item to render, so rendering starts before a large dataset
    is planned to its end and memory grows with the items done, not the items asked for."""
    items_dir = output / "items"
    for index in range(total):
        plan = spec.plan_item(index, per_point)
        base = {"index": index, "id": plan.id, "split": spec.split_of(index), "seed": plan.seed,
                "params": plan.params, "path": f"items/{plan.id}", "attempts": 0}
        if plan.scene is None:
            rows[index] = {**base, "status": "failed", "resumed": False, "files": [], "error": plan.error}
            bar.rejected += 1
            continue
        meta = None if force else _finished(items_dir / plan.id, spec.hash, spec.outputs, plan.seed, plan.params)
        if meta is not None:
            rows[index] = _done_row(base, meta, resumed=True)
            bar.resumed += 1
            continue
        # until a worker reports, the manifest (rewritten every MANIFEST_EVERY_S) says pending
        rows[index] = {**base, "status": "pending", "resumed": False, "files": [], "error": None}
        yield item_task(spec, plan, output)


def _done_row(base: Mapping[str, Any], meta: Mapping[str, Any], *, resumed: bool) -> dict:
    """The manifest row of an item found complete on disk (from its meta.json)."""
    item_id = base["id"]
    return {**base, "status": "done", "resumed": resumed, "files": [f"items/{item_id}/{name}" for name in meta["files"]],
            "error": None, "exposure_s": meta.get("sensor", {}).get("exposure_s"),
            "seconds": meta.get("timings_s", {}).get("total"), "variant": meta.get("render", {}).get("variant"),
            "file_checks": meta["dataset"]["file_checks"], "labels": meta["dataset"].get("labels")}


def _finished(item_dir: Path, spec_hash: str, outputs: Sequence[str], seed: int, params: Mapping) -> dict | None:
    """The item's meta when its folder is complete for this spec, this item's planned seed
    and parameters (a sweep re-plans items when ``-n`` changes), and these outputs, and every
    file still has the size and SHA-256 it was written with."""
    meta = read_json(item_dir / "meta.json")
    if not isinstance(meta, dict) or not isinstance(meta.get("dataset"), dict):
        return None
    if meta["dataset"].get("spec_hash") != spec_hash or not set(outputs) <= set(meta["dataset"].get("outputs", [])):
        return None
    if meta["dataset"].get("seed") != seed or meta["dataset"].get("params") != json_ready(params):
        return None
    checks = meta["dataset"].get("file_checks")
    if not isinstance(checks, dict):
        return None
    for name in meta.get("files", []):
        if name == "meta.json":
            continue
        path = item_dir / name
        if name not in checks or not path.is_file() or path.stat().st_size != checks[name].get("bytes"):
            return None
        if file_check(path) != checks[name]:
            return None
    return meta


def _warn_on_another_variant(rows: Mapping[int, dict], progress: bool) -> None:
    """Warn when the items kept from an earlier run were rendered with another Mitsuba variant
    than the new ones will be: the same seed draws different samples on scalar and LLVM, so
    the dataset would mix two noise realisations without saying so."""
    import warnings

    kept = {r.get("variant") for r in rows.values() if r.get("resumed") and r.get("variant")}
    new = {r.get("variant") for r in rows.values() if not r.get("resumed") and r.get("variant")}
    others = sorted(kept - new)
    if new and others:
        message = (f"resumed items were rendered with {', '.join(others)}, the items rendered now use "
                   f"{', '.join(sorted(new))}: "
                   "the same seed draws other samples on another variant (the manifest records each item's); "
                   "use --force to render every item on this one")
        warnings.warn(message, ResumeVariantWarning, stacklevel=3)
        if progress:
            print(f"dataset: warning: {message}", file=sys.stderr)


class ResumeVariantWarning(UserWarning):
    """A resumed dataset mixes items of two Mitsuba variants."""


def _remove_partials(items_dir: Path, item_id: str | None = None) -> None:
    """Remove staging leftovers (``.<id>.partial-*``, ``.<id>.old-*``) of dead attempts."""
    if not items_dir.is_dir():
        return
    pattern = re.compile(rf"^\.{re.escape(item_id) if item_id else '[0-9]+'}\.(partial|old)-")
    for entry in items_dir.iterdir():
        if pattern.match(entry.name):
            shutil.rmtree(entry, ignore_errors=True) if entry.is_dir() else entry.unlink(missing_ok=True)


@contextlib.contextmanager
def _lock(output: Path) -> Iterator[None]:
    import fcntl

    output.mkdir(parents=True, exist_ok=True)
    handle = open(output / ".dataset.lock", "w")
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise ConfigError(f"another spectral-cam dataset run is writing {output}; wait for it or "
                              f"choose another -o") from None
        yield
    finally:
        handle.close()


def _write_manifest(path: Path, rows: Mapping[int, dict]) -> None:
    """One JSON line per item, in index order, atomically."""
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as handle:
            for index in sorted(rows):
                row = {k: rows[index].get(k) for k in _MANIFEST_KEYS}
                handle.write(json.dumps(json_ready(row), ensure_ascii=False, allow_nan=False, default=str) + "\n")


def generate_dataset(
    spec: DatasetSpec,
    output: str | Path,
    *,
    n: int | None = None,
    executor: cf.Executor | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    retries: int = 2,
    force: bool = False,
    progress: bool = True,
    render_threads: int | None = None,
    item_function: Callable[[Mapping[str, Any]], dict] = render_item,
    dashboard: bool = False,
) -> DatasetSummary:
    """Render a dataset: plan every item, skip finished ones, run the rest, write the manifest.

    Parameters
    ----------
    spec
        From :func:`~spectral_cam.apps.dataset.load_spec`.
    output
        Dataset folder (created; resumed when it holds a dataset of the same spec).
    n
        Items (per grid point when the spec sweeps); default the spec's ``[dataset] n``.
    executor
        Any ``concurrent.futures.Executor`` (e.g. ``dask.distributed.Client.get_executor(
        pure=False)``, a ``ProcessPoolExecutor`` with the spawn context); not shut down here.
    scheduler
        Without ``executor``: a Dask scheduler address (``tcp://host:8786``), ``"inline"``
        (this process, one item after another), or None for a new ``LocalCluster``.
    workers
        LocalCluster worker processes (default :func:`default_workers`).
    retries
        Resubmissions of an item whose worker died (any exception from the executor
        itself; exceptions inside the item are recorded, not retried).
    force
        Render every item again, and accept a folder made from another spec.
    progress
        Show the progress bar on stderr.
    render_threads
        Mitsuba threads per item on the workers; default: the usable cores over the
        workers for a new LocalCluster, else Mitsuba's own default (every core).
    item_function
        What the executor runs per item: a picklable function of an :func:`item_task` dict
        returning a manifest row, :func:`render_item` unless wrapped (e.g. to observe or
        fault-inject a worker).
    dashboard
        With a new LocalCluster: serve Dask's dashboard on http://127.0.0.1:8787 (every
        server listens on the loopback interface; see :func:`local_cluster`).

    Returns
    -------
    DatasetSummary

    Raises
    ------
    ConfigError
        For an invalid count, a folder holding another spec's dataset (without ``force``),
        or a folder another run is writing.
    DatasetInterrupted
        On Ctrl-C or SIGTERM (a ``KeyboardInterrupt``): the manifest, metadata.jsonl and the
        card list the items done (a worker's item completed as the interrupt came counts), a
        local cluster's staging folders are removed, and the same call resumes.

    Examples
    --------
    >>> import tempfile
    >>> from spectral_cam.apps.dataset import spec_from_dict
    >>> spec = spec_from_dict({"sensor": {"width_px": 24, "height_px": 16}, "render": {"spp": 4},
    ...                        "lens": {"f_number": {"log_uniform": [2.0, 8.0]}}})
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     summary = generate_dataset(spec, folder, n=2, scheduler="inline", progress=False)
    >>> summary.items, summary.rendered, summary.failed
    (2, 2, 0)

    References
    ----------
    .. [1] Python ``concurrent.futures`` (PEP 3148); Dask ``Client.get_executor``.
    """
    started = time.perf_counter()
    output = Path(output).resolve()
    total = spec.item_count(n)
    per_point = total // spec.grid_size
    if not isinstance(retries, int) or retries < 0:
        raise ConfigError(f"--retries {retries!r}: must be a whole number >= 0")
    if render_threads is not None and (not isinstance(render_threads, int) or render_threads < 1):
        raise ConfigError(f"render_threads {render_threads!r}: must be a whole number >= 1 (or None)")
    if executor is None and scheduler != "inline":
        _require_dask()  # before the folder, its lock or a manifest row exists
    items_dir = output / "items"
    summary = DatasetSummary(output=output, items=total)
    with _lock(output):
        info_path = output / "dataset.json"
        previous = read_json(info_path)
        if isinstance(previous, dict) and previous.get("spec_hash") != spec.hash and not force:
            raise ConfigError(
                f"{output} holds a dataset of another spec (hash {str(previous.get('spec_hash'))[:12]}, this spec "
                f"{spec.hash[:12]}); choose a new -o, or pass --force to render every item again")
        write_json({"spec_hash": spec.hash, "items": total, "per_grid_point": per_point, "spec": spec.to_dict()},
                   info_path)
        _remove_partials(items_dir)
        if force and items_dir.is_dir():  # items of an earlier, larger run are not this dataset's
            for stale in items_dir.iterdir():
                if stale.is_dir() and stale.name.isdigit() and int(stale.name) >= total:
                    shutil.rmtree(stale, ignore_errors=True)

        rows: dict[int, dict] = {}
        bar = ProgressBar(total, enabled=progress)
        manifest = output / "manifest.jsonl"
        try:
            _run(spec, total, per_point, output, rows, bar, summary, manifest, force=force, executor=executor,
                 scheduler=scheduler, workers=workers, dashboard=dashboard, render_threads=render_threads,
                 item_function=item_function, retries=retries)
        except KeyboardInterrupt:  # Ctrl-C or SIGTERM: keep what is done, say how to go on
            if executor is None and scheduler in (None, "inline"):  # our workers are gone: their staging too
                _remove_partials(items_dir)
            bar.done += _settle_pending(rows, items_dir, spec)
            bar.close()
            _write_manifest(manifest, rows)
            write_metadata(output, rows)
            _write_classes(output, spec, rows)
            write_card(output, spec, rows, spec_hash=spec.hash)  # the shards on disk are the last complete run's
            raise DatasetInterrupted(output, done=sum(1 for r in rows.values() if r["status"] == "done"),
                                     failed=sum(1 for r in rows.values() if r["status"] == "failed"),
                                     total=total) from None
        summary.resumed = sum(1 for r in rows.values() if r.get("resumed"))
        if summary.resumed and summary.rendered:
            _warn_on_another_variant(rows, progress)
        bar.close()
        summary.failed = sum(1 for r in rows.values() if r["status"] == "failed")
        summary.errors = {r["id"]: r["error"] for r in sorted(rows.values(), key=lambda r: r["index"])
                          if r["status"] == "failed"}
        write_metadata(output, rows)  # what loaders read: Hugging Face's ImageFolder, the card's readers
        _write_classes(output, spec, rows)  # before the card, which lists its classes
        try:
            if any(r["status"] == "done" for r in rows.values()):
                _write_shards(output, spec, rows)
                _write_summaries(output, sweeps=bool(spec.sweeps))
                if spec.exports:  # [dataset] exports: COCO, depth PNGs, .flo into DIR/exports/
                    export_into_dataset(output, dict(spec.exports))
        finally:  # last: it links the shards, previews and exports (and lists the items should they fail)
            write_card(output, spec, rows, spec_hash=spec.hash)
    summary.seconds = time.perf_counter() - started
    return summary


def _run(spec, total, per_point, output, rows, bar, summary, manifest, *, force, executor, scheduler, workers,
         dashboard, render_threads, item_function, retries) -> None:
    """Plan, resume and render every item into ``rows``; the manifest is written however it ends."""
    items_dir = output / "items"
    bar.update()  # at once: planning a large dataset is itself work
    planned = _plan_items(spec, total, per_point, output, rows, bar, force=force)
    first = next(planned, None)  # plans (and skips finished items) up to the first to render
    if first is not None:
        _check_disk(first, total - sum(1 for r in rows.values() if r["status"] != "pending"), output)
    try:
        if first is not None:
            with _executor(executor, scheduler, workers, dashboard) as (pool, window, threads):
                tasks = ({**task, "render_threads": render_threads or threads}
                         for task in itertools.chain([first], planned))
                _run_tasks(pool, item_function, tasks, rows, items_dir, window=window, retries=retries,
                           bar=bar, summary=summary, manifest=manifest, owned=executor is None)
    finally:
        _write_manifest(manifest, rows)
        summary.manifest = manifest


def _write_classes(output: Path, spec: DatasetSpec, rows: dict) -> None:
    """classes.json (:func:`~.labels.write_classes`) where the outputs name classes; a stale one removed otherwise."""
    if _class_map(spec) is None or write_classes(output, _class_map(spec), rows) is None:
        (output / "classes.json").unlink(missing_ok=True)


class DatasetInterrupted(KeyboardInterrupt):
    """A dataset run stopped by Ctrl-C or SIGTERM. The finished items are kept (and listed in the
    manifest, metadata.jsonl and the card); running the same command again resumes.

    Attributes
    ----------
    output : Path
        The dataset folder.
    done, failed, total : int
        Items done (complete on disk), failed, and in the dataset.
    """

    def __init__(self, output: Path, *, done: int, failed: int, total: int):
        self.output, self.done, self.failed, self.total = output, done, failed, total
        super().__init__(self.message)

    @property
    def message(self) -> str:
        """``"11/12 items done; rerun the same command to resume"`` (with the failures, if any)."""
        failed = f", {self.failed} failed" if self.failed else ""
        return (f"{self.done}/{self.total} items done{failed}, kept in {self.output}; "
                f"rerun the same command to resume")


def _settle_pending(rows: dict, items_dir: Path, spec: DatasetSpec) -> int:
    """After an interrupt: an item still "pending" whose folder a worker completed before the
    run stopped (its result never came back) is done; the manifest says so, as a rerun would
    find. Returns how many such items there were."""
    settled = 0
    for index, row in rows.items():
        if row["status"] != "pending":
            continue
        meta = _finished(items_dir / row["id"], spec.hash, spec.outputs, row["seed"], row["params"])
        if meta is not None:
            rows[index] = _done_row(row, meta, resumed=False)
            settled += 1
    return settled


#: Items whose capture plans stand for the whole dataset in ``--dry-run`` (each renders its depth probe).
PLANNED_SAMPLE = 3


def plan_dataset(spec: DatasetSpec, *, n: int | None = None, workers: int | None = None,
                 scheduler: str | None = None) -> str:
    """What ``spectral-cam dataset --dry-run`` prints: the capture plans of the first
    :data:`PLANNED_SAMPLE` valid items (:func:`spectral_cam.render.plan.make_plan`), and the
    dataset's total from them: time over the cluster's workers (``workers`` local processes,
    default :func:`default_workers`; one process for ``scheduler="inline"``; per item for a
    remote scheduler, whose size is not known here), peak memory per worker, and the files'
    size. Nothing but the probes the plans need and their cost probes is rendered.

    Raises
    ------
    ConfigError
        For an invalid count, or when none of the first items has a valid scene.
    """
    from ...render.plan import make_plan

    total = spec.item_count(n)
    per_point = total // spec.grid_size
    plans, errors = [], []
    for index in range(total):
        item = spec.plan_item(index, per_point)
        if item.scene is None:
            errors.append(f"{item.id}: {item.error}")
        else:
            outputs = [name for name in spec.outputs if name in RESULT_FILES]
            plans.append((item, make_plan(scene_from_dict(item.scene), outputs=outputs, measure=True)))
        if len(plans) == PLANNED_SAMPLE or len(errors) > 10 * PLANNED_SAMPLE:
            break
    if not plans:
        raise ConfigError(f"none of the first items has a valid scene: {'; '.join(errors[:3])}")
    time_s = sum(p.budget["time_s"] for _, p in plans) / len(plans)
    memory = max(p.budget["memory_bytes"] for _, p in plans)
    files = sum(sum(p.budget["outputs_bytes"].values()) + _label_bytes(item.scene, spec.outputs)
                for item, p in plans) / len(plans)
    lines = [f"item {item.id} {item.params}:\n  " + plan.summary().replace("\n", "\n  ") for item, plan in plans]
    parallel = 1 if scheduler == "inline" else (None if scheduler else (workers or default_workers()))
    where = (f"{parallel} worker process{'es' if parallel != 1 else ''}" if parallel else
             f"the cluster at {scheduler} (its size unknown here: time per item)")
    total_s = time_s * total / parallel if parallel else time_s
    lines.append(f"dataset: {total} items on {where}: about {total_s:.3g} s"
                 + (" per item" if not parallel else f" ({time_s:.3g} s an item)")
                 + f", peak memory about {memory / 1e9:.2g} GB a worker"
                 + (f" ({memory * parallel / 1e9:.2g} GB in all)" if parallel else "")
                 + f", files about {files * total / 1e9:.3g} GB (uncompressed: the labels' EXRs and PNGs compress); "
                 f"from the plans of {len(plans)} item(s)"
                 + (f"; {len(errors)} of the first {len(plans) + len(errors)} items invalid (recorded as failed, "
                    f"never rendered):" if errors else ""))
    lines += [f"  invalid item {error}" for error in errors[:5]]
    if len(errors) > 5:
        lines.append(f"  ... {len(errors) - 5} more")
    return "\n".join(lines)


def _label_bytes(scene: Mapping[str, Any], outputs) -> float:
    """Bytes of an item's labels beyond the render job's own files (which its plan sizes from the
    scene): each label's :meth:`~.labels.registry.Label.estimate_bytes` at the item's frame."""
    sensor = scene_from_dict(scene).sensor
    return sum(LABELS[name].estimate_bytes(sensor.width_px, sensor.height_px)
               for name in outputs if name not in RESULT_FILES)


def _check_disk(task: Mapping[str, Any], items: int, output: Path) -> None:
    """Refuse a dataset whose result files cannot fit on the disk, before rendering: the first
    item's files (:func:`spectral_cam.budget.estimate_result_bytes`; the labels besides them not
    counted, so it never refuses what fits) times the items left to render."""
    from ...io import check_free_disk
    from ...budget import estimate_result_bytes

    per_item = sum(estimate_result_bytes(scene_from_dict(task["scene"]),
                                         [name for name in task["outputs"] if name in RESULT_FILES]).values())
    check_free_disk(per_item * items, output, what=f"{items} items of about {per_item / 1e6:.3g} MB each",
                    remedy="free space, choose -o elsewhere, render fewer items (-n), or drop outputs such as "
                    "'radiance' (render.radiance_precision = 'half' halves it)")


def _run_tasks(pool, item_function, tasks, rows, items_dir, *, window, retries, bar, summary, manifest,
               owned: bool = False) -> None:
    """Keep ``window`` tasks in flight, drawing new ones from the (lazy) ``tasks`` iterator and
    resubmitting those whose worker died (``retries`` times). On the way out the tasks in flight
    are cancelled, except after an interrupt on an executor this run made (``owned``): closing it
    stops them, and a cancelled running task only makes each worker log a warning."""
    tasks = iter(tasks)
    pending: collections.deque = collections.deque()  # resubmissions first
    attempts: collections.Counter = collections.Counter()
    in_flight: dict[cf.Future, dict] = {}
    last_manifest = time.perf_counter()
    exhausted = False
    try:
        while pending or in_flight or not exhausted:
            while len(in_flight) < window:
                if pending:
                    task = pending.popleft()
                else:
                    task = next(tasks, None)
                    if task is None:
                        exhausted = True
                        break
                attempts[task["index"]] += 1
                _remove_partials(items_dir, task["id"])
                in_flight[pool.submit(item_function, task)] = task
            done, _ = cf.wait(list(in_flight), timeout=1.0, return_when=cf.FIRST_COMPLETED)
            for future in done:
                task = in_flight.pop(future)
                index = task["index"]
                try:
                    row = future.result()
                except Exception as exc:  # the worker died (KilledWorker, BrokenProcessPool, ...)
                    if attempts[index] <= retries:
                        summary.retried += 1
                        pending.appendleft(task)
                        continue
                    row = {"status": "failed", "files": [],
                           "error": f"worker lost {attempts[index]} times; last: {type(exc).__name__}: {exc}"}
                row = {**row, "index": index, "id": task["id"], "split": task.get("split"), "seed": task["seed"],
                       "params": task["params"],
                       "path": f"items/{task['id']}", "resumed": False, "attempts": attempts[index]}
                if row["status"] == "done":
                    row["files"] = [f"items/{task['id']}/{name}" for name in row["files"]]
                    summary.rendered += 1
                rows[index] = row
                bar.update(done=int(row["status"] == "done"), failed=int(row["status"] != "done"))
            if not done:
                bar.update()
            if time.perf_counter() - last_manifest > MANIFEST_EVERY_S:
                _write_manifest(manifest, rows)
                last_manifest = time.perf_counter()
    except KeyboardInterrupt:
        if not owned:
            for future in in_flight:
                future.cancel()
        raise
    except BaseException:
        for future in in_flight:
            future.cancel()
        raise


def _write_summaries(output: Path, *, sweeps: bool) -> None:
    """Contact sheet and label previews for every dataset; blur chart for sweeps (of the blur presets)."""
    write_contact_sheet(output)
    write_label_preview(output)
    if sweeps:
        write_blur_chart(output)


def _write_shards(output: Path, spec: DatasetSpec, rows: Mapping[int, dict]) -> None:
    """The Parquet shards of typed Hugging Face columns (where ``datasets`` is installed: the card
    says how to add them otherwise) and, with ``[dataset] webdataset = true``, the WebDataset tars;
    each rewritten whole from the finished items, one split after another."""
    metadata = metadata_rows(rows)
    splits = [name for name, _ in spec.splits]
    params = sorted({key for row in rows.values() for key in (row.get("params") or {})})
    if datasets_installed():
        write_parquet_shards(output, metadata, splits=splits, params=params, shard_items=spec.shard_items)
    if spec.webdataset:
        write_webdataset_shards(output, metadata, splits=splits, shard_items=spec.shard_items)
