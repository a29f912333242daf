"""Result files written one way everywhere: JSON and CSV, numbers formatted for people, provenance
(package versions).

Every result a command writes (``meta.json``, ``results.json``, ``summary.csv``, the
manifest, the validation CSVs) goes through these functions: JSON is strict (non-finite
numbers become the strings ``"nan"``/``"inf"``), files appear atomically
(:func:`spectral_cam.io.atomic_path`), and a number printed for people uses
:func:`format_number`.

References
----------
.. [1] RFC 8259, The JavaScript Object Notation (JSON) Data Interchange Format, §6 (numbers:
   NaN and infinities are not JSON).
"""

from __future__ import annotations

import csv
import json
import math
from importlib import metadata
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from .io import atomic_path

__all__ = ["json_ready", "write_json", "read_json", "format_number", "exact_number", "write_csv", "replace_block",
           "package_versions"]

#: The packages whose versions a result records (with Python and LibRaw).
PROVENANCE_PACKAGES = ("spectral_cam", "mitsuba", "drjit", "colour-science", "numpy", "OpenEXR", "rawpy",
                       "tifffile", "opencv-python-headless", "scikit-image", "matplotlib")


def json_ready(value: Any) -> Any:
    """``value`` with NumPy arrays and scalars, tuples, paths and callables turned into plain
    JSON types; non-finite floats become strings.

    Examples
    --------
    >>> json_ready({"a": np.float32(0.5), "b": (1, np.inf), "c": np.arange(2)})
    {'a': 0.5, 'b': [1, 'inf'], 'c': [0, 1]}
    """
    if isinstance(value, Mapping):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_ready(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, Path):
        return str(value)
    if callable(value) and not isinstance(value, type):
        return getattr(value, "__name__", type(value).__name__)
    return value


def write_json(data: Any, path: str | Path) -> Path:
    """Write ``data`` as indented, strict UTF-8 JSON, atomically (:func:`json_ready` first)."""
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(json_ready(data), indent=2, ensure_ascii=False, allow_nan=False) + "\n",
                       encoding="utf-8")
    return path


def read_json(path: str | Path) -> Any | None:
    """The JSON in ``path``, or None when it is missing or unreadable."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def format_number(value: Any, *, digits: int = 4) -> str:
    """A number for people: ``digits`` significant figures between 10⁻³ and 10⁵, scientific
    notation outside; ``""`` for None, ``"nan"``/``"inf"`` as such; anything else as ``str``.

    Examples
    --------
    >>> format_number(0.012345), format_number(123456.0), format_number(None), format_number(0)
    ('0.01235', '1.235e+05', '', '0')
    """
    if value is None:
        return ""
    if isinstance(value, (bool, str)) or not isinstance(value, (int, float, np.number)):
        return str(value)
    value = float(value)
    if not math.isfinite(value):
        return str(value)
    if value == 0:
        return "0"
    magnitude = abs(value)
    return f"{value:.{digits}g}" if 1e-3 <= magnitude < 1e5 else f"{value:.{digits - 1}e}"


def exact_number(value: Any) -> str:
    """A number for a CSV that keeps every digit: whole numbers as written, floats as their
    ``repr``; ``""`` for None.

    Examples
    --------
    >>> exact_number(4), exact_number(np.float64(0.1)), exact_number(None)
    ('4', '0.1', '')
    """
    if value is None:
        return ""
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return str(int(value))
    value = float(value)
    return "nan" if math.isnan(value) else repr(value)


def write_csv(rows: Iterable[Mapping[str, Any]], path: str | Path, fields: Sequence[str], *,
              number=format_number) -> Path:
    """Write rows (mappings) as a CSV with a header of ``fields``, atomically; numbers go
    through ``number`` (:func:`format_number` or :func:`exact_number`)."""
    path = Path(path)
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle)
            writer.writerow(fields)
            for row in rows:
                writer.writerow([number(v) if isinstance(v, (int, float, np.number)) and not isinstance(v, bool)
                                 else ("" if v is None else v) for v in (row.get(f) for f in fields)])
    return path


def replace_block(path: str | Path, begin: str, end: str, block: str) -> None:
    """Replace the text from marker ``begin`` to marker ``end`` (both kept, as ``block`` holds
    them) in a text file: how benchmarks regenerate their README paragraphs from their CSVs."""
    path = Path(path)
    text = path.read_text(encoding="utf-8")
    start, stop = text.find(begin), text.find(end)
    if start < 0 or stop < start:
        raise ValueError(f"{path} has no {begin} … {end} block; add the two markers where it belongs")
    path.write_text(text[:start] + block + text[stop + len(end):], encoding="utf-8")


def package_versions() -> dict[str, str]:
    """Versions of Python, LibRaw and the packages a result depends on (provenance for
    meta.json, validation reports and stress results).

    References
    ----------
    .. [1] Python Packaging Authority, ``importlib.metadata`` (installed distribution versions).
    """
    import platform

    import rawpy

    out = {"python": platform.python_version(), "LibRaw": ".".join(map(str, rawpy.libraw_version))}
    for name in PROVENANCE_PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out
