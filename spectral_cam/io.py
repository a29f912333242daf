"""Safe file output: every file appears complete or not at all.

References
----------
.. [1] POSIX rename(2): replacing a path by rename is atomic within one file system.
"""

from __future__ import annotations

import contextlib
import errno
import glob
import os
import shutil
import tempfile
from pathlib import Path
from typing import Iterator

from .errors import ConfigError

__all__ = ["atomic_path", "staged_directory", "discard_in_progress", "exchange_paths", "recover_interrupted",
           "check_free_disk"]


#: Staging folders and temporary files being written now: what an interrupt must remove
#: (:func:`discard_in_progress`), wherever the main thread happens to be when it arrives.
_IN_PROGRESS: set[Path] = set()


def discard_in_progress() -> None:
    """Remove every staging folder and temporary file still being written (a signal handler
    calls this first, so that no partial output survives however the interrupt unwinds)."""
    for path in list(_IN_PROGRESS):
        if path.is_dir():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)
        _IN_PROGRESS.discard(path)


@contextlib.contextmanager
def _in_progress(path: Path) -> Iterator[None]:
    _IN_PROGRESS.add(path)
    try:
        yield
    finally:
        _IN_PROGRESS.discard(path)


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path in the target's folder; rename it onto ``path`` on success,
    remove it on failure. A killed process leaves only a ``.partial-*`` file behind."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.partial-", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    tmp = Path(tmp)
    try:
        with _in_progress(tmp):
            yield tmp
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; a result file should not be
            os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


@contextlib.contextmanager
def staged_directory(target: str | Path, *, force: bool = False) -> Iterator[Path]:
    """Fill a temporary sibling folder, then move it onto ``target`` in one rename.

    An existing ``target`` is replaced only with ``force``; on any error the partial
    folder is removed, so no half-written result directory is ever left under ``target``.
    """
    target = Path(target)
    recover_interrupted(target)
    if target.exists() and not force:
        raise ConfigError(f"{target} exists; pass --force (force=True) to overwrite it")
    target.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{target.name}.partial-", dir=target.parent))
    try:
        with _in_progress(stage):
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(stage, 0o777 & ~umask)  # mkdtemp makes 0700
            yield stage
        _publish(stage, target, force=force)  # no longer discardable: it may hold the old result
    finally:
        if stage.exists():
            shutil.rmtree(stage, ignore_errors=True)


def _publish(stage: Path, target: Path, *, force: bool) -> None:
    """Move a finished staging folder onto ``target``. ``force`` is checked again here, since
    ``target`` may have appeared while the work ran; a replaced result is restored if the
    final rename fails, so one of the two always survives."""
    if not target.exists():
        os.rename(stage, target)  # an empty folder created meanwhile would be replaced, not merged
        return
    if not force:
        raise ConfigError(f"{target} appeared while this result was being made; pass --force to replace it")
    if exchange_paths(stage, target):  # one atomic step: the old result is now at `stage`
        shutil.rmtree(stage, ignore_errors=True)
        return
    # no atomic exchange here: two renames; a kill between them leaves the old result in
    # the .old folder, which recover_interrupted() moves back on the next run
    trash = Path(tempfile.mkdtemp(prefix=f".{target.name}.old-", dir=target.parent))
    try:
        os.replace(target, trash / target.name)
        try:
            os.replace(stage, target)
        except BaseException:
            os.replace(trash / target.name, target)
            raise
    finally:
        shutil.rmtree(trash, ignore_errors=True)


def exchange_paths(a: str | Path, b: str | Path) -> bool:
    """Swap two paths atomically (Linux ``renameat2(RENAME_EXCHANGE)``); False where the
    platform or file system cannot, so the caller falls back to two renames.

    References
    ----------
    .. [1] Linux man-pages, rename(2): ``renameat2`` flag ``RENAME_EXCHANGE`` (Linux 3.15,
       glibc 2.28).
    """
    import ctypes

    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    if renameat2(at_fdcwd, os.fsencode(str(a)), at_fdcwd, os.fsencode(str(b)), rename_exchange) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), str(b))


def recover_interrupted(target: str | Path) -> list[Path]:
    """Move back a result a killed replacement left in a hidden ``.<name>.old-*`` folder
    beside ``target`` (only while ``target`` itself is missing), and remove such folders.

    Returns
    -------
    list of pathlib.Path
        The restored paths (at most one).
    """
    target = Path(target)
    restored = []
    for trash in sorted(target.parent.glob(f".{glob.escape(target.name)}.old-*")):
        kept = trash / target.name
        if kept.exists() and not target.exists():
            os.replace(kept, target)
            restored.append(target)
        shutil.rmtree(trash, ignore_errors=True)
    return restored


def check_free_disk(need_bytes: float, folder: str | Path, *, what: str, remedy: str) -> None:
    """Refuse, before any work, output that cannot fit: ``need_bytes`` (an estimate of what
    will be written under ``folder``) against the free space of the file system that will
    hold it (its nearest existing parent).

    Raises
    ------
    ConfigError
        Naming the estimate, the free space and ``remedy``.
    """
    folder = Path(folder).resolve()
    existing = next((p for p in (folder, *folder.parents) if p.exists()), Path("/"))
    free = shutil.disk_usage(existing).free
    if need_bytes > free:
        raise ConfigError(f"{what} needs about {need_bytes / 1e9:.3g} GB but {existing} has {free / 1e9:.3g} GB free; "
                          f"{remedy}")
