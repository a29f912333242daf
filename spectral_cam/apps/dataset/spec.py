"""Dataset specs: fixed scene values, distributions, sweeps, outputs and seed; one plan per item.

A spec is a scene file (any ``[section] key = value`` of docs/design.md, "Scene file") in which any
value may instead be a distribution (:data:`DISTRIBUTIONS`, or ``{ files = "glob" }``: a choice of
the files it matches, e.g. a folder of XML scenes), plus a ``[dataset]`` table (``scene``,
``seed``, ``n``, ``outputs``, ``sweep``). :meth:`DatasetSpec.plan_item` turns (spec, index) into
the item's seed, sampled parameters and validated scene, the same on any machine and in any order;
:meth:`DatasetSpec.split_of` puts each index in a split (``[dataset] splits``, ``split_seed``) by a
hash of (split seed, index) alone, so an item keeps its split when the dataset grows or resumes.

The pieces a spec is made of live beside it: the scene keys and the paths in values
(:mod:`.spec_keys`), distributions (:mod:`.distributions`) and sweep axes (:mod:`.sweeps`), whose
public names are importable from here too.

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
from .distributions import DISTRIBUTIONS, Distribution, parse_distribution
from .labels import DEFAULT_OUTPUTS, LABELS
from .spec_keys import by_content, check_key, resolve_paths, resolve_paths_table
from .sweeps import Sweep, parse_sweep, sweep_values

__all__ = ["DISTRIBUTIONS", "FORMAT_VERSION", "DEFAULT_SPLITS", "SHARD_ITEMS", "Distribution", "Sweep", "parse_sweep",
           "ItemPlan", "DatasetSpec",
           "spec_from_dict", "load_spec", "with_exports"]

#: Format version of dataset.json, part of the spec hash.
FORMAT_VERSION = 1
#: Splits of a spec without ``[dataset] splits``: every item in ``train`` (Hugging Face's default split).
DEFAULT_SPLITS = (("train", 1.0),)
#: Items per Parquet and WebDataset shard by default (``[dataset] shard_items``).
SHARD_ITEMS = 1000
#: [dataset] keys that do not decide the items' pixels (not in the spec hash: they may change on resume).
_UNHASHED = ("outputs", "count", "source", "splits", "split_seed", "webdataset", "shard_items", "exports")
_SPLIT_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


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
        text = json.dumps(by_content(decisive), sort_keys=True, separators=(",", ":"))
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
    settings = _dataset_settings(data.pop("dataset", {}) or {})
    fixed = _base_scene(settings, base_dir)
    distributions = _spec_tables(data, fixed, base_dir)
    _apply_overrides(overrides, fixed, distributions)
    axes = _sweep_axes(settings, sweeps, distributions)
    ordered = _outputs(settings)
    seed, count = _seed_and_count(settings)
    spec = DatasetSpec(fixed=fixed, distributions=distributions, sweeps=tuple(axes), outputs=ordered,
                       seed=seed, count=count, base_dir=str(base_dir), source=source, **_sharding(settings),
                       exports=_exports(settings.get("exports", ()), ordered))
    spec.check_values()
    return spec


#: Keys of a spec's ``[dataset]`` table.
_DATASET_KEYS = ("scene", "seed", "n", "outputs", "sweep", "splits", "split_seed", "webdataset", "shard_items",
                 "exports")


def _dataset_settings(table: Mapping[str, Any]) -> dict:
    """The ``[dataset]`` table, its keys checked."""
    settings = dict(table)
    unknown = sorted(set(settings) - set(_DATASET_KEYS))
    if unknown:
        raise ConfigError(f"unknown key(s) {', '.join('dataset.' + k for k in unknown)}; valid keys of "
                          f"[dataset]: {', '.join(_DATASET_KEYS)}")
    return settings


def _base_scene(settings: Mapping[str, Any], base_dir: Path) -> dict[str, dict[str, Any]]:
    """``{section: {key: value}}`` of ``[dataset] scene`` (a TOML scene file), its paths resolved
    against its own folder; empty without one."""
    fixed: dict[str, dict[str, Any]] = {}
    if not settings.get("scene"):
        return fixed
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
            check_key(f"{section}.{key}", str(scene_path))
            fixed.setdefault(section, {})[key] = resolve_paths(value, scene_path.parent.resolve())
    return fixed


def _spec_tables(data: Mapping[str, Any], fixed: dict, base_dir: Path) -> dict[str, Distribution]:
    """The spec's own scene tables: fixed values go into ``fixed`` (over the base scene's), inline
    tables become distributions (replacing the base scene's value); returns the distributions."""
    distributions: dict[str, Distribution] = {}
    for section, table in data.items():
        if not isinstance(table, dict):
            raise ConfigError(f"spec: [{section}] must be a table of key = value pairs")
        for key, value in table.items():
            dotted = f"{section}.{key}"
            check_key(dotted, "spec")
            if dotted == "render.spectral_output":
                raise ConfigError("spec: render.spectral_output follows the dataset's outputs; add or remove "
                                  "'radiance' in [dataset] outputs instead")
            if isinstance(value, dict):
                distributions[dotted] = parse_distribution(dotted, resolve_paths_table(value, base_dir))
                fixed.get(section, {}).pop(key, None)
            else:
                fixed.setdefault(section, {})[key] = resolve_paths(value, base_dir)
    return distributions


def _apply_overrides(overrides: Sequence[str] | Mapping[str, Any], fixed: dict, distributions: dict) -> None:
    """``--set`` values: fixed, on top of the spec (a drawn key becomes fixed); paths against the
    working directory."""
    if isinstance(overrides, Mapping):
        items = list(overrides.items())
    else:
        items = [parse_override(text) for text in overrides]
    for dotted, value in items:
        section, key = check_key(dotted, "--set")
        if dotted == "render.spectral_output":
            raise ConfigError("render.spectral_output follows the dataset's outputs; add or remove 'radiance' "
                              "in [dataset] outputs instead")
        distributions.pop(dotted, None)
        fixed.setdefault(section, {})[key] = resolve_paths(value, Path.cwd())


def _sweep_axes(settings: Mapping[str, Any], sweeps: Sequence[str | Sweep], distributions: Mapping) -> list[Sweep]:
    """``[dataset] sweep``'s axes, then ``sweeps``; each key once and none also drawn."""
    axes: list[Sweep] = []
    table = settings.get("sweep", {}) or {}
    if not isinstance(table, dict):
        raise ConfigError("dataset.sweep must be a table: { \"lens.f_number\" = \"1.4:8:5:log\" }")
    for key, spec in table.items():
        check_key(key, "dataset.sweep")
        axes.append(Sweep(key, sweep_values(key, spec, "dataset.sweep")))
    axes += [s if isinstance(s, Sweep) else parse_sweep(s) for s in sweeps]
    seen = set()
    for axis in axes:
        if axis.key in seen:
            raise ConfigError(f"sweep key {axis.key} is given twice; give each key once")
        if axis.key in distributions:
            raise ConfigError(f"{axis.key} is both swept and drawn from a distribution; choose one")
        seen.add(axis.key)
    return axes


def _outputs(settings: Mapping[str, Any]) -> tuple[str, ...]:
    """``[dataset] outputs`` checked against the labels, in the labels' order."""
    outputs = settings.get("outputs", list(DEFAULT_OUTPUTS))
    if isinstance(outputs, str):
        outputs = [outputs]
    if not isinstance(outputs, list) or not outputs:
        raise ConfigError(f"dataset.outputs must be a non-empty list among {', '.join(LABELS)}")
    for name in outputs:
        if name not in LABELS:
            raise ConfigError(f"dataset.outputs: unknown output {name!r}; valid: {', '.join(LABELS)}")
    return tuple(name for name in LABELS if name in outputs)


def _seed_and_count(settings: Mapping[str, Any]) -> tuple[int, int | None]:
    """``[dataset] seed`` (default 0) and ``n`` (default None), checked."""
    seed = settings.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ConfigError(f"dataset.seed = {seed!r}: must be a whole number >= 0")
    count = settings.get("n")
    if count is not None and (not isinstance(count, int) or isinstance(count, bool) or count < 1):
        raise ConfigError(f"dataset.n = {count!r}: must be a whole number >= 1")
    return seed, count


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
