"""Running a dataset: plan every item, skip finished ones, render the rest on an executor.

:func:`generate_dataset` holds the folder's lock, writes ``dataset.json``, plans each item
(:meth:`~spectral_cam.apps.dataset.spec.DatasetSpec.plan_item`), resumes complete items,
hands the others to a ``concurrent.futures.Executor`` (a Dask ``LocalCluster`` by default,
:func:`~.executors.local_cluster`) as plain-data tasks (:func:`~.tasks.item_task`) run by
:func:`~.tasks.render_item`, resubmits an item whose worker died, keeps ``manifest.jsonl`` current
and ends with metadata.jsonl, the shards, the contact sheet and blur chart
(:mod:`spectral_cam.apps.dataset.sheets`), the exports and the card. An interrupt (Ctrl-C,
SIGTERM) keeps every finished item and says so (:class:`DatasetInterrupted`).

The run's parts live beside it, and their public names are importable from here too: the executors
(:mod:`.executors`), an item's task and worker function (:mod:`.tasks`), the folder's lock, manifest
and resume checks (:mod:`.folder`), and the dry run and disk check (:mod:`.costs`). The cluster
recipes (SLURM, Kubernetes) are in the package docstring, :mod:`spectral_cam.apps.dataset`.

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
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

from ...errors import ConfigError
from ...progress import ProgressLine, duration
from .labels import write_classes
from .card import metadata_rows, write_card, write_metadata
from .costs import PLANNED_SAMPLE, check_disk, plan_dataset
from .executors import default_workers, local_cluster, open_executor, require_dask
from .exports import export_into_dataset
from .folder import (ResumeVariantWarning, claim_folder, done_row, finished_meta, folder_lock, remove_partials,
                     settle_pending, warn_on_another_variant, write_manifest)
from .hf import datasets_installed, write_parquet_shards, write_webdataset_shards
from .sheets import write_blur_chart, write_contact_sheet, write_label_preview
from .spec import DatasetSpec
from .tasks import class_map, item_task, render_item

__all__ = ["DatasetSummary", "DatasetInterrupted", "generate_dataset", "item_task", "render_item", "local_cluster", "default_workers",
           "ProgressBar", "MANIFEST_EVERY_S", "open_executor", "plan_dataset", "PLANNED_SAMPLE", "ResumeVariantWarning"]

#: Seconds between manifest rewrites during a run (it is always written at the end).
MANIFEST_EVERY_S = 30.0


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
        meta = None if force else finished_meta(items_dir / plan.id, spec.hash, spec.outputs, plan.seed, plan.params)
        if meta is not None:
            rows[index] = done_row(base, meta, resumed=True)
            bar.resumed += 1
            continue
        # until a worker reports, the manifest (rewritten every MANIFEST_EVERY_S) says pending
        rows[index] = {**base, "status": "pending", "resumed": False, "files": [], "error": None}
        yield item_task(spec, plan, output)


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
        require_dask()  # before the folder, its lock or a manifest row exists
    summary = DatasetSummary(output=output, items=total)
    with folder_lock(output):
        claim_folder(output, spec, total, per_point, force=force)
        rows: dict[int, dict] = {}
        bar = ProgressBar(total, enabled=progress)
        manifest = output / "manifest.jsonl"
        try:
            _run(spec, total, per_point, output, rows, bar, summary, manifest, force=force, executor=executor,
                 scheduler=scheduler, workers=workers, dashboard=dashboard, render_threads=render_threads,
                 item_function=item_function, retries=retries)
        except KeyboardInterrupt:  # Ctrl-C or SIGTERM: keep what is done, say how to go on
            raise _interrupted(output, spec, rows, bar, manifest, total,
                               ours=executor is None and scheduler in (None, "inline")) from None
        summary.resumed = sum(1 for r in rows.values() if r.get("resumed"))
        if summary.resumed and summary.rendered:
            warn_on_another_variant(rows, progress)
        bar.close()
        summary.failed = sum(1 for r in rows.values() if r["status"] == "failed")
        summary.errors = {r["id"]: r["error"] for r in sorted(rows.values(), key=lambda r: r["index"])
                          if r["status"] == "failed"}
        _write_results(output, spec, rows)
    summary.seconds = time.perf_counter() - started
    return summary


def _interrupted(output: Path, spec: DatasetSpec, rows: dict, bar: ProgressBar, manifest: Path, total: int, *,
                 ours: bool) -> DatasetInterrupted:
    """After an interrupt: the manifest, metadata.jsonl, classes.json and the card list what is done
    (the shards on disk stay the last complete run's); the exception to raise says so. ``ours``:
    the workers were this run's, so they are gone and so is their staging."""
    items_dir = output / "items"
    if ours:
        remove_partials(items_dir)
    bar.done += settle_pending(rows, items_dir, spec)
    bar.close()
    write_manifest(manifest, rows)
    write_metadata(output, rows)
    _write_classes(output, spec, rows)
    write_card(output, spec, rows, spec_hash=spec.hash)
    return DatasetInterrupted(output, done=sum(1 for r in rows.values() if r["status"] == "done"),
                              failed=sum(1 for r in rows.values() if r["status"] == "failed"), total=total)


def _write_results(output: Path, spec: DatasetSpec, rows: Mapping[int, dict]) -> None:
    """What a finished run writes from its rows: metadata.jsonl, classes.json, and (with an item
    done) the shards, contact sheet and previews, the exports; the card last."""
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


def _run(spec, total, per_point, output, rows, bar, summary, manifest, *, force, executor, scheduler, workers,
         dashboard, render_threads, item_function, retries) -> None:
    """Plan, resume and render every item into ``rows``; the manifest is written however it ends."""
    items_dir = output / "items"
    bar.update()  # at once: planning a large dataset is itself work
    planned = _plan_items(spec, total, per_point, output, rows, bar, force=force)
    first = next(planned, None)  # plans (and skips finished items) up to the first to render
    if first is not None:
        check_disk(first, total - sum(1 for r in rows.values() if r["status"] != "pending"), output)
    try:
        if first is None:
            return
        with _interrupt_latch() as latch:
            with open_executor(executor, scheduler, workers, dashboard=dashboard) as (pool, window, threads):
                tasks = ({**task, "render_threads": render_threads or threads}
                         for task in itertools.chain([first], planned))
                _run_tasks(pool, item_function, tasks, rows, items_dir, window=window, retries=retries,
                           bar=bar, summary=summary, manifest=manifest, owned=executor is None, latch=latch)
                latch.check()  # one swallowed as the loop's last futures were freed: the workers are still ours
            latch.check()  # one swallowed while the executor closed
    finally:
        write_manifest(manifest, rows)
        summary.manifest = manifest


def _write_classes(output: Path, spec: DatasetSpec, rows: dict) -> None:
    """classes.json (:func:`~.labels.write_classes`) where the outputs name classes; a stale one removed otherwise."""
    if class_map(spec) is None or write_classes(output, class_map(spec), rows) is None:
        (output / "classes.json").unlink(missing_ok=True)


# ----------------------------------------------------------------------------- the result loop
class _InterruptLatch:
    """Remembers an interrupt (SIGINT, SIGTERM) whose handler raised, so that :meth:`check` raises it
    again should it have been swallowed on its way up.

    Python runs a signal's handler in the main thread wherever that thread is, finalisers
    included, and an exception raised inside a finaliser (``__del__``, a weakref callback) is
    printed as "Exception ignored" and dropped. Between tiny items the driver frees each item's
    futures, and a Dask future's ``__del__`` releases its key in Python code (``Client._dec_ref``):
    a Ctrl-C landing there was lost, and the CLI's watchdog ended the run 10 s later with "no
    partial output was kept" (issue 41). Only interrupts a handler raised are latched: a handler
    that chooses not to raise is left to decide.

    References
    ----------
    .. [1] Python documentation, ``signal``: "Python signal handlers are always executed in the
       main Python thread"; ``sys.unraisablehook`` (exceptions raised in ``__del__`` are ignored).
    """

    def __init__(self):
        self.interrupt: KeyboardInterrupt | None = None

    def wrap(self, handler: Callable) -> Callable:
        """``handler`` (a callable signal handler), latching the interrupt it raises."""
        def latched(signum, frame):
            try:
                handler(signum, frame)
            except KeyboardInterrupt as exc:
                self.interrupt = exc
                raise
        return latched

    def check(self) -> None:
        """Raise the latched interrupt (a swallowed one: one on its way up never returns here)."""
        if self.interrupt is not None:
            raise self.interrupt.with_traceback(None)


@contextlib.contextmanager
def _interrupt_latch() -> Iterator[_InterruptLatch]:
    """An :class:`_InterruptLatch` on SIGINT's and SIGTERM's Python handlers while the run renders
    (main thread only; an ignored or default disposition is left as it is); the handlers are
    restored after."""
    import signal
    import threading

    latch = _InterruptLatch()
    previous = {}
    if threading.current_thread() is threading.main_thread():
        for signum in (signal.SIGINT, signal.SIGTERM):
            handler = signal.getsignal(signum)
            if callable(handler):
                previous[signum] = signal.signal(signum, latch.wrap(handler))
    try:
        yield latch
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


class _InFlight:
    """The tasks of a run between the (lazy) task iterator and their rows: up to ``window`` in
    flight, a task whose worker died resubmitted first (``retries`` times)."""

    def __init__(self, pool: cf.Executor, item_function: Callable, tasks, items_dir: Path, *, window: int,
                 retries: int):
        self.pool, self.item_function, self.tasks, self.items_dir = pool, item_function, iter(tasks), items_dir
        self.window, self.retries = window, retries
        self.pending: collections.deque = collections.deque()  # resubmissions first
        self.attempts: collections.Counter = collections.Counter()
        self.futures: dict[cf.Future, dict] = {}
        self.exhausted = False

    def busy(self) -> bool:
        """Tasks left: in flight, to resubmit, or still to draw."""
        return bool(self.pending or self.futures or not self.exhausted)

    def fill(self) -> None:
        """Submit tasks (resubmissions first) until ``window`` are in flight or none is left."""
        while len(self.futures) < self.window:
            if self.pending:
                task = self.pending.popleft()
            else:
                task = next(self.tasks, None)
                if task is None:
                    self.exhausted = True
                    break
            self.attempts[task["index"]] += 1
            remove_partials(self.items_dir, task["id"])
            self.futures[self.pool.submit(self.item_function, task)] = task

    def wait(self) -> set:
        """The futures done within a second (an empty set when none is)."""
        done, _ = cf.wait(list(self.futures), timeout=1.0, return_when=cf.FIRST_COMPLETED)
        return done

    def row(self, future: cf.Future, summary: DatasetSummary) -> dict | None:
        """The manifest row of a finished task, or None when its worker died and it is resubmitted."""
        task = self.futures.pop(future)
        index = task["index"]
        try:
            row = future.result()
        except Exception as exc:  # the worker died (KilledWorker, BrokenProcessPool, ...)
            if self.attempts[index] <= self.retries:
                summary.retried += 1
                self.pending.appendleft(task)
                return None
            row = {"status": "failed", "files": [],
                   "error": f"worker lost {self.attempts[index]} times; last: {type(exc).__name__}: {exc}"}
        row = {**row, "index": index, "id": task["id"], "split": task.get("split"), "seed": task["seed"],
               "params": task["params"],
               "path": f"items/{task['id']}", "resumed": False, "attempts": self.attempts[index]}
        if row["status"] == "done":
            row["files"] = [f"items/{task['id']}/{name}" for name in row["files"]]
            summary.rendered += 1
        return row

    def cancel(self) -> None:
        """Cancel every task in flight."""
        for future in self.futures:
            future.cancel()


def _run_tasks(pool, item_function, tasks, rows, items_dir, *, window, retries, bar, summary, manifest,
               owned: bool = False, latch: _InterruptLatch | None = None) -> None:
    """Keep ``window`` tasks in flight, drawing new ones from the (lazy) ``tasks`` iterator and
    resubmitting those whose worker died (``retries`` times); after each round, raise an
    interrupt a finaliser swallowed (``latch``). On the way out the tasks in flight
    are cancelled, except after an interrupt on an executor this run made (``owned``): closing it
    stops them, and a cancelled running task only makes each worker log a warning."""
    flight = _InFlight(pool, item_function, tasks, items_dir, window=window, retries=retries)
    last_manifest = time.perf_counter()
    try:
        while flight.busy():
            flight.fill()
            done = flight.wait()
            for future in done:
                row = flight.row(future, summary)
                if row is not None:
                    rows[row["index"]] = row
                    bar.update(done=int(row["status"] == "done"), failed=int(row["status"] != "done"))
            if not done:
                bar.update()
            if time.perf_counter() - last_manifest > MANIFEST_EVERY_S:
                write_manifest(manifest, rows)
                last_manifest = time.perf_counter()
            if latch is not None:
                latch.check()
    except KeyboardInterrupt:
        if not owned:
            flight.cancel()
        raise
    except BaseException:
        flight.cancel()
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
