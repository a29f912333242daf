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
import socket
import tempfile
from pathlib import Path
from typing import Iterator

from .errors import ConfigError, OutputPathError

__all__ = ["atomic_path", "staged_directory", "discard_in_progress", "exchange_paths", "recover_interrupted",
           "remove_abandoned_partials", "check_free_disk"]


#: Staging folders and temporary files being written now: what an interrupt must remove
#: (:func:`discard_in_progress`), wherever the main thread happens to be when it arrives.
_IN_PROGRESS: set[Path] = set()


def _partial_prefix(name: str) -> str:
    """``.<name>.partial-<host>-<pid>-``: the owner is in the name, so a later run can tell a
    folder a killed process left (kill -9 runs no cleanup) from one another process is filling."""
    return f".{name}.partial-{socket.gethostname()}-{os.getpid()}-"


def _owner_is_gone(path: Path, name: str) -> bool:
    """True for a ``.partial-`` path this host's process left and that process no longer runs."""
    ours = f".{name}.partial-{socket.gethostname()}-"
    pid_text = path.name[len(ours):].split("-", 1)[0] if path.name.startswith(ours) else ""
    if not pid_text.isdigit():
        return False  # another machine's (a shared folder) or an older name: not ours to judge
    try:
        os.kill(int(pid_text), 0)
    except ProcessLookupError:
        return True
    except PermissionError:  # alive, another user's
        return False
    return False


def remove_abandoned_partials(target: str | Path) -> list[Path]:
    """Remove the ``.<name>.partial-*`` files and folders beside ``target`` that a killed
    process on this machine left (its pid no longer runs).

    Returns
    -------
    list of pathlib.Path
        The removed paths.
    """
    target = Path(target)
    removed = []
    for path in target.parent.glob(f".{glob.escape(target.name)}.partial-*"):
        if _owner_is_gone(path, target.name):
            _remove(path)
            removed.append(path)
    return removed


def _remove(path: Path) -> None:
    """Remove a folder tree, a file or a symbolic link (not what the link points to)."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def discard_in_progress() -> None:
    """Remove every staging folder and temporary file still being written (a signal handler
    calls this first, so that no partial output survives however the interrupt unwinds)."""
    for path in list(_IN_PROGRESS):
        _remove(path)
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
    _make_parent(path)
    remove_abandoned_partials(path)
    fd, tmp = tempfile.mkstemp(prefix=_partial_prefix(path.name), suffix=path.suffix, dir=path.parent)
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
    if os.path.lexists(target) and not force:  # a dangling symbolic link is there too
        raise ConfigError(f"{target} exists{_what_is_there(target)}; pass --force (force=True) to replace it")
    _make_parent(target)
    remove_abandoned_partials(target)
    stage = Path(tempfile.mkdtemp(prefix=_partial_prefix(target.name), dir=target.parent))
    try:
        with _in_progress(stage):
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(stage, 0o777 & ~umask)  # mkdtemp makes 0700
            yield stage
        try:
            _publish(stage, target, force=force)  # no longer discardable: it may hold the old result
        except OSError as exc:  # name the user's path, not the hidden staging folder
            raise OSError(exc.errno, f"cannot put the result at {target}: {exc.strerror}") from None
    finally:
        if os.path.lexists(stage):
            _remove(stage)


def _what_is_there(target: Path) -> str:
    if target.is_symlink():
        return f" (a symbolic link to {os.readlink(target)}{'' if target.exists() else ', which does not exist'})"
    return "" if target.is_dir() else " (a file)"


def _make_parent(path: Path) -> None:
    """Create ``path``'s folder, or say which part of it is in the way."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        blocker = next((p for p in (path.parent, *path.parent.parents) if os.path.lexists(p) and not p.is_dir()), None)
        where = f"{blocker}{_what_is_there(blocker)}" if blocker else str(path.parent)
        raise OutputPathError(f"cannot write {path}: {where} is in the way of its folder; choose another path "
                              "or remove it") from None


def _publish(stage: Path, target: Path, *, force: bool) -> None:
    """Move a finished staging folder onto ``target``. ``force`` is checked again here, since
    ``target`` may have appeared while the work ran; a replaced result is restored if the
    final rename fails, so one of the two always survives."""
    if not os.path.lexists(target):
        os.rename(stage, target)  # an empty folder created meanwhile would be replaced, not merged
        return
    if not force:
        raise ConfigError(f"{target} appeared while this result was being made; pass --force to replace it")
    if exchange_paths(stage, target):  # one atomic step: the old result (folder, file or link) is now at `stage`
        _remove(stage)
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
