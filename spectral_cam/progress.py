"""One progress display for every long command: a status line on stderr.

On a terminal the line is redrawn in place; elsewhere (logs, CI) it is printed at the start,
at most every ``every_s`` seconds and at the end, never twice the same. The render's spp
passes, dataset items and validation cells all report through :class:`ProgressLine`.
"""

from __future__ import annotations

import math
import sys
import time
from typing import Callable, TextIO

__all__ = ["ProgressLine", "duration", "spp_progress"]


def duration(seconds: float) -> str:
    """A duration for people: ``"42 s"``, ``"3 min 07 s"``, ``"2 h 05 min"``, ``"?"``.

    Examples
    --------
    >>> duration(42.4), duration(187), duration(7500), duration(float("inf"))
    ('42 s', '3 min 07 s', '2 h 05 min', '?')
    """
    if not math.isfinite(seconds):
        return "?"
    seconds = int(round(seconds))
    if seconds < 60:
        return f"{seconds} s"
    if seconds < 3600:
        return f"{seconds // 60} min {seconds % 60:02d} s"
    return f"{seconds // 3600} h {seconds % 3600 // 60:02d} min"


class ProgressLine:
    """A status line: ``show(text)`` redraws it (terminal) or logs it (at most every
    ``every_s`` seconds); ``close()`` prints the last text and ends the line; ``log(text)``
    prints a line of its own (a result) without disturbing the status line.

    Parameters
    ----------
    enabled : bool
        False makes every call a no-op (``--quiet``).
    stream : file, optional
        Default ``sys.stderr``.
    every_s : float
        Least seconds between two logged lines when the stream is not a terminal.
    """

    def __init__(self, *, enabled: bool = True, stream: TextIO | None = None, every_s: float = 10.0):
        self.enabled = enabled
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.every_s = every_s
        self.started = time.perf_counter()
        self._text = ""
        self._last_print = -math.inf
        self._last_line: str | None = None
        self._drawn = False

    @property
    def elapsed_s(self) -> float:
        return time.perf_counter() - self.started

    def show(self, text: str, *, final: bool = False) -> None:
        """Set the status text and draw it (or log it when it is due or ``final``)."""
        self._text = text
        if not self.enabled:
            return
        if self.tty:
            print("\r" + text, end="\n" if final else "", file=self.stream, flush=True)
            self._drawn = not final
            return
        now = time.perf_counter()
        if final or now - self._last_print >= self.every_s:
            self._print(text)
            self._last_print = now

    def log(self, text: str) -> None:
        """Print ``text`` on a line of its own."""
        if not self.enabled:
            return
        if self.tty and self._drawn:
            print(file=self.stream)
            self._drawn = False
        print(text, file=self.stream, flush=True)

    def close(self) -> None:
        """Print the final status text and end the line."""
        if self._text:
            self.show(self._text, final=True)

    def _print(self, line: str) -> None:
        if line != self._last_line:
            print(line, file=self.stream, flush=True)
            self._last_line = line


def spp_progress(label: str, *, enabled: bool = True, stream: TextIO | None = None) -> Callable[..., None]:
    """A ``progress(done_spp, total_spp, seconds, tile=None)`` callback for
    :func:`spectral_cam.render` that shows ``label: 64/256 spp (25 %), 1.2 s, ~3 s left``, or
    for a frame rendered in tiles ``label: tile 3/50 (6 %), 9.1 s, ~140 s left``."""
    line = ProgressLine(enabled=enabled, stream=stream, every_s=math.inf)

    def progress(done: int, total: int, seconds: float, tile: tuple[int, int] | None = None) -> None:
        if tile is not None:
            finished, tiles = tile
            fraction = (finished + done / total) / tiles if done < total else finished / tiles
            eta = seconds * (1 - fraction) / fraction if fraction > 0 else 0.0
            text = f"{label}: tile {min(finished + (done < total), tiles)}/{tiles} ({100 * fraction:.0f} %), " \
                   f"{seconds:.1f} s, ~{eta:.0f} s left"
            line.show(text, final=fraction >= 1 or done == 0)
            return
        rate = done / seconds if seconds > 0 else 0.0
        eta = (total - done) / rate if rate > 0 else 0.0
        text = f"{label}: {done}/{total} spp ({100 * done / total:.0f} %), {seconds:.1f} s, ~{eta:.0f} s left"
        line.show(text, final=done >= total or done == 0)

    return progress
