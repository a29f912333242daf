"""Dataset specs: fixed scene values, distributions, sweeps, outputs and seed; one plan per item.

A spec is a scene file (any ``[section] key = value`` of docs/design.md, "Scene file") in which any
value may instead be a distribution (:data:`DISTRIBUTIONS`, or ``{ files = "glob" }``: a choice of
the files it matches, e.g. a folder of XML scenes), plus a ``[dataset]`` table (``scene``,
``seed``, ``n``, ``outputs``, ``sweep``). :meth:`DatasetSpec.plan_item` turns (spec, index) into
the item's seed, sampled parameters and validated scene, the same on any machine and in any order;
:meth:`DatasetSpec.split_of` puts each index in a split (``[dataset] splits``, ``split_seed``) by a
hash of (split seed, index) alone, so an item keeps its split when the dataset grows or resumes.

References
----------
.. [1] O'Neill, M. E. (2014) and NumPy ``SeedSequence``: independent streams from a root
   entropy and a spawn key (numpy.random.SeedSequence documentation, NEP 19).
.. [2] Hugging Face ``datasets``, "Splits" (split names; ``train``, ``validation``, ``test``).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import ConfigError
from ...records import json_ready
from ...scene import SceneConfig, parse_override, read_toml, scene_from_dict
from .labels import DEFAULT_OUTPUTS, LABELS

__all__ = ["DISTRIBUTIONS", "FORMAT_VERSION", "DEFAULT_SPLITS", "SHARD_ITEMS", "Distribution", "Sweep", "parse_sweep",
           "ItemPlan", "DatasetSpec",
           "spec_from_dict", "load_spec", "with_exports"]

#: Distributions a spec value may take (an inline table with exactly one of these keys).
DISTRIBUTIONS = ("uniform", "log_uniform", "choice")
#: Format version of dataset.json, part of the spec hash.
FORMAT_VERSION = 1
#: Splits of a spec without ``[dataset] splits``: every item in ``train`` (Hugging Face's default split).
DEFAULT_SPLITS = (("train", 1.0),)
#: Items per Parquet and WebDataset shard by default (``[dataset] shard_items``).
SHARD_ITEMS = 1000
#: [dataset] keys that do not decide the items' pixels (not in the spec hash: they may change on resume).
_UNHASHED = ("outputs", "count", "source", "splits", "split_seed", "webdataset", "shard_items", "exports")
_SPLIT_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")

_SWEEP_RANGE = re.compile(r"^\s*([^:\s]+)\s*:\s*([^:\s]+)\s*:\s*(\d+)\s*(?::\s*(lin|log)\s*)?$")


# ----------------------------------------------------------------------------- scene keys
def _section_fields() -> dict[str, dict[str, dataclasses.Field]]:
    """{section: {key: dataclass field}} of every scene-file key."""
    out = {}
    for section in dataclasses.fields(SceneConfig):
        out[section.name] = {f.name: f for f in dataclasses.fields(section.default_factory)}
    return out


_FIELDS = _section_fields()


def _check_key(dotted: str, origin: str) -> tuple[str, str]:
    section, _, key = dotted.partition(".")
    if section not in _FIELDS or not key:
        raise ConfigError(f"{origin}: {dotted!r} is not a scene key; use section.key with a section "
                          f"among {', '.join(_FIELDS)}")
    if key not in _FIELDS[section]:
        raise ConfigError(f"{origin}: unknown key {dotted!r}; valid keys of [{section}]: "
                          f"{', '.join(_FIELDS[section])}")
    return section, key


def _is_whole(dotted: str) -> bool:
    """True for keys whose type is a whole number only (sampled values get rounded)."""
    section, key = dotted.split(".", 1)
    kinds = str(_FIELDS[section][key].type).replace(" ", "").split("|")
    return kinds == ["int"]


@functools.lru_cache(maxsize=256)
def _file_digest(path: str, modified_ns: int, size: int) -> str:
    """A file's content digest (cached per path, modification time and size: an edited file is read again)."""
    return "sha256:" + hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _by_content(value: Any) -> Any:
    """``value`` with every existing CSV/XML file path replaced by its content's digest."""
    if isinstance(value, dict):
        return {k: _by_content(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_by_content(v) for v in value]
    if isinstance(value, str) and value.lower().endswith((".csv", ".xml")) and Path(value).is_file():
        status = Path(value).stat()
        return _file_digest(str(Path(value).resolve()), status.st_mtime_ns, status.st_size)
    return value


def _resolve_paths(value: Any, base_dir: Path) -> Any:
    """Make relative CSV/XML paths (in values and choices) absolute against ``base_dir``."""
    if isinstance(value, str) and value.lower().endswith((".csv", ".xml")):
        path = Path(value).expanduser()
        return str((path if path.is_absolute() else base_dir / path).resolve())
    if isinstance(value, list):
        return [_resolve_paths(v, base_dir) for v in value]
    return value


# ----------------------------------------------------------------------------- distributions
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


def _parse_distribution(key: str, table: Mapping[str, Any]) -> Distribution:
    kinds = [k for k in table if k in DISTRIBUTIONS]
    extra = sorted(set(table) - set(DISTRIBUTIONS) - {"weights"})
    if len(kinds) != 1 or extra:
        raise ConfigError(
            f"{key} = {dict(table)!r}: a distribution is an inline table with exactly one of "
            f"{', '.join(DISTRIBUTIONS)} (choice may add weights), e.g. "
            f"{{ uniform = [0.5, 5.0] }} or {{ choice = [\"D65\", \"A\"] }}")
    kind = kinds[0]
    spec = table[kind]
    whole = _is_whole(key)
    if kind == "choice":
        if not isinstance(spec, list) or not spec:
            raise ConfigError(f"{key}: choice needs a non-empty list of values; got {spec!r}")
        weights = table.get("weights", ())
        if weights:
            if (not isinstance(weights, list) or len(weights) != len(spec)
                    or not all(isinstance(w, (int, float)) and not isinstance(w, bool) and w >= 0 for w in weights)
                    or not sum(weights) > 0):
                raise ConfigError(f"{key}: weights must be {len(spec)} numbers >= 0 with a positive sum; "
                                  f"got {weights!r}")
        return Distribution(key, kind, values=tuple(spec), weights=tuple(float(w) for w in weights))
    if "weights" in table:
        raise ConfigError(f"{key}: weights apply to choice only, not {kind}")
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


# ----------------------------------------------------------------------------- sweeps
@dataclass(frozen=True)
class Sweep:
    """One axis of a grid sweep: a scene key and the values it takes, in order."""

    key: str
    values: tuple

    def to_dict(self) -> dict:
        """``{"key": ..., "values": [...]}`` (what dataset.json records)."""
        return {"key": self.key, "values": json_ready(list(self.values))}


def _sweep_values(key: str, spec: Any, origin: str) -> tuple:
    if isinstance(spec, list):
        if not spec:
            raise ConfigError(f"{origin}: sweep {key} needs at least one value")
        values = tuple(spec)
    elif isinstance(spec, str):
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
        values = tuple(float(v) for v in grid)
    else:
        values = (spec,)
    if _is_whole(key):
        values = tuple(int(round(v)) if isinstance(v, float) else v for v in values)
    return values


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
    _check_key(key, "--sweep")
    if raw.startswith("["):
        _, value = parse_override(f"{key}={raw}")
        if not isinstance(value, list):
            raise ConfigError(f"--sweep {text!r}: the list is not valid TOML, e.g. [1.4, 2.8, 5.6]")
        return Sweep(key, _sweep_values(key, value, "--sweep"))
    return Sweep(key, _sweep_values(key, raw, "--sweep"))


# ----------------------------------------------------------------------------- spec
@dataclass(frozen=True)
class ItemPlan:
    """One item as planned by the driver: where it goes and what it renders.

    ``scene`` is the resolved, validated scene dict, or None when the item's values are
    impossible (then ``error`` says why and the item is recorded as failed).
    """

    index: int
    id: str
    seed: int
    params: dict
    scene: dict | None
    error: str | None = None


@dataclass(frozen=True)
class DatasetSpec:
    """A dataset specification: fixed scene values, distributions, sweeps, outputs, seed.

    Build with :func:`load_spec` or :func:`spec_from_dict`.
    """

    fixed: dict = field(default_factory=dict)
    distributions: dict = field(default_factory=dict)
    sweeps: tuple = ()
    outputs: tuple = DEFAULT_OUTPUTS
    seed: int = 0
    count: int | None = None
    base_dir: str = "."
    source: str | None = None
    splits: tuple = DEFAULT_SPLITS
    split_seed: int | None = None
    webdataset: bool = False
    shard_items: int = SHARD_ITEMS
    exports: tuple = ()

    def to_dict(self) -> dict:
        """The spec as JSON (what dataset.json records)."""
        return {
            "format": FORMAT_VERSION,
            "fixed": json_ready(self.fixed),
            "distributions": {k: d.to_dict() for k, d in sorted(self.distributions.items())},
            "sweeps": [s.to_dict() for s in self.sweeps],
            "outputs": list(self.outputs),
            "seed": self.seed,
            "count": self.count,
            "source": self.source,
            "splits": dict(self.splits),
            "split_seed": self.effective_split_seed,
            "webdataset": self.webdataset,
            "shard_items": self.shard_items,
            "exports": dict(self.exports),
        }

    @functools.cached_property
    def hash(self) -> str:
        """SHA-256 of what decides the items (fixed values, distributions, sweeps, seed);
        not of the outputs or the count, so either can change on resume. A scene or spectrum
        file counts by its content, not its path, so the same spec and files give the same items
        in any folder on any machine (the absolute path of an XML scene made them differ)."""
        decisive = {k: v for k, v in self.to_dict().items() if k not in _UNHASHED}
        text = json.dumps(_by_content(decisive), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    @property
    def grid_size(self) -> int:
        """Grid points of the sweeps (1 without sweeps)."""
        return math.prod(len(s.values) for s in self.sweeps) if self.sweeps else 1

    def item_count(self, n: int | None = None) -> int:
        """Items in the dataset: ``n`` (or the spec's count) per grid point of the sweeps.

        Raises
        ------
        ConfigError
            Without sweeps, when neither ``n`` nor the spec gives a count.
        """
        n = self.count if n is None else n
        if n is None:
            if not self.sweeps:
                raise ConfigError("give the number of items: -n N (or n = N in the spec's [dataset] table)")
            n = 1
        if not isinstance(n, int) or isinstance(n, bool) or n < 1:
            raise ConfigError(f"-n {n!r}: the number of items must be a whole number >= 1")
        return n * self.grid_size

    @property
    def effective_split_seed(self) -> int:
        """The seed of the split assignment: ``[dataset] split_seed``, else the dataset's seed."""
        return self.seed if self.split_seed is None else self.split_seed

    def split_of(self, index: int) -> str:
        """The split of item ``index``: the first split whose cumulative fraction exceeds
        u = SHA-256(split seed, index) / 2^64 (uniform on [0, 1)).

        Each index is assigned on its own, so an item keeps its split when ``-n`` grows, on
        resume, and whichever items failed; the shares of a split are binomial about its
        fraction (not exact, as a shuffled list cut at the fractions would be, which reassigns
        items whenever N changes).

        Parameters
        ----------
        index
            Item index, 0-based.

        Returns
        -------
        str
            A name of ``[dataset] splits`` (``"train"`` without it).

        References
        ----------
        .. [1] FIPS 180-4, SHA-256: its output bits are indistinguishable from uniform.
        """
        digest = hashlib.sha256(f"spectral_cam.split:{self.effective_split_seed}:{int(index)}".encode()).digest()
        u = int.from_bytes(digest[:8], "big") / 2.0 ** 64
        total = 0.0
        for name, fraction in self.splits:
            total += fraction
            if u < total:
                return name
        return next(name for name, fraction in reversed(self.splits) if fraction > 0)  # u within rounding of 1

    def _entropy(self) -> int:
        return int(self.hash[:32], 16)  # 128 bits of the hash, which holds the dataset seed

    def item_seed(self, index: int) -> int:
        """The item's render seed: a 32-bit word of ``SeedSequence(hash, (index, 1))``."""
        return int(np.random.SeedSequence(self._entropy(), spawn_key=(index, 1)).generate_state(1)[0])

    def plan_item(self, index: int, n: int | None = None) -> ItemPlan:
        """Sweep values, draws and the validated scene of item ``index``.

        Parameters
        ----------
        index
            Item index, 0-based.
        n
            Items per grid point (sweeps only; default: the spec's count, else 1).

        Returns
        -------
        ItemPlan
            With ``scene`` None and the reason in ``error`` when the item's values are
            impossible (it is then recorded as failed, never rendered).

        References
        ----------
        .. [1] NumPy ``SeedSequence``: streams from (entropy, spawn_key) are independent and
           reproducible, whatever order items are planned in.
        """
        per_point = (self.count or 1) if n is None else n
        params: dict[str, Any] = {}
        if self.sweeps:
            # grid point index // per_point in mixed radix, the last axis fastest (itertools.product order)
            rest = (index // per_point) % self.grid_size
            point = []
            for axis in reversed(self.sweeps):
                rest, digit = divmod(rest, len(axis.values))
                point.append(axis.values[digit])
            params.update({s.key: json_ready(v) for s, v in zip(self.sweeps, reversed(point))})
        rng = np.random.default_rng(np.random.SeedSequence(self._entropy(), spawn_key=(index, 0)))
        for key in sorted(self.distributions):
            params[key] = self.distributions[key].sample(rng)
        seed = self.item_seed(index)
        overrides = dict(params)
        if "render.seed" not in params and "seed" not in self.fixed.get("render", {}):
            overrides["render.seed"] = seed
        item_id = f"{index:06d}"
        try:
            config = self.scene(overrides)
        except ConfigError as exc:
            return ItemPlan(index, item_id, seed, params, None, f"ConfigError: {exc}")
        return ItemPlan(index, item_id, seed, params, config.to_dict())

    def scene(self, overrides: Mapping[str, Any] | None = None) -> SceneConfig:
        """The validated scene of the fixed values with ``overrides`` (``{"section.key": value}``)
        on top, as an item renders it (a thin lens unless the spec names another model;
        ``render.spectral_output`` following the ``radiance`` output).

        Raises
        ------
        ConfigError
            For an impossible value, saying what would be valid.
        """
        fixed = {section: dict(table) for section, table in self.fixed.items()}
        fixed.setdefault("lens", {}).setdefault("model", "thin")
        fixed.setdefault("render", {})["spectral_output"] = "radiance" in self.outputs
        config = scene_from_dict(fixed, overrides=dict(overrides or {}), base_dir=self.base_dir)
        if "radiance" in self.outputs and config.render.bands == "camera":
            raise ConfigError("render.bands = 'camera' renders no spectrum, so output 'radiance' cannot be "
                              "written; use render.bands = 'auto' or a band grid such as '400:700:10'")
        return config

    def check_values(self) -> None:
        """Load every value a key can take through the scene's checks, before any item is planned:
        each choice and sweep value, and the bounds of each (log-)uniform draw, on the fixed
        values.

        A value is refused only where the fixed values alone load and it fails beside each of
        eight draws of the other drawn and swept keys (a fixed seed); a value that fails only
        beside some draws of another key is left to the items' plans, which record each such
        item as failed with the reason (and ``--dry-run`` lists them).

        Raises
        ------
        ConfigError
            Naming the key, the value (and which of the listed values it is) and the scene's reason.
        """
        try:
            self.scene()
        except ConfigError:
            return  # the fixed values alone fail: every item says so, no value is to blame
        for key, where, value in self._values_to_check():
            rng = np.random.default_rng(0)
            contexts = 8 if (set(self.distributions) | {s.key for s in self.sweeps}) - {key} else 1
            errors = []
            for _ in range(contexts):
                errors.append(self._refusal({**self._draw_others(key, rng), key: value}))
                if errors[-1] is None:
                    break
            else:
                beside = " beside 8 draws of the other keys" if contexts > 1 else ""
                raise ConfigError(f"{key}: {where} {json.dumps(json_ready(value))}, is refused by the scene "
                                  f"checks{beside} ({errors[0]}); remove it or give a value the scene takes")

    def _refusal(self, overrides: Mapping[str, Any]) -> str | None:
        try:
            self.scene(overrides)
        except ConfigError as exc:
            return str(exc)
        return None

    def _draw_others(self, key: str, rng: np.random.Generator) -> dict:
        drawn = {k: d.sample(rng) for k, d in self.distributions.items() if k != key}
        drawn.update({s.key: json_ready(s.values[int(rng.integers(len(s.values)))]) for s in self.sweeps
                      if s.key != key})
        return drawn

    def _values_to_check(self):
        for key, dist in sorted(self.distributions.items()):
            if dist.kind == "choice":
                for k, value in enumerate(dist.values):
                    yield key, f"choice value {k + 1} of {len(dist.values)},", value
                continue
            for name, bound in (("low", dist.low), ("high", dist.high)):
                value = list(bound) if isinstance(bound, tuple) else bound
                if dist.whole:
                    value = json_ready(np.asarray(np.ceil(value) if name == "low" else np.floor(value), dtype=int))
                yield key, f"{dist.kind} {name} bound", value
        for axis in self.sweeps:
            for k, value in enumerate(axis.values):
                yield axis.key, f"sweep value {k + 1} of {len(axis.values)},", value


def spec_from_dict(
    data: Mapping[str, Any],
    *,
    base_dir: str | Path = ".",
    sweeps: Sequence[str | Sweep] = (),
    overrides: Sequence[str] | Mapping[str, Any] = (),
    source: str | None = None,
) -> DatasetSpec:
    """Build a :class:`DatasetSpec` from a parsed spec (as read from TOML).

    Parameters
    ----------
    data
        ``{"dataset": {...}, "lens": {"f_number": {"log_uniform": [1.4, 16]}, ...}, ...}``.
    base_dir
        Folder that relative paths (base scene file, CSV, XML) are resolved against.
    sweeps
        Extra grid axes (``--sweep`` strings or :class:`Sweep`), after the spec's own.
    overrides
        Fixed values (``--set section.key=value``) applied on top of the spec.
    source
        The spec file, recorded in dataset.json.

    Raises
    ------
    ConfigError
        For an unknown section, key, output or distribution, a malformed sweep, or a choice,
        sweep value or bound the scene cannot render (:meth:`DatasetSpec.check_values`).

    Examples
    --------
    >>> spec = spec_from_dict({"dataset": {"seed": 1}, "lens": {"f_number": {"choice": [2.8, 5.6]}}},
    ...                       sweeps=["lens.focus_distance_m=[1.0, 3.0]"])
    >>> spec.item_count(2), spec.outputs
    (4, ('raw', 'image', 'depth', 'defocus', 'all_in_focus', 'clean_rgb'))
    >>> plan = spec.plan_item(2, 2)
    >>> plan.id, plan.params["lens.focus_distance_m"], plan.params["lens.f_number"] in (2.8, 5.6)
    ('000002', 3.0, True)
    """
    base_dir = Path(base_dir).resolve()
    data = dict(data)
    settings = dict(data.pop("dataset", {}) or {})
    valid_settings = ("scene", "seed", "n", "outputs", "sweep", "splits", "split_seed", "webdataset", "shard_items",
                      "exports")
    unknown = sorted(set(settings) - set(valid_settings))
    if unknown:
        raise ConfigError(f"unknown key(s) {', '.join('dataset.' + k for k in unknown)}; valid keys of "
                          f"[dataset]: {', '.join(valid_settings)}")
    fixed: dict[str, dict[str, Any]] = {}
    if settings.get("scene"):
        scene_path = Path(str(settings["scene"])).expanduser()
        scene_path = scene_path if scene_path.is_absolute() else base_dir / scene_path
        try:
            base = tomllib.loads(scene_path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise ConfigError(f"dataset.scene = {str(settings['scene'])!r}: cannot read it as a TOML scene "
                              f"file ({exc})") from None
        for section, table in base.items():
            if not isinstance(table, dict):
                raise ConfigError(f"{scene_path}: [{section}] must be a table")
            for key, value in table.items():
                _check_key(f"{section}.{key}", str(scene_path))
                fixed.setdefault(section, {})[key] = _resolve_paths(value, scene_path.parent.resolve())
    distributions: dict[str, Distribution] = {}
    for section, table in data.items():
        if not isinstance(table, dict):
            raise ConfigError(f"spec: [{section}] must be a table of key = value pairs")
        for key, value in table.items():
            dotted = f"{section}.{key}"
            _check_key(dotted, "spec")
            if dotted == "render.spectral_output":
                raise ConfigError("spec: render.spectral_output follows the dataset's outputs; add or remove "
                                  "'radiance' in [dataset] outputs instead")
            if isinstance(value, dict):
                distributions[dotted] = _parse_distribution(dotted, _resolve_paths_table(value, base_dir))
                fixed.get(section, {}).pop(key, None)
            else:
                fixed.setdefault(section, {})[key] = _resolve_paths(value, base_dir)
    if isinstance(overrides, Mapping):
        items = list(overrides.items())
    else:
        items = [parse_override(text) for text in overrides]
    for dotted, value in items:
        section, key = _check_key(dotted, "--set")
        if dotted == "render.spectral_output":
            raise ConfigError("render.spectral_output follows the dataset's outputs; add or remove 'radiance' "
                              "in [dataset] outputs instead")
        distributions.pop(dotted, None)
        fixed.setdefault(section, {})[key] = _resolve_paths(value, Path.cwd())

    axes: list[Sweep] = []
    table = settings.get("sweep", {}) or {}
    if not isinstance(table, dict):
        raise ConfigError("dataset.sweep must be a table: { \"lens.f_number\" = \"1.4:8:5:log\" }")
    for key, spec in table.items():
        _check_key(key, "dataset.sweep")
        axes.append(Sweep(key, _sweep_values(key, spec, "dataset.sweep")))
    axes += [s if isinstance(s, Sweep) else parse_sweep(s) for s in sweeps]
    seen = set()
    for axis in axes:
        if axis.key in seen:
            raise ConfigError(f"sweep key {axis.key} is given twice; give each key once")
        if axis.key in distributions:
            raise ConfigError(f"{axis.key} is both swept and drawn from a distribution; choose one")
        seen.add(axis.key)

    outputs = settings.get("outputs", list(DEFAULT_OUTPUTS))
    if isinstance(outputs, str):
        outputs = [outputs]
    if not isinstance(outputs, list) or not outputs:
        raise ConfigError(f"dataset.outputs must be a non-empty list among {', '.join(LABELS)}")
    for name in outputs:
        if name not in LABELS:
            raise ConfigError(f"dataset.outputs: unknown output {name!r}; valid: {', '.join(LABELS)}")
    seed = settings.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ConfigError(f"dataset.seed = {seed!r}: must be a whole number >= 0")
    count = settings.get("n")
    if count is not None and (not isinstance(count, int) or isinstance(count, bool) or count < 1):
        raise ConfigError(f"dataset.n = {count!r}: must be a whole number >= 1")
    ordered = tuple(name for name in LABELS if name in outputs)
    spec = DatasetSpec(fixed=fixed, distributions=distributions, sweeps=tuple(axes), outputs=ordered,
                       seed=seed, count=count, base_dir=str(base_dir), source=source, **_sharding(settings),
                       exports=_exports(settings.get("exports", ()), ordered))
    spec.check_values()
    return spec


def _exports(value: Any, outputs: Sequence[str]) -> tuple:
    """``[dataset] exports``: a list of format names (their default options) or a table of
    format = {options}, checked (:func:`~.exports.check_exports`) as (format, options) pairs."""
    from .exports import EXPORTS, check_exports

    example = (f"e.g. exports = [\"coco\", \"depth_png\"] or exports = {{ depth_png = {{ scale_m = 0.00390625 }} }}; "
               f"formats: {', '.join(EXPORTS.names())}")
    if isinstance(value, (list, tuple)):
        if not all(isinstance(name, str) for name in value) or len(set(value)) != len(value):
            raise ConfigError(f"dataset.exports = {value!r}: give each format name once, {example}")
        value = {name: {} for name in value}
    if not isinstance(value, Mapping):
        raise ConfigError(f"dataset.exports = {value!r}: {example}")
    return tuple(check_exports(value, outputs).items())


def with_exports(spec: DatasetSpec, names: Sequence[str]) -> DatasetSpec:
    """``spec`` also writing the export formats ``names`` (default options), checked against its
    outputs (``spectral-cam dataset --export``); formats it already names keep their options."""
    exports = dict(spec.exports)
    exports.update({name: {} for name in names if name not in exports})
    return dataclasses.replace(spec, exports=_exports(exports, spec.outputs))


def _sharding(settings: Mapping[str, Any]) -> dict:
    """``splits``, ``split_seed``, ``webdataset`` and ``shard_items`` of ``[dataset]``, checked."""
    splits = settings.get("splits", dict(DEFAULT_SPLITS))
    example = "e.g. splits = { train = 0.8, val = 0.1, test = 0.1 }"
    if not isinstance(splits, dict) or not splits:
        raise ConfigError(f"dataset.splits = {splits!r}: give a table of split name = fraction, {example}")
    for name, fraction in splits.items():
        if not _SPLIT_NAME.match(name):
            raise ConfigError(f"dataset.splits: split name {name!r} must be a letter then letters, digits or _ "
                              f"(Hugging Face split names); {example}")
        if (not isinstance(fraction, (int, float)) or isinstance(fraction, bool) or not math.isfinite(fraction)
                or not 0 <= fraction <= 1):
            raise ConfigError(f"dataset.splits.{name} = {fraction!r}: a fraction must be a number in [0, 1]; {example}")
    if abs(sum(splits.values()) - 1.0) > 1e-9:
        raise ConfigError(f"dataset.splits: the fractions sum to {sum(splits.values()):.12g}; they must sum to 1, "
                          f"{example}")
    split_seed = settings.get("split_seed")
    if split_seed is not None and (not isinstance(split_seed, int) or isinstance(split_seed, bool) or split_seed < 0):
        raise ConfigError(f"dataset.split_seed = {split_seed!r}: must be a whole number >= 0 (default: dataset.seed)")
    webdataset = settings.get("webdataset", False)
    if not isinstance(webdataset, bool):
        raise ConfigError(f"dataset.webdataset = {webdataset!r}: must be true or false (write WebDataset .tar shards)")
    shard_items = settings.get("shard_items", SHARD_ITEMS)
    if not isinstance(shard_items, int) or isinstance(shard_items, bool) or shard_items < 1:
        raise ConfigError(f"dataset.shard_items = {shard_items!r}: items per shard must be a whole number >= 1")
    return {"splits": tuple((name, float(f)) for name, f in splits.items()), "split_seed": split_seed,
            "webdataset": webdataset, "shard_items": shard_items}


def _resolve_paths_table(table: Mapping[str, Any], base_dir: Path) -> dict:
    """A distribution table with its paths absolute; ``{ files = "rooms/*.xml" }`` becomes the
    choice of the files that pattern matches (relative to the spec's folder, sorted, so the
    drawn file of an item does not depend on the order the file system lists them)."""
    if "files" in table:
        pattern = table["files"]
        if set(table) - {"files", "weights"} or not isinstance(pattern, str) or not pattern.strip():
            raise ConfigError(f"{{ files = {pattern!r} }}: give one glob pattern, e.g. {{ files = \"rooms/*.xml\" }}")
        absolute = Path(pattern).expanduser()
        absolute = absolute if absolute.is_absolute() else base_dir / absolute
        found = sorted(str(p.resolve()) for p in Path(absolute.anchor).glob(str(absolute.relative_to(absolute.anchor)))
                       if p.is_file())
        if not found:
            raise ConfigError(f"{{ files = {pattern!r} }} matches no file (looked for {absolute})")
        if "weights" in table:
            raise ConfigError(f"{{ files = {pattern!r} }}: weights apply to an explicit choice list")
        return {"choice": found}
    return {k: (_resolve_paths(v, base_dir) if k == "choice" else v) for k, v in table.items()}


def load_spec(
    path: str | Path,
    *,
    sweeps: Sequence[str | Sweep] = (),
    overrides: Sequence[str] | Mapping[str, Any] = (),
) -> DatasetSpec:
    """Read a dataset spec file (TOML).

    Parameters
    ----------
    path
        The spec: a scene file whose values may be distributions, plus ``[dataset]``.
    sweeps
        ``--sweep`` strings (``section.key=start:stop:count``).
    overrides
        ``--set`` strings (``section.key=value``), fixed values on top of the spec.

    Returns
    -------
    DatasetSpec

    Raises
    ------
    ConfigError
        When the file is missing or invalid, saying what would be valid.
    """
    path = Path(path)
    data = read_toml(path, "dataset spec")
    return spec_from_dict(data, base_dir=path.parent, sweeps=sweeps, overrides=overrides,
                          source=str(path.resolve()))
