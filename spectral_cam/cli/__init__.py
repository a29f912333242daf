"""``spectral-cam``: the command-line face of the Python API, thin: parse, call, map errors.

    spectral-cam render SCENE.toml -o OUTDIR [--set section.key=value]... [--force]
    spectral-cam develop RAW.dng -o IMAGE [--set isp.key=value]... [--force]
    spectral-cam cameras | keys | validate | dataset | stress | bench

One module per command in this package (``cli/render.py``, ``cli/stress.py``, ...), each with
``configure_parser(parser)`` and ``run(args) -> exit status``, registered in :data:`COMMANDS`
and imported only when its command runs.

User errors (bad scene files, names, values, existing outputs) print one clear message and
exit with status 2, never a traceback. Results appear atomically: a render writes into a
hidden staging folder that is renamed onto OUTDIR only when every file is complete.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import gc
import importlib
import os
import sys

from ..errors import SpectralCamError
from ..registry import Registry

__all__ = ["main"]

#: Every ``spectral-cam`` command: name → loader of its module (``spectral_cam.cli.<name>``,
#: defining ``configure_parser(parser)`` and ``run(args)``).
COMMANDS = Registry("command")


def _command(name: str, description: str) -> None:
    COMMANDS.add(name, lambda: importlib.import_module(f"{__name__}.{name}"), description=description)


_command("render", "render a scene file into OUTDIR")
_command("develop", "develop any DNG (ours or a camera's) into an image")
_command("cameras", "list the measured camera sensors")
_command("keys", "list every scene key: default, meaning and the code that declares it")
_command("validate", "validate colour pipelines against spectral ground truth")
_command("dataset", "generate a randomised or swept synthetic dataset")
_command("export", "a dataset as COCO instances, 16-bit depth PNGs or Middlebury .flo flow")
_command("stress", "chart where methods break (stress scenes)")
_command("bench", "speed-against-accuracy benchmarks (CSV + PNG charts)")
_command("sequence", "frames over time through auto-exposure/white-balance control loops")


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser (command names and one-line help; each command's own
    arguments are parsed by :func:`command_parser`)."""
    parser = argparse.ArgumentParser(
        prog="spectral-cam",
        description="Spectral, path-traced scene-to-sensor camera simulator.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    for name, entry in COMMANDS.items():
        sub.add_parser(name, help=entry.description, add_help=False)
    return parser


def command_parser(name: str) -> argparse.ArgumentParser:
    """The parser of one command, its module imported now."""
    entry = COMMANDS[name]
    parser = argparse.ArgumentParser(prog=f"spectral-cam {name}", description=entry.description)
    module = entry.function()
    module.configure_parser(parser)
    parser.set_defaults(func=module.run)
    return parser


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that every staging folder and temporary file is removed."""


#: Seconds an interrupted command has to unwind before the process exits regardless (a
#: KeyboardInterrupt raised inside native code can be lost; a job must still stop).
INTERRUPT_GRACE_S = 10.0
_WATCHDOGS: list = []
_SIGNALLED: list = []


def _interrupt(signum, frame):
    """SIGINT/SIGTERM while a command runs: remove the partial output now (whatever the
    exception meets on its way up), arm a watchdog, then unwind as Ctrl-C."""
    import signal
    import threading

    from ..io import discard_in_progress

    discard_in_progress()

    def hard_exit():
        discard_in_progress()
        print("spectral-cam: interrupted; no partial output was kept", file=sys.stderr, flush=True)
        os._exit(130)

    _SIGNALLED.append(signum)  # native code may re-raise the interrupt unchained (drjit.custom)
    watchdog = threading.Timer(INTERRUPT_GRACE_S, hard_exit)
    watchdog.daemon = True
    watchdog.start()
    _WATCHDOGS.append(watchdog)  # cancelled when the command has unwound
    raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


#: glibc's malloc returns a freed block of more than ``M_MMAP_THRESHOLD`` (at most 32 MB by
#: default) to the kernel, which zeroes every page of the next one again: a 24 MP develop, whose
#: stages each make 100–300 MB arrays, spent about a second in page faults (63 k faults vs 34 k
#: with the blocks kept in the heap). These two settings keep large blocks in the heap for reuse.
#: A small frame gains nothing and its peak grows (ColorChecker, 480 × 320: 251 vs 243 MB), so
#: ``render`` and ``develop`` keep them only from :data:`KEEP_BLOCKS_PIXELS` up (a 2.5 MP render without
#: them: 9.4 s against 6.6 s bare, with them 1.13×).
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_KEEP_BYTES = 1 << 30
#: Frame size (pixels) from which ``render`` and ``develop`` keep large blocks in the heap.
KEEP_BLOCKS_PIXELS = 1_000_000


def keep_large_blocks(pixels: float | None = None) -> None:
    """Ask glibc to serve and keep large arrays in the heap (no-op elsewhere, and for a frame
    of fewer than :data:`KEEP_BLOCKS_PIXELS` ``pixels``)."""
    if pixels is not None and pixels < KEEP_BLOCKS_PIXELS:
        return
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.mallopt(_M_MMAP_THRESHOLD, ctypes.c_int(_KEEP_BYTES))
        libc.mallopt(_M_TRIM_THRESHOLD, ctypes.c_int(2 * _KEEP_BYTES - 1))
    except (OSError, AttributeError):  # not glibc: nothing to tune
        pass


@contextlib.contextmanager
def _scene_warnings_as_lines():
    """Print a :class:`~spectral_cam.errors.SceneWarning` as ``spectral-cam: warning: ...``
    (one line, no source location); other warnings as Python shows them."""
    import warnings

    from ..errors import SceneWarning

    shown = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, SceneWarning):
            print(f"spectral-cam: warning: {message}", file=sys.stderr)
        else:
            shown(message, category, filename, lineno, file, line)

    warnings.showwarning = show
    try:
        yield
    finally:
        warnings.showwarning = shown


def main(argv: list[str] | None = None) -> int:
    """Run one ``spectral-cam`` command; the exit status: 0 done, 1 finished with failed
    cells or items, 2 a user error (message, no traceback), 130 interrupted (SIGINT or
    SIGTERM: no partial output is kept)."""
    as_command = argv is None
    argv = list(sys.argv[1:] if argv is None else argv)
    if as_command:  # the process ends with the command: skip the exit's collection of what it made
        atexit.register(gc.freeze)
    if argv and argv[0] in COMMANDS:
        args = command_parser(argv[0]).parse_args(argv[1:])
    else:
        build_parser().parse_args(argv)  # prints usage and exits: no command named
        return 2
    if argv[0] not in ("render", "develop"):  # those two decide by the frame's size
        keep_large_blocks()
    with _sigterm_as_interrupt(), _scene_warnings_as_lines():
        try:
            return args.func(args)
        except SpectralCamError as exc:
            print(f"spectral-cam: error: {exc}", file=sys.stderr)
            return 2
        except BrokenPipeError:  # the reader went away (`spectral-cam keys | head`): nothing is wrong
            _quiet_stdout()
            return 1
        except OSError as exc:  # e.g. an output path under a file, a read-only folder
            print(f"spectral-cam: error: {exc.strerror or exc}: {exc.filename or ''}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            return _interrupted()
        except Exception as exc:
            # native code can re-raise the interrupt as something else: drjit.custom (Mitsuba's
            # render in AD variants) as RuntimeError, an import as SystemError
            if _caused_by_interrupt(exc):
                return _interrupted()
            raise


def _quiet_stdout() -> None:
    """Point stdout at /dev/null, so the interpreter's flush at exit meets no closed pipe either
    (the Python documentation's recipe for SIGPIPE)."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())


def _caused_by_interrupt(exc: BaseException) -> bool:
    if _SIGNALLED:
        return True
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def _interrupted() -> int:
    from ..io import discard_in_progress

    discard_in_progress()
    print("spectral-cam: interrupted; no partial output was kept", file=sys.stderr)
    return 130


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """SIGINT and SIGTERM run :func:`_interrupt` while a command runs (main thread only); the
    previous handlers are restored after, so a program that calls :func:`main` keeps its own."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {}
    for signum in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(signum) is not signal.SIG_IGN:  # an ignored signal (nohup, `&`) stays ignored
            previous[signum] = signal.signal(signum, _interrupt)
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        while _WATCHDOGS:
            _WATCHDOGS.pop().cancel()
        _SIGNALLED.clear()
