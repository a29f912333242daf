"""Grid sweeps of a dataset spec: the axes ``[dataset] sweep`` and ``--sweep`` add.

A sweep axis is a scene key and the values it takes in order (:class:`Sweep`): a list, or
``start:stop:count`` evenly spaced (``:log``: geometrically, as f-numbers are), both ends included
(:func:`parse_sweep`). Several axes give their product (:meth:`~.spec.DatasetSpec.plan_item`
walks it in ``itertools.product`` order); a whole-number key's values are rounded.

References
----------
.. [1] NumPy ``linspace`` / ``geomspace`` (both ends included).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import ConfigError
from ...records import json_ready
from ...scene import parse_override
from .spec_keys import check_key, is_whole

__all__ = ["Sweep", "parse_sweep", "sweep_values"]

_SWEEP_RANGE = re.compile(r"^\s*([^:\s]+)\s*:\s*([^:\s]+)\s*:\s*(\d+)\s*(?::\s*(lin|log)\s*)?$")


@dataclass(frozen=True)
class Sweep:
    """One axis of a grid sweep: a scene key and the values it takes, in order."""

    key: str
    values: tuple

    def to_dict(self) -> dict:
        """``{"key": ..., "values": [...]}`` (what dataset.json records)."""
        return {"key": self.key, "values": json_ready(list(self.values))}


def sweep_values(key: str, spec: Any, origin: str) -> tuple:
    """The values of sweep axis ``key``: a list as given, a ``start:stop:count[:log]`` range, or a
    single value; rounded for a whole-number key. ``origin`` names where the sweep was given.

    Raises
    ------
    ConfigError
        For an empty list or a malformed range, saying what would be valid.
    """
    if isinstance(spec, list):
        if not spec:
            raise ConfigError(f"{origin}: sweep {key} needs at least one value")
        values = tuple(spec)
    elif isinstance(spec, str):
        values = _range_values(key, spec, origin)
    else:
        values = (spec,)
    if is_whole(key):
        values = tuple(int(round(v)) if isinstance(v, float) else v for v in values)
    return values


def _range_values(key: str, spec: str, origin: str) -> tuple:
    """``start:stop:count`` evenly spaced, ``start:stop:count:log`` geometrically; both ends included."""
    match = _SWEEP_RANGE.match(spec)
    if not match:
        raise ConfigError(f"{origin}: sweep {key}={spec!r}: use start:stop:count (e.g. 0.5:5:10), "
                          f"start:stop:count:log, or a list [v1, v2, ...]")
    try:
        start, stop = float(match.group(1)), float(match.group(2))
    except ValueError:
        raise ConfigError(f"{origin}: sweep {key}={spec!r}: start and stop must be numbers") from None
    count = int(match.group(3))
    if count < 1:
        raise ConfigError(f"{origin}: sweep {key}={spec!r}: count must be >= 1")
    if match.group(4) == "log":
        if start <= 0 or stop <= 0:
            raise ConfigError(f"{origin}: sweep {key}={spec!r}: a log sweep needs start, stop > 0")
        grid = np.geomspace(start, stop, count)
    else:
        grid = np.linspace(start, stop, count)
    return tuple(float(v) for v in grid)


def parse_sweep(text: str) -> Sweep:
    """Parse ``section.key=start:stop:count[:log]`` or ``section.key=[v1, v2, ...]``.

    Parameters
    ----------
    text
        The ``--sweep`` argument; the range form gives ``count`` values from ``start`` to
        ``stop`` inclusive, evenly spaced (``:log``: geometrically, e.g. f-numbers).

    Returns
    -------
    Sweep

    Raises
    ------
    ConfigError
        For an unknown key or a malformed range, saying what would be valid.
    """
    if "=" not in text:
        raise ConfigError(f"--sweep {text!r}: use section.key=start:stop:count, e.g. "
                          f"lens.focus_distance_m=0.5:5:10")
    key, raw = (part.strip() for part in text.split("=", 1))
    check_key(key, "--sweep")
    if raw.startswith("["):
        _, value = parse_override(f"{key}={raw}")
        if not isinstance(value, list):
            raise ConfigError(f"--sweep {text!r}: the list is not valid TOML, e.g. [1.4, 2.8, 5.6]")
        return Sweep(key, sweep_values(key, value, "--sweep"))
    return Sweep(key, sweep_values(key, raw, "--sweep"))
