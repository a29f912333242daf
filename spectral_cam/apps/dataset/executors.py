"""Where a dataset's items run: this process, a local Dask cluster, or a running Dask scheduler.

:func:`open_executor` gives a run its ``concurrent.futures.Executor`` (with how many tasks to keep
in flight and how many Mitsuba threads a task gets): the one a caller passes, ``"inline"`` (each
task at submission, here), a remote scheduler's address, or a new :func:`local_cluster` of spawned
worker processes. A local cluster listens on the loopback interface only, its workers ignore the
terminal's SIGINT (the driver stops them: on an interrupt it kills them mid-item, their nannies
told not to restart them, and keeps Dask's loggers quiet), and each worker's numerical libraries
get its share of the cores.

References
----------
.. [1] Rocklin, M. (2015). Dask: parallel computation with blocked algorithms and task
   scheduling. Proc. 14th Python in Science Conference, 130–136.
.. [2] Python ``concurrent.futures`` (PEP 3148); Dask ``Client.get_executor``.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import os
from typing import Any, Iterator

from ...errors import ConfigError

__all__ = ["LOOPBACK", "default_workers", "local_cluster", "open_executor", "require_dask"]


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
    """The cores this process may run on (its affinity mask on Linux)."""
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
    worker's death at once (``allowed_failures`` 0), so :func:`~.run.generate_dataset` resubmits
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
    tornado); returns their levels before. Their children with a level of their own too: Dask's
    configuration sets ``tornado.application`` to ERROR (and ``distributed.client``,
    ``distributed.gc`` to WARNING), so silencing ``tornado`` alone still let the event loop's
    CommClosedError tracebacks through (seen under load)."""
    import logging

    roots = ("distributed", "tornado", "asyncio")
    loggers = [logging.getLogger(name) for name in roots]
    loggers += [logger for name, logger in list(logging.Logger.manager.loggerDict.items())
                if isinstance(logger, logging.Logger) and logger.level != logging.NOTSET
                and name.split(".")[0] in roots and name not in roots]
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


def open_executor(executor=None, scheduler: str | None = None, workers: int | None = None, *,
                  dashboard: bool = False):
    """The executor a run submits to (the one given, ``"inline"``, a Dask scheduler's address,
    or a local cluster of ``workers``, serving Dask's dashboard with ``dashboard``), as a context
    manager yielding (executor, tasks kept in flight, Mitsuba threads per task or None): what
    :func:`~.run.generate_dataset` and ``spectral-cam sequence`` share."""
    return _executor(executor, scheduler, workers, dashboard)


def require_dask() -> None:
    """Refuse a run that needs dask.distributed where it is not installed."""
    try:
        import dask.distributed  # noqa: F401
    except ImportError:
        raise ConfigError("the Dask executor needs dask.distributed: pip install 'spectral_cam[dask]' "
                          "(or run with --scheduler inline)") from None


def _dask_threads(executor) -> int:
    """Threads of a Dask client's workers behind ``executor`` (0 for another executor)."""
    client = getattr(executor, "_client", None)
    try:
        return sum(client.nthreads().values()) if client is not None else 0
    except Exception:  # a closed client: fall back to the default window
        return 0
