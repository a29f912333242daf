"""Distributions a dataset spec may give instead of a fixed value, and their draws.

A spec value written as an inline table with one of :data:`DISTRIBUTIONS` (``uniform``,
``log_uniform``, ``choice`` with optional ``weights``) is parsed and checked by
:func:`parse_distribution` into a :class:`Distribution`, which an item draws from with its own
generator (:meth:`Distribution.sample`). List bounds draw list-valued keys element by element; keys
typed ``int`` draw whole numbers with both ends included (:func:`_whole_draw`).

References
----------
.. [1] NumPy ``Generator.uniform`` / ``Generator.choice`` / ``Generator.integers``.
.. [2] Optuna ``IntDistribution(log=True)``: log-uniform over [low − ½, high + ½], rounded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ...errors import ConfigError
from ...records import json_ready
from .spec_keys import is_whole

__all__ = ["DISTRIBUTIONS", "Distribution", "parse_distribution"]

#: Distributions a spec value may take (an inline table with exactly one of these keys).
DISTRIBUTIONS = ("uniform", "log_uniform", "choice")


@dataclass(frozen=True)
class Distribution:
    """A distribution over one scene key.

    Attributes
    ----------
    key
        ``"section.key"``.
    kind
        ``"uniform"``, ``"log_uniform"`` or ``"choice"``.
    low, high
        Bounds of (log-)uniform draws: numbers, or tuples for element-wise draws of a
        list-valued key (in the key's units).
    values, weights
        Choices and their relative weights (uniform when empty).
    whole
        Draw whole numbers, both bounds included (keys typed ``int``; :func:`_whole_draw`).
    """

    key: str
    kind: str
    low: Any = None
    high: Any = None
    values: tuple = ()
    weights: tuple[float, ...] = ()
    whole: bool = False

    def sample(self, rng: np.random.Generator) -> Any:
        """One draw (a Python number, list or choice value).

        Parameters
        ----------
        rng
            The item's generator (its stream decides every draw of the item).

        References
        ----------
        .. [1] NumPy ``Generator.uniform`` / ``Generator.choice``; a log-uniform variable is
           exp(U(ln a, ln b)).
        """
        if self.kind == "choice":
            p = None
            if self.weights:
                w = np.asarray(self.weights, dtype=float)
                p = w / w.sum()
            return json_ready(self.values[int(rng.choice(len(self.values), p=p))])
        low = np.asarray(self.low, dtype=float)
        high = np.asarray(self.high, dtype=float)
        if self.whole:
            draw = _whole_draw(rng, self.kind, low, high)
            return draw.tolist() if np.ndim(draw) else int(draw)
        if self.kind == "uniform":
            draw = rng.uniform(low, high)
        else:
            draw = np.exp(rng.uniform(np.log(low), np.log(high)))
        return draw.tolist() if np.ndim(draw) else float(draw)

    def to_dict(self) -> dict:
        """The distribution as the spec writes it (``{"uniform": [low, high]}``, ...)."""
        if self.kind == "choice":
            out = {"choice": json_ready(list(self.values))}
            if self.weights:
                out["weights"] = list(self.weights)
            return out
        return {self.kind: [json_ready(self.low), json_ready(self.high)]}


def _whole_draw(rng: np.random.Generator, kind: str, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Whole numbers from ceil(low) to floor(high), both included: each equally likely for
    ``uniform``; for ``log_uniform`` each k has the log-width of its rounding cell,
    P(k) ∝ ln((k + ½) / (k − ½)) (a continuous log-uniform draw over [lo − ½, hi + ½], rounded).
    Rounding a continuous draw over [lo, hi] instead gives both ends half a cell, so they came
    up half as often (19 and 21 of 200 draws of [4, 10] against about 32 for the others).

    References
    ----------
    .. [1] NumPy ``Generator.integers`` (``endpoint=True``: the high end included).
    .. [2] Optuna ``IntDistribution(log=True)``: log-uniform over [low − ½, high + ½], rounded.
    """
    lo, hi = np.ceil(low).astype(np.int64), np.floor(high).astype(np.int64)
    if kind == "uniform":
        return rng.integers(lo, hi, endpoint=True)
    draw = np.rint(np.exp(rng.uniform(np.log(lo - 0.5), np.log(hi + 0.5)))).astype(np.int64)
    return np.clip(draw, lo, hi)  # exp(log(hi + ½)) may round up past hi by one ulp


def _bound(key: str, value: Any, kind: str) -> Any:
    if isinstance(value, list):
        if not value or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            raise ConfigError(f"{key}: {kind} bounds must be numbers or equal-length lists of numbers; got {value!r}")
        return tuple(float(v) for v in value)
    if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    raise ConfigError(f"{key}: {kind} bounds must be finite numbers; got {value!r}")


def parse_distribution(key: str, table: Mapping[str, Any]) -> Distribution:
    """The :class:`Distribution` an inline table gives scene key ``key``, checked.

    Parameters
    ----------
    key
        ``"section.key"`` (already checked to exist).
    table
        ``{"uniform": [low, high]}``, ``{"log_uniform": [low, high]}`` or ``{"choice": [...],
        "weights": [...]}`` (paths already resolved).

    Raises
    ------
    ConfigError
        For anything else, saying what a distribution may be.
    """
    kinds = [k for k in table if k in DISTRIBUTIONS]
    extra = sorted(set(table) - set(DISTRIBUTIONS) - {"weights"})
    if len(kinds) != 1 or extra:
        raise ConfigError(
            f"{key} = {dict(table)!r}: a distribution is an inline table with exactly one of "
            f"{', '.join(DISTRIBUTIONS)} (choice may add weights), e.g. "
            f"{{ uniform = [0.5, 5.0] }} or {{ choice = [\"D65\", \"A\"] }}")
    kind = kinds[0]
    if kind == "choice":
        return _parse_choice(key, table)
    if "weights" in table:
        raise ConfigError(f"{key}: weights apply to choice only, not {kind}")
    return _parse_range(key, kind, table[kind])


def _parse_choice(key: str, table: Mapping[str, Any]) -> Distribution:
    """``{ choice = [...], weights = [...] }``: a non-empty list, weights >= 0 with a positive sum."""
    spec = table["choice"]
    if not isinstance(spec, list) or not spec:
        raise ConfigError(f"{key}: choice needs a non-empty list of values; got {spec!r}")
    weights = table.get("weights", ())
    if weights:
        if (not isinstance(weights, list) or len(weights) != len(spec)
                or not all(isinstance(w, (int, float)) and not isinstance(w, bool) and w >= 0 for w in weights)
                or not sum(weights) > 0):
            raise ConfigError(f"{key}: weights must be {len(spec)} numbers >= 0 with a positive sum; "
                              f"got {weights!r}")
    return Distribution(key, "choice", values=tuple(spec), weights=tuple(float(w) for w in weights))


def _parse_range(key: str, kind: str, spec: Any) -> Distribution:
    """``[low, high]`` of a (log-)uniform draw: ordered, > 0 for ``log_uniform``, and holding a
    whole number (below 2**53) for a whole-number key."""
    whole = is_whole(key)
    if not isinstance(spec, list) or len(spec) != 2:
        raise ConfigError(f"{key}: {kind} needs [low, high]; got {spec!r}")
    low, high = (_bound(key, v, kind) for v in spec)
    if isinstance(low, tuple) != isinstance(high, tuple) or (
            isinstance(low, tuple) and len(low) != len(high)):
        raise ConfigError(f"{key}: {kind} bounds must both be numbers or lists of the same length")
    lows, highs = np.atleast_1d(low), np.atleast_1d(high)
    if np.any(lows > highs):
        raise ConfigError(f"{key}: {kind} needs low <= high; got [{spec[0]!r}, {spec[1]!r}]")
    if kind == "log_uniform" and np.any(lows <= 0):
        raise ConfigError(f"{key}: log_uniform bounds must be > 0; got [{spec[0]!r}, {spec[1]!r}]")
    if whole and max(np.abs(np.atleast_1d(low)).max(), np.abs(np.atleast_1d(high)).max()) >= 2 ** 53:
        raise ConfigError(f"{key}: whole-number bounds must stay below 2**53; got [{spec[0]!r}, {spec[1]!r}]")
    if whole and np.any(np.ceil(lows) > np.floor(highs)):
        raise ConfigError(f"{key} takes whole numbers, and [{spec[0]!r}, {spec[1]!r}] holds none; give bounds "
                          f"with at least one whole number between them, e.g. [4, 10]")
    return Distribution(key, kind, low=low, high=high, whole=whole)
