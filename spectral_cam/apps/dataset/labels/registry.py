"""The label registry: one :class:`Label` per ``[dataset] outputs`` name, carrying everything
about it — its writer, its reader, a one-line description, its files and its size estimate.

The writer, the loader (:func:`spectral_cam.apps.dataset.read_item`), the dataset card, the spec's
validation and the dry run's size total all read :data:`LABELS`; no other table of labels exists.

References
----------
.. [1] docs/design.md, "Registries" and "Dataset layouts".
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable

from ....registry import Entry, Registry

__all__ = ["Label", "LabelRegistry", "LABELS", "FILE_HEADER_BYTES"]

#: What a label file takes beyond its pixels (an EXR's header and offset tables, a PNG's chunks).
FILE_HEADER_BYTES = 4096.0


@dataclass(frozen=True)
class Label(Entry):
    """One dataset label.

    Attributes
    ----------
    function : callable
        The writer, ``(item, folder) -> list of written paths``; it records its meta.json entries
        in ``item.records`` under its ``options`` (each None in an item without the label).
    files : tuple of str
        The files it writes, the first the one the reader is given; shell patterns allowed
        (``image.*``: whichever formats were written).
    reader : callable or None
        ``(path) -> {item key: array or record}``: the file's contents (:meth:`locate`) as
        :func:`~spectral_cam.apps.dataset.read_item` serves them (None: not read back).
    bytes_per_pixel : float
        Uncompressed size of its files per pixel of the frame (bytes), an upper bound.
    fixed_bytes : float
        Size beyond the pixels (headers; a JSON record's whole size), bytes.
    read_from : tuple of str
        The names (shell patterns) of the file the reader takes, any of them; default the
        first of :attr:`files`.
    """

    files: tuple[str, ...] = ()
    reader: Callable[[Path], dict] | None = None
    bytes_per_pixel: float = 0.0
    fixed_bytes: float = FILE_HEADER_BYTES
    read_from: tuple[str, ...] = ()

    def estimate_bytes(self, width: int, height: int) -> float:
        """Bytes the label's files take for a ``width`` × ``height`` px frame (uncompressed: an
        upper bound for the zip-compressed EXRs and the PNGs)."""
        return self.fixed_bytes + self.bytes_per_pixel * float(width) * float(height)

    def locate(self, folder: Path, written: Iterable[str]) -> Path | None:
        """The file the reader reads: the first of the item's ``written`` files (meta.json's
        ``files``, in order) that :attr:`read_from` (or the first of :attr:`files`) matches,
        case aside; None where it wrote none."""
        patterns = [p.lower() for p in (self.read_from or self.files[:1])]
        for name in written:
            if any(fnmatch.fnmatchcase(Path(name).name.lower(), p) for p in patterns):
                return Path(folder) / name
        return None


class LabelRegistry(Registry):
    """A :class:`~spectral_cam.registry.Registry` of :class:`Label` entries; the registration
    order is the order of ``outputs`` in dataset.json and meta.json and of the loader's keys."""

    def register(self, name: str, **fields: Any):
        """Decorator: register the decorated writer as label ``name`` (fields of :class:`Label`)."""

        def decorate(function: Callable) -> Callable:
            self.add(name, function, **fields)
            return function

        return decorate

    def add(self, name: str, function: Callable, *, options: tuple[str, ...] = (), description: str = "",
            files: Iterable[str] = (), reader: Callable[[Path], dict] | None = None, bytes_per_pixel: float = 0.0,
            fixed_bytes: float = FILE_HEADER_BYTES, read_from: Iterable[str] = ()) -> Label:
        """Register ``function`` as the writer of label ``name`` (a name can be registered once)."""
        if name in self._entries:
            raise ValueError(f"{self.kind} {name!r} is registered twice")
        if bytes_per_pixel < 0 or fixed_bytes < 0:
            raise ValueError(f"{self.kind} {name!r}: bytes_per_pixel and fixed_bytes must be >= 0 (bytes)")
        entry = Label(name, function, tuple(options), description, tuple(files), reader, float(bytes_per_pixel),
                      float(fixed_bytes), tuple(read_from))
        self._entries[name] = entry
        return entry

    def unregister(self, name: str) -> None:
        """Remove label ``name`` (a test's or plug-in's own; the package's are never removed)."""
        self.check(name)
        del self._entries[name]

    def loadable(self) -> tuple[str, ...]:
        """The labels :func:`~spectral_cam.apps.dataset.read_item` reads: those with a reader."""
        return tuple(name for name, entry in self._entries.items() if entry.reader is not None)


#: What an item can write besides meta.json: ``[dataset] outputs`` name → :class:`Label`.
LABELS = LabelRegistry("dataset output")
