"""Issue 39 #19: Ctrl-C during ``spectral-cam dataset`` printed Dask's CancelledError tracebacks
and "killing" warnings from every worker, then "no partial output was kept" although the finished
items were kept. The terminal's Ctrl-C (SIGINT to the whole process group) now ends the run in
one line that says how many items are done and that the same command resumes; the manifest
agrees with the item folders on disk, no staging folder is left, and rerunning resumes.

Issue 41: a Ctrl-C landing in a finaliser the driver runs between items (a Dask future's ``__del__``)
raised its KeyboardInterrupt there, where Python prints and drops it; the run now stops all the same."""

from __future__ import annotations

import concurrent.futures as cf
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from spectral_cam.apps.dataset import DatasetInterrupted, generate_dataset, spec_from_dict

from .reading import read_manifest

SPEC = """
[scene]
preset = "colorchecker"
[sensor]
width_px = 64
height_px = 48
[render]
spp = 64
[lens]
f_number = { uniform = [2.0, 8.0] }
"""


#: Items per run, each a 64 × 48 px render at 64 spp: Ctrl-C after the second lands while the
#: driver waits on the workers, not in its bookkeeping between items (40 items of 24 × 16 px at 2 spp
#: took 4 s on a quiet machine, mostly bookkeeping, and the signal was not seen there once in the suite)
ITEMS = 16


def _dataset(spec: Path, out: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "spectral_cam.cli", "dataset", str(spec), "-n", str(ITEMS), "-o", str(out),
                             "--workers", "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True,  # its own process group, as a terminal's job
                            preexec_fn=_sigint_at_default)


def _sigint_at_default() -> None:
    """A shell starts a foreground job with SIGINT at its default; a child inherits an ignored
    SIGINT (POSIX execve), and an earlier test's local cluster may have left this process's
    ignored, which the CLI then rightly keeps ignored (as for `nohup` or `&`)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _complete(out: Path) -> list[str]:
    items = out / "items"
    return sorted(p.name for p in items.iterdir() if p.name.isdigit()) if items.is_dir() else []


@pytest.mark.timeout(600)
def test_ctrl_c_keeps_the_finished_items_says_so_and_the_same_command_resumes(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    out = tmp_path / "out"
    run = _dataset(spec, out)
    deadline = time.monotonic() + 400
    while len(_complete(out)) < 2 and run.poll() is None and time.monotonic() < deadline:
        time.sleep(0.1)
    assert run.poll() is None, "the dataset finished before it could be interrupted: " + run.communicate()[1]
    os.killpg(run.pid, signal.SIGINT)  # what Ctrl-C at a terminal sends: every process of the job
    _, err = run.communicate(timeout=60)
    assert run.returncode == 130, err

    kept = _complete(out)
    rows = read_manifest(out)
    done = [row["id"] for row in rows if row["status"] == "done"]
    assert done == kept and len(kept) >= 2  # every complete folder counted, no half-written one counted
    last = err.strip().splitlines()[-1]
    assert last == f"spectral-cam: interrupted: {len(kept)}/{ITEMS} items done, kept in {out}; rerun the same command to resume"
    for noise in ("Traceback", "CancelledError", "killing", "no partial output was kept", "WARNING", "ERROR"):
        assert noise not in err, err
    assert not [p.name for p in (out / "items").iterdir() if p.name.startswith(".")]
    assert (out / "README.md").is_file() and f"{len(kept)} items rendered" in (out / "README.md").read_text()

    before = {name: (out / "items" / name / "raw.dng").stat().st_mtime_ns for name in kept}
    again = _dataset(spec, out)
    _, err = again.communicate(timeout=400)
    assert again.returncode == 0, err
    assert f"{ITEMS} items, {ITEMS - len(kept)} rendered, {len(kept)} resumed, 0 failed" in err
    assert before == {name: (out / "items" / name / "raw.dng").stat().st_mtime_ns for name in kept}
    assert [row["status"] for row in read_manifest(out)] == ["done"] * ITEMS


class _InterruptsWhenFreed:
    """Raises SIGINT in this process from its finaliser, as a Ctrl-C landing in a Dask future's
    ``__del__`` (``Client._dec_ref``, run in the driver when the loop frees an item's future): Python
    runs the handler there, and the KeyboardInterrupt it raises is printed and dropped."""

    def __del__(self):
        signal.raise_signal(signal.SIGINT)


class _FreeingExecutor(cf.Executor):
    """Runs each task at submission; its first future carries an :class:`_InterruptsWhenFreed`."""

    _max_workers = 1

    def __init__(self):
        self.submitted = 0

    def submit(self, fn, /, *args, **kwargs):
        future: cf.Future = cf.Future()
        future.set_result(fn(*args, **kwargs))
        self.submitted += 1
        if self.submitted == 1:
            future.finaliser = _InterruptsWhenFreed()
        return future


def _not_rendered(task: dict) -> dict:
    return {"index": task["index"], "status": "failed", "files": [], "error": "not rendered"}


@pytest.mark.timeout(120)
def test_an_interrupt_a_finaliser_swallows_still_stops_the_run(tmp_path, monkeypatch):
    swallowed = []
    monkeypatch.setattr(sys, "unraisablehook", lambda unraisable: swallowed.append(unraisable.exc_type))
    spec = spec_from_dict({"sensor": {"width_px": 24, "height_px": 16}, "render": {"spp": 2}})
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # as Python starts a program
    try:
        with pytest.raises(DatasetInterrupted) as stopped:
            generate_dataset(spec, tmp_path / "out", n=6, executor=_FreeingExecutor(), item_function=_not_rendered,
                             progress=False)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert swallowed == [KeyboardInterrupt]  # Python dropped it: the run saw it only through its latch
    assert stopped.value.total == 6 and stopped.value.failed < 6  # it stopped before the last items
    assert [row["status"] for row in read_manifest(tmp_path / "out")] == ["failed"] * stopped.value.failed
