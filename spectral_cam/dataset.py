"""Synthetic datasets: randomised or swept scenes rendered on a Dask cluster, resumable.

``spectral-cam dataset SPEC.toml -n N -o DIR`` renders N items. The spec is a scene file
(any ``[section] key = value`` of DESIGN.md) in which any value may instead be a
distribution, plus a ``[dataset]`` table::

    [dataset]
    scene = "scenes/dof.toml"      # optional base scene file (the spec's tables win)
    seed = 0                       # dataset seed; item seeds derive from (spec, index)
    n = 100                        # default item count (-n wins)
    outputs = ["raw", "image", "depth", "defocus", "all_in_focus", "clean_rgb"]  # + "radiance"
    # sweep = { "exposure.iso" = [100, 800, 3200] }   # optional grid axes (a swept key takes no distribution)

    [sensor]
    model = { choice = ["nikon_d850", "canon_eos_5d_mkiv", "sony_ilce_7m3"] }
    width_px = 256
    [illuminant]
    spd = { choice = ["D65", "A", "blackbody:5000"], weights = [2, 1, 1] }
    illuminance_lux = { log_uniform = [50, 20000] }
    [lens]
    f_number = { log_uniform = [1.4, 16] }
    focus_distance_m = { uniform = [0.5, 5.0] }
    [scene]
    preset = { choice = ["colorchecker", "dof_targets", "slanted_edge"] }
    depths_m = { uniform = [[0.5, 1.0, 2.0], [1.0, 3.0, 8.0]] }   # element-wise bounds

Distributions (:data:`DISTRIBUTIONS`): ``uniform = [low, high]``, ``log_uniform = [low,
high]`` (uniform in log, both > 0), ``choice = [v, ...]`` with optional ``weights``; list
bounds sample list-valued keys element by element; keys whose type is a whole number are
rounded. ``--sweep key=start:stop:count`` (``:log`` for a geometric series, or
``key=[v1, v2, ...]``) adds a grid axis; several sweeps give their product, and ``-n`` then
counts items per grid point. A sweep renders a contact sheet and, for the ``dof_targets``
and ``point_sources`` presets, a chart of measured blur against depth beside the thin-lens
prediction.

Each item is a folder ``DIR/items/<index:06d>/`` that appears in one rename when complete
(:func:`spectral_cam.io.staged_directory`):

    raw.dng            the simulated RAW                                    ("raw")
    image.png          the developed sRGB image (every isp.outputs format)   ("image")
    radiance.exr       spectral radiance per nm, Fichet et al. layout       ("radiance", opt-in)
    depth.exr          camera-space z (m)                                   ("depth")
    defocus.exr        signed thin-lens CoC diameter in pixels, channel CoC ("defocus")
    all_in_focus.png   the same pose through a pinhole at the same exposure ("all_in_focus")
    clean_rgb.exr      noise-free linear camera RGB (1 = white level − black level)  ("clean_rgb")
    meta.json          resolved config, optics, sensor, seeds, sampled parameters, timings

Items render through a thin lens (``lens.model = "thin"`` unless the spec says otherwise,
so the defocus label always describes the image), ``render.spectral_output`` follows the
``radiance`` output (without it, ``render.bands = "auto"`` may choose the faster camera
film), and the all-in-focus render keeps every setting but the lens model and fixes
``exposure.time_s`` to the main item's resolved exposure. Relative paths in the spec
resolve against its folder (in ``--set`` values, against the working directory).

``DIR/manifest.jsonl`` holds one row per item (status "done", "failed" or, while a run is
under way or after it was interrupted, "pending"; seed, parameters, files, error);
``DIR/dataset.json`` the spec and its hash; ``DIR/contact_sheet.png`` the first items'
images. Items are independent tasks:

- seeds: item *i* draws its parameters from ``SeedSequence(spec hash, (i, 0))`` and renders
  with ``render.seed`` = the first word of ``SeedSequence(spec hash, (i, 1))`` unless the
  spec sets ``render.seed``; the same spec gives the same items on any machine, in any
  order, and ``-n`` can grow a random dataset without changing its first items (in a sweep
  the items per grid point set which index gets which point, so a different ``-n`` re-plans
  them and resume renders the changed ones again);
- resume: an item whose folder is complete (its meta.json lists files that all exist, made
  from the same spec hash with the same seed and parameters, holding the outputs asked
  for) is skipped; anything else is rendered again and replaces the folder atomically;
- a worker that dies mid-item (killed, out of memory) loses only that item, which is
  submitted again (``--retries``, default 2); an item that raises (an impossible value, a
  broken scene file) is recorded as failed with its error and the run goes on;
- a progress bar on stderr shows items done, failures, the rate and the ETA.

Execution: any ``concurrent.futures.Executor`` (:func:`generate_dataset`); by default a Dask
``LocalCluster`` of spawned worker processes (``--workers K``; one render per worker, one
Dask thread each, Mitsuba's thread pool sized to the worker's share of the cores); with
``--scheduler tcp://HOST:8786`` the same command runs on a running Dask cluster, whose
workers must have spectral_cam installed and see DIR at the same path (a shared file
system). ``--scheduler inline`` runs the items one after another in this process.

Cluster recipes
---------------
SLURM, with dask-jobqueue (``pip install dask-jobqueue``)::

    from dask.distributed import Client
    from dask_jobqueue import SLURMCluster
    from spectral_cam.dataset import generate_dataset, load_spec

    cluster = SLURMCluster(cores=8, processes=1, memory="16GB", walltime="04:00:00",
                           job_extra_directives=["--cpus-per-task=8"],
                           job_script_prologue=["source /path/to/venv/bin/activate"])
    cluster.adapt(minimum_jobs=1, maximum_jobs=32)   # one worker process (one render) per job
    with Client(cluster) as client:
        generate_dataset(load_spec("spec.toml"), "/shared/dataset", n=10000,
                         executor=client.get_executor(pure=False))

(or start the scheduler yourself, ``dask scheduler`` on a login node, and submit jobs that run
``dask worker tcp://LOGIN:8786 --nworkers 1 --nthreads 1``; then run
``spectral-cam dataset spec.toml -n 10000 -o /shared/dataset --scheduler tcp://LOGIN:8786``).
``processes=1`` keeps one render per job, and Mitsuba then uses the job's cores.

Kubernetes, with the Dask Helm chart or dask-kubernetes' operator::

    helm install dask dask/dask --set worker.replicas=16 \\
        --set worker.image.repository=YOUR/spectral-cam-image \\
        --set worker.resources.limits.cpu=4 --set worker.args="{--nthreads,1}"
    # mount the output volume (ReadWriteMany) at the same path in the worker pods and here
    spectral-cam dataset spec.toml -n 10000 -o /data/dataset --scheduler tcp://dask-scheduler:8786

(dask-kubernetes: ``KubeCluster(name="spectral-cam", image=..., n_workers=16,
resources={"limits": {"cpu": "4"}}, worker_command="dask worker --nthreads 1")``, then
``Client(cluster).get_executor(pure=False)`` as above.) Resubmitting the same command after
a pre-empted job resumes where it stopped.

References
----------
.. [1] Rocklin, M. (2015). Dask: parallel computation with blocked algorithms and task
   scheduling. Proc. 14th Python in Science Conference, 130–136.
.. [2] O'Neill, M. E. (2014) and NumPy ``SeedSequence``: independent streams from a root
   entropy and a spawn key (numpy.random.SeedSequence documentation, NEP 19).
.. [3] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10 (circle of confusion).
.. [4] EMVA Standard 1288, Release 4.0 Linear (2021), §2 (mean photo-electrons).
"""

from __future__ import annotations

import argparse
import collections
import concurrent.futures as cf
import contextlib
import dataclasses
import functools
import hashlib
import json
import math
import os
import re
import shutil
import signal
import sys
import time
import tomllib
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

import numpy as np

from .errors import ConfigError
from .io import atomic_path, staged_directory
from .scene import SceneConfig, parse_override, scene_from_dict

__all__ = [
    "DISTRIBUTIONS",
    "OUTPUTS",
    "DEFAULT_OUTPUTS",
    "Distribution",
    "Sweep",
    "DatasetSpec",
    "ItemPlan",
    "DatasetSummary",
    "load_spec",
    "spec_from_dict",
    "parse_sweep",
    "defocus_map_px",
    "clean_camera_rgb",
    "disc_otf",
    "measure_blur",
    "measure_scene_blur",
    "item_task",
    "render_item",
    "generate_dataset",
    "default_workers",
    "ProgressBar",
    "local_cluster",
    "write_contact_sheet",
    "write_blur_chart",
    "configure_parser",
    "run",
]

#: Distributions a spec value may take (an inline table with exactly one of these keys).
DISTRIBUTIONS = ("uniform", "log_uniform", "choice")
#: What an item can hold besides meta.json, and the file each output writes.
OUTPUTS = {
    "raw": "raw.dng",
    "image": "image.<isp.outputs>",
    "radiance": "radiance.exr",
    "depth": "depth.exr",
    "defocus": "defocus.exr",
    "all_in_focus": "all_in_focus.<isp.outputs>",
    "clean_rgb": "clean_rgb.exr",
}
#: Outputs of an item unless the spec's ``[dataset] outputs`` says otherwise (the spectral
#: cube, 31 float32 channels, is opt-in).
DEFAULT_OUTPUTS = ("raw", "image", "depth", "defocus", "all_in_focus", "clean_rgb")
#: Presets whose blur the item measures (per depth) when it renders the all-in-focus image.
BLUR_PRESETS = ("dof_targets", "point_sources")
#: Environment variable of the worker-death test hook: the absolute path of one item folder.
#: The first attempt at that item SIGKILLs its own worker process mid-item and leaves the
#: marker file ``<path>.killed``; later attempts run normally. For tests only.
TEST_KILL_ENV = "SPECTRAL_CAM_DATASET_TEST_KILL"
#: Items on the contact sheet of a dataset (the first ones; a sweep's grid is usually smaller).
CONTACT_SHEET_MAX = 64
#: Format version of dataset.json, part of the spec hash.
FORMAT_VERSION = 1
#: Seconds between manifest rewrites during a run (it is always written at the end).
MANIFEST_EVERY_S = 30.0

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


def _resolve_paths(value: Any, base_dir: Path) -> Any:
    """Make relative CSV/XML paths (in values and choices) absolute against ``base_dir``."""
    if isinstance(value, str) and value.lower().endswith((".csv", ".xml")):
        path = Path(value).expanduser()
        return str((path if path.is_absolute() else base_dir / path).resolve())
    if isinstance(value, list):
        return [_resolve_paths(v, base_dir) for v in value]
    return value


def _jsonable(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, list):
        return [_jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, np.generic):
        return value.item()
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
        Round draws to whole numbers (keys typed ``int``).
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
            return _jsonable(self.values[int(rng.choice(len(self.values), p=p))])
        low = np.asarray(self.low, dtype=float)
        high = np.asarray(self.high, dtype=float)
        if self.kind == "uniform":
            draw = rng.uniform(low, high)
        else:
            draw = np.exp(rng.uniform(np.log(low), np.log(high)))
        if self.whole:
            draw = np.rint(draw).astype(int)
        return draw.tolist() if np.ndim(draw) else (int(draw) if self.whole else float(draw))

    def to_dict(self) -> dict:
        if self.kind == "choice":
            out = {"choice": _jsonable(list(self.values))}
            if self.weights:
                out["weights"] = list(self.weights)
            return out
        return {self.kind: [_jsonable(self.low), _jsonable(self.high)]}


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
    return Distribution(key, kind, low=low, high=high, whole=whole)


# ----------------------------------------------------------------------------- sweeps
@dataclass(frozen=True)
class Sweep:
    """One axis of a grid sweep: a scene key and the values it takes, in order."""

    key: str
    values: tuple

    def to_dict(self) -> dict:
        return {"key": self.key, "values": _jsonable(list(self.values))}


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

    def to_dict(self) -> dict:
        """The spec as JSON (what dataset.json records)."""
        return {
            "format": FORMAT_VERSION,
            "fixed": _jsonable(self.fixed),
            "distributions": {k: d.to_dict() for k, d in sorted(self.distributions.items())},
            "sweeps": [s.to_dict() for s in self.sweeps],
            "outputs": list(self.outputs),
            "seed": self.seed,
            "count": self.count,
            "source": self.source,
        }

    @functools.cached_property
    def hash(self) -> str:
        """SHA-256 of what decides the items (fixed values, distributions, sweeps, seed);
        not of the outputs or the count, so either can change on resume."""
        decisive = {k: v for k, v in self.to_dict().items() if k not in ("outputs", "count", "source")}
        text = json.dumps(decisive, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    @property
    def grid_size(self) -> int:
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
            params.update({s.key: _jsonable(v) for s, v in zip(self.sweeps, reversed(point))})
        rng = np.random.default_rng(np.random.SeedSequence(self._entropy(), spawn_key=(index, 0)))
        for key in sorted(self.distributions):
            params[key] = self.distributions[key].sample(rng)
        seed = self.item_seed(index)
        overrides = dict(params)
        if "render.seed" not in params and "seed" not in self.fixed.get("render", {}):
            overrides["render.seed"] = seed
        fixed = {section: dict(table) for section, table in self.fixed.items()}
        fixed.setdefault("lens", {}).setdefault("model", "thin")
        fixed.setdefault("render", {})["spectral_output"] = "radiance" in self.outputs
        item_id = f"{index:06d}"
        try:
            config = scene_from_dict(fixed, overrides=overrides, base_dir=self.base_dir)
            if "radiance" in self.outputs and config.render.bands == "camera":
                raise ConfigError("render.bands = 'camera' renders no spectrum, so output 'radiance' cannot be "
                                  "written; use render.bands = 'auto' or a band grid such as '400:700:10'")
        except ConfigError as exc:
            return ItemPlan(index, item_id, seed, params, None, f"ConfigError: {exc}")
        return ItemPlan(index, item_id, seed, params, config.to_dict())


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
        For an unknown section, key, output or distribution, or a malformed sweep.
    """
    base_dir = Path(base_dir).resolve()
    data = dict(data)
    settings = dict(data.pop("dataset", {}) or {})
    valid_settings = ("scene", "seed", "n", "outputs", "sweep")
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
        raise ConfigError(f"dataset.outputs must be a non-empty list among {', '.join(OUTPUTS)}")
    for name in outputs:
        if name not in OUTPUTS:
            raise ConfigError(f"dataset.outputs: unknown output {name!r}; valid: {', '.join(OUTPUTS)}")
    seed = settings.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ConfigError(f"dataset.seed = {seed!r}: must be a whole number >= 0")
    count = settings.get("n")
    if count is not None and (not isinstance(count, int) or isinstance(count, bool) or count < 1):
        raise ConfigError(f"dataset.n = {count!r}: must be a whole number >= 1")
    ordered = tuple(name for name in OUTPUTS if name in outputs)
    return DatasetSpec(fixed=fixed, distributions=distributions, sweeps=tuple(axes), outputs=ordered,
                       seed=seed, count=count, base_dir=str(base_dir), source=source)


def _resolve_paths_table(table: Mapping[str, Any], base_dir: Path) -> dict:
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
    from .scene import read_toml

    path = Path(path)
    data = read_toml(path, "dataset spec")
    return spec_from_dict(data, base_dir=path.parent, sweeps=sweeps, overrides=overrides,
                          source=str(path.resolve()))


# ----------------------------------------------------------------------------- labels
def defocus_map_px(lens, depth_m: np.ndarray) -> np.ndarray:
    """Signed circle-of-confusion diameter in pixels at every pixel of a depth map.

    ``c = A·f·(z − z_f) / (z·(z_f − f)) / p`` with aperture diameter A = f/N, pixel pitch
    p and camera-space depth z: positive behind the focus plane (z > z_f), negative in
    front of it, zero on it; where nothing was hit (z = ∞) the limit A·f/(z_f − f)/p.

    Parameters
    ----------
    lens : ThinLens
        The item's lens and sensor geometry (:meth:`spectral_cam.optics.ThinLens.from_config`).
    depth_m : numpy.ndarray
        (H, W) camera-space z (m), ``inf`` where no surface was hit.

    Returns
    -------
    numpy.ndarray
        (H, W) float32 signed CoC diameter (pixels).

    References
    ----------
    .. [1] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10.
    .. [2] Potmesil, M., & Chakravarty, I. (1981). A lens and aperture camera model for
       synthetic image generation. SIGGRAPH '81, 297–305 (signed CoC for depth of field).
    """
    z = np.asarray(depth_m, dtype=np.float64)
    magnitude = lens.coc_diameter_px(z)
    sign = np.where(np.isinf(z), 1.0, np.sign(z - lens.focus_distance_m))
    return (sign * magnitude).astype(np.float32)


def clean_camera_rgb(radiance, config: SceneConfig, *, exposure_s: float) -> np.ndarray:
    """Noise-free linear camera RGB: every channel at every pixel, before CFA sampling.

    ``x_c = t·cos⁴θ·Σ_b L_b·w_b,c · K / (W − B)``: the mean photo-electrons of channel c
    through the sensor's own signal model (:func:`spectral_cam.sensor.signal_model`: band
    weights of the measured QE, lens and filter transmission, camera equation; or the
    photon-weighted camera film), scaled so that 1 is the white level above black, the
    scale of the RAW after black subtraction and normalisation. No shot, read, dark or
    fixed-pattern noise, no dark signal, no clipping (values above 1 are beyond
    saturation), no quantisation.

    Parameters
    ----------
    radiance : SpectralImage
        Band integrals of radiance (W·m⁻²·sr⁻¹), (H, W, B), or camera film channels.
    config : SceneConfig
        The item's scene (sensor, lens, ISO).
    exposure_s : float
        Exposure time (s), the one the RAW was exposed with.

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 (camera r, g, b), or (H, W, 1) for a monochrome sensor.

    References
    ----------
    .. [1] EMVA Standard 1288, Release 4.0 Linear (2021), §2.1–2.2 (μ_e = η·μ_p, gain K).
    """
    from .sensor import signal_model, system_gain

    sensor = config.sensor
    model = signal_model(radiance, config)
    scale = exposure_s * system_gain(sensor, config.exposure.iso) / (2 ** sensor.bit_depth - 1 - sensor.black_level_dn)
    rgb = np.asarray(radiance.data, dtype=np.float64) @ (np.asarray(model.weights, dtype=np.float64) * scale)
    if model.cos4 is not None:
        rgb *= np.asarray(model.cos4, dtype=np.float64)[..., None]
    return rgb.astype(np.float32)


def disc_otf(frequency_cyc_per_px, diameter_px: float):
    """Optical transfer function of a uniform disc blur: ``2·J₁(π·c·ν)/(π·c·ν)`` (signed).

    Parameters
    ----------
    frequency_cyc_per_px
        Radial spatial frequency ν (cycles per pixel).
    diameter_px
        Disc (circle of confusion) diameter c (pixels).

    References
    ----------
    .. [1] Goodman, J. W. (2005). Introduction to Fourier Optics, 3rd ed., §2.1 (the
       Fourier transform of a circle function, jinc).
    .. [2] Smith, W. J. (2008). Modern Optical Engineering, 4th ed., §11.10.
    """
    from scipy.special import j1

    x = np.pi * float(diameter_px) * np.asarray(frequency_cyc_per_px, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(np.abs(x) < 1e-9, 1.0, 2.0 * j1(x) / np.where(np.abs(x) < 1e-9, 1.0, x))


def measure_blur(sharp: np.ndarray, blurred: np.ndarray, mask: np.ndarray, *,
                 max_diameter_px: float) -> float:
    """The disc diameter that best turns the sharp image into the blurred one on a mask.

    Minimises ``Σ_mask (D_c ⊛ sharp − blurred)²`` over c ∈ [0, max], with the disc blur
    D_c applied as its transfer function (:func:`disc_otf`) to the sharp image's spectrum
    (edges mirrored): both images already integrate over their pixels (the render's box
    filter), so the disc itself must not be pixel-integrated a second time. A coarse scan,
    then golden-section refinement. For a plane at one depth the thin-lens image is the
    pinhole image convolved with the CoC disc, so c is the measured blur diameter.

    Parameters
    ----------
    sharp, blurred
        (H, W) linear images at the same exposure (e.g. the all-in-focus and the main
        item's clean camera RGB summed over channels).
    mask
        (H, W) bool: the pixels compared (away from occlusion edges and the frame).
    max_diameter_px
        Upper end of the search (pixels).

    Returns
    -------
    float
        Diameter (pixels); NaN when the mask is empty.

    References
    ----------
    .. [1] Pentland, A. P. (1987). A new sense for depth of field. IEEE TPAMI 9(4), 523–531
       (blur estimated by comparing a sharp and a defocused image).
    .. [2] Kiefer, J. (1953). Sequential minimax search for a maximum. Proc. AMS 4(3),
       502–506 (golden-section search).
    """
    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        return float("nan")
    sharp = np.asarray(sharp, dtype=np.float64)
    height, width = sharp.shape
    top = max(float(max_diameter_px), 1.0)
    pad = int(min(math.ceil(top / 2) + 4, max(height, width)))
    padded = np.pad(sharp, pad, mode="symmetric")
    spectrum = np.fft.rfft2(padded)
    radial = np.hypot(np.fft.fftfreq(padded.shape[0])[:, None], np.fft.rfftfreq(padded.shape[1])[None, :])
    target = np.asarray(blurred, dtype=np.float64)[mask]

    def cost(c: float) -> float:
        image = np.fft.irfft2(spectrum * disc_otf(radial, c), s=padded.shape)[pad:pad + height, pad:pad + width]
        return float(np.sum((image[mask] - target) ** 2))

    grid = np.linspace(0.0, top, 33)
    costs = [cost(c) for c in grid]
    best = int(np.argmin(costs))
    lo, hi = grid[max(best - 1, 0)], grid[min(best + 1, len(grid) - 1)]
    ratio = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
    fa, fb = cost(a), cost(b)
    while hi - lo > 0.01:
        if fa <= fb:
            hi, b, fb = b, a, fa
            a = hi - ratio * (hi - lo)
            fa = cost(a)
        else:
            lo, a, fa = a, b, fb
            b = lo + ratio * (hi - lo)
            fb = cost(b)
    candidates = [(costs[best], float(grid[best])), (fa, a), (fb, b)]
    return float(min(candidates)[1])


def measure_scene_blur(config: SceneConfig, depth_m: np.ndarray, sharp: np.ndarray,
                       blurred: np.ndarray) -> list[dict]:
    """Measured and thin-lens blur per depth of a ``dof_targets`` or ``point_sources`` item.

    ``dof_targets``: the pixels of each plane (from the depth map), shrunk by the largest
    predicted blur radius + 2 px so that no other plane's blur and no frame edge reaches
    them. ``point_sources``: each source is a connected blob of the all-in-focus image above 1 %
    of its peak (the background is black), its depth the depth map's median over the blob; the region is a
    disc of radius (predicted blur radius + blob radius + 3 px) around it, measured only
    when it lies inside the frame and no other source's blur spot reaches it. The
    prediction only sizes the regions; the measurement is :func:`measure_blur` between the
    all-in-focus (pinhole) and the main image.

    Both images are rendered at the sensor's resolution, so a hard edge in the pinhole image
    aliases (its harmonics above Nyquist fold back), which the disc model cannot blur away
    as the lens did: on the 8-px checkers of ``dof_targets`` the measured diameter reads
    about 0.5, 0.25, 0.13 and 0.07 px high at 1.5, 3.3, 6.6 and 10 px (the same bias
    appears on synthetic, 16×-supersampled checkers); on ``point_sources`` it stays within
    the Monte-Carlo scatter (≈1–2 %).

    Parameters
    ----------
    config
        The item's scene.
    depth_m
        (H, W) camera-space z (m).
    sharp, blurred
        (H, W) linear all-in-focus and main images at the same exposure.

    Returns
    -------
    list of dict
        ``{"depth_m", "predicted_coc_px", "measured_coc_px", "pixels", "note"}`` per depth,
        nearest first (``measured_coc_px`` None, with the reason in ``note``, where no
        usable region was left).

    References
    ----------
    .. [1] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10.
    """
    from scipy import ndimage

    from .optics import ThinLens

    lens = ThinLens.from_config(config.lens, config.sensor)
    depth = np.asarray(depth_m, dtype=np.float64)
    finite = np.isfinite(depth)
    height, width = depth.shape
    results = []
    if config.scene.preset == "dof_targets":
        depths = sorted(set(float(z) for z in config.scene.depths_m))
        predicted = {z: float(lens.coc_diameter_px(z)) for z in depths}
        margin = 0.5 * max(predicted.values()) + 2.0
        for z in depths:
            region = finite & (np.abs(depth - z) <= 1e-3 * z)
            padded = np.pad(region, 1, constant_values=False)
            inner = ndimage.distance_transform_edt(padded)[1:-1, 1:-1] > margin
            results.append(_blur_row(z, predicted[z], sharp, blurred, inner,
                                     None if inner.any() else f"no pixels {margin:.1f} px inside the plane"))
        return results
    if config.scene.preset != "point_sources":
        raise ConfigError(f"blur is measured on {', '.join(BLUR_PRESETS)} scenes; got "
                          f"scene.preset = {config.scene.preset!r}")
    sharp_image = np.asarray(sharp, dtype=np.float64)
    # the background is black; diffraction's faint skirt aside, a source is above 1 % of the peak
    labels, count = ndimage.label(sharp_image > 0.01 * sharp_image.max(), structure=np.ones((3, 3), dtype=bool))
    sources = []
    for label in range(1, count + 1):
        blob = labels == label
        blob_depth = depth[blob & finite]
        if blob_depth.size == 0:
            continue  # a sub-pixel source the one-sample depth render missed: no depth to test
        rows, cols = np.nonzero(blob)
        weights = sharp_image[blob]
        z = float(np.median(blob_depth))
        sources.append({"z": z, "row": float(rows @ weights / weights.sum()),
                        "col": float(cols @ weights / weights.sum()),
                        "r_img": math.sqrt(blob.sum() / math.pi), "c": float(lens.coc_diameter_px(z))})
    yy, xx = np.mgrid[0:height, 0:width]
    for source in sources:
        reach = 0.5 * source["c"] + source["r_img"] + 3.0
        row, col = source["row"], source["col"]
        note = None
        if not (reach <= row + 0.5 and reach <= col + 0.5 and row + reach <= height - 0.5
                and col + reach <= width - 0.5):
            note = "blur spot leaves the frame"
        elif any(math.hypot(row - o["row"], col - o["col"]) < reach + 0.5 * o["c"] + o["r_img"]
                 for o in sources if o is not source):
            note = "blur spot overlaps another source's"
        region = ((yy - row) ** 2 + (xx - col) ** 2 <= reach * reach) if note is None else np.zeros_like(finite)
        results.append(_blur_row(source["z"], source["c"], sharp, blurred, region, note))
    return sorted(results, key=lambda r: r["depth_m"])


def _blur_row(depth: float, predicted: float, sharp, blurred, region, note: str | None) -> dict:
    pixels = int(region.sum())
    measured = measure_blur(sharp, blurred, region, max_diameter_px=2.0 * predicted + 6.0) if pixels else None
    return {"depth_m": depth, "predicted_coc_px": predicted,
            "measured_coc_px": None if measured is None or not math.isfinite(measured) else measured,
            "pixels": pixels, "note": note}


# ----------------------------------------------------------------------------- one item
def _write_exr(channels: dict[str, np.ndarray], path: Path, attributes: dict[str, str]) -> Path:
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **attributes}
    with atomic_path(path) as tmp:
        with OpenEXR.File(header, {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in channels.items()}) as exr:
            exr.write(str(tmp))
    return path


def _test_kill_hook(target: Path) -> None:
    """SIGKILL this process on the first attempt at the item named by :data:`TEST_KILL_ENV`."""
    named = os.environ.get(TEST_KILL_ENV)
    if not named or Path(named).resolve() != target.resolve():
        return
    marker = Path(f"{named}.killed")
    try:
        fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        return
    os.write(fd, f"killed pid {os.getpid()}\n".encode())
    os.fsync(fd)
    os.close(fd)
    os.kill(os.getpid(), signal.SIGKILL)


def _write_item(config: SceneConfig, target: Path, task: Mapping[str, Any]) -> dict:
    """Render and write one item folder atomically; returns its meta.json content."""
    from .isp import develop
    from .isp.encode import write_outputs
    from .job import result_meta, simulate, write_json
    from .optics import ThinLens
    from .raw import write_dng
    from .render import render
    from .sensor import expose
    from .spectral_exr import write_depth_exr, write_spectral_exr

    outputs = set(task["outputs"])
    started = time.perf_counter()
    with staged_directory(target, force=True) as stage:
        sim = simulate(config)
        radiance, raw, developed = sim.radiance, sim.raw, sim.developed
        timings = dict(sim.timings_s)
        _test_kill_hook(target)
        exposure_s = float(raw.meta["exposure_s"])

        t0 = time.perf_counter()
        lens = ThinLens.from_config(config.lens, config.sensor)
        written: list[Path] = []
        if "radiance" in outputs:
            written.append(write_spectral_exr(radiance, stage / "radiance.exr"))
        if "depth" in outputs:
            written.append(write_depth_exr(radiance.depth_m, stage / "depth.exr"))
        if "raw" in outputs:
            written.append(write_dng(raw, stage / "raw.dng"))
        if "image" in outputs:
            written += write_outputs(developed, stage, config.isp.outputs, stem="image",
                                     quality=config.isp.jpeg_quality)
        if "defocus" in outputs:
            written.append(_write_exr({"CoC": defocus_map_px(lens, radiance.depth_m)}, stage / "defocus.exr",
                                      {"spectral_cam_units": "signed CoC diameter, pixels (+ behind focus)"}))
        channels = ("Y",) if config.sensor.cfa == "none" else ("R", "G", "B")
        measure = (task.get("measure_blur", False) and "all_in_focus" in outputs
                   and config.scene.preset in BLUR_PRESETS and not config.scene.mitsuba_xml)
        clean = None
        if "clean_rgb" in outputs or measure:
            clean = clean_camera_rgb(radiance, config, exposure_s=exposure_s)
        if "clean_rgb" in outputs:
            written.append(_write_exr({name: clean[..., i] for i, name in enumerate(channels)},
                                      stage / "clean_rgb.exr",
                                      {"spectral_cam_units": "linear camera RGB, 1 = white level - black level"}))
        timings["write"] = time.perf_counter() - t0

        aif_meta = None
        blur = None
        if "all_in_focus" in outputs:
            t0 = time.perf_counter()
            aif_config = config.replace(**{"lens.model": "pinhole", "exposure.time_s": exposure_s})
            aif_radiance = render(aif_config, with_depth=False)
            aif_raw = expose(aif_radiance, aif_config)
            aif_developed = develop(aif_raw, aif_config.isp)
            aif_files = write_outputs(aif_developed, stage, aif_config.isp.outputs, stem="all_in_focus",
                                      quality=aif_config.isp.jpeg_quality)
            written += aif_files
            timings["all_in_focus"] = time.perf_counter() - t0
            aif_meta = {"lens_model": "pinhole", "exposure_s": exposure_s,
                        "files": sorted(p.name for p in aif_files),
                        "render": {k: v for k, v in aif_radiance.meta.items()
                                   if k not in ("optics", "timings_s", "model_decisions")},
                        "model_decisions": aif_radiance.meta.get("model_decisions", {})}
            if measure:
                t0 = time.perf_counter()
                sharp = clean_camera_rgb(aif_radiance, aif_config, exposure_s=exposure_s).sum(axis=-1)
                blur = measure_scene_blur(config, radiance.depth_m, sharp, clean.sum(axis=-1))
                timings["blur_measurement"] = time.perf_counter() - t0
        timings["total"] = time.perf_counter() - started

        meta = result_meta(config, sim, written, timings, dataset={
            "index": task["index"], "id": task["id"], "seed": task["seed"], "spec_hash": task["spec_hash"],
            "params": task["params"], "outputs": list(task["outputs"])})
        meta.update({
            "defocus": {"file": "defocus.exr", "channel": "CoC", "units": "px",
                        "formula": "A*f*(z - z_f)/(z*(z_f - f))/pixel_pitch, A = f/N",
                        "sign": "+ behind the focus plane, - in front"} if "defocus" in outputs else None,
            "clean_rgb": {"file": "clean_rgb.exr", "channels": list(channels),
                          "units": "linear camera RGB; 1 = white level - black level",
                          "electrons_per_unit": (2 ** config.sensor.bit_depth - 1 - config.sensor.black_level_dn)
                          / raw.meta["K_dn_per_e"],
                          "excludes": "shot, read, dark and fixed-pattern noise, dark signal, clipping, "
                                      "quantisation"} if "clean_rgb" in outputs else None,
            "all_in_focus": aif_meta,
            "blur": blur,
        })
        write_json(meta, stage / "meta.json")
    return meta


def _set_render_threads(threads: int | None) -> None:
    if threads:
        import drjit

        if drjit.thread_count() != threads:
            drjit.set_thread_count(int(threads))


def item_task(spec: DatasetSpec, plan: ItemPlan, output: str | Path, *,
              render_threads: int | None = None) -> dict:
    """The task :func:`render_item` takes for a planned item (plain data: it travels to the
    worker by pickling).

    Parameters
    ----------
    spec
        The dataset spec (its hash and outputs go into the item's meta.json).
    plan
        From :meth:`DatasetSpec.plan_item`; must have a scene (``plan.error`` None).
    output
        The dataset folder; the item goes to ``<output>/items/<id>``.
    render_threads
        Mitsuba threads on the worker (None: Mitsuba's default, all cores).
    """
    if plan.scene is None:
        raise ConfigError(f"item {plan.id} has no valid scene: {plan.error}")
    return {"index": plan.index, "id": plan.id, "seed": plan.seed, "params": plan.params, "scene": plan.scene,
            "path": str(Path(output).resolve() / "items" / plan.id), "outputs": list(spec.outputs),
            "spec_hash": spec.hash, "render_threads": render_threads, "measure_blur": bool(spec.sweeps)}


def render_item(task: Mapping[str, Any]) -> dict:
    """Render one dataset item on a worker; never raises for a bad item.

    Parameters
    ----------
    task
        ``{"index", "id", "seed", "params", "scene" (resolved scene dict), "path" (item
        folder), "outputs", "spec_hash", "render_threads", "measure_blur"}`` as :func:`generate_dataset`
        builds it.

    Returns
    -------
    dict
        A manifest row: ``status`` "done" with ``files``, or "failed" with ``error`` (the
        exception and message) and ``traceback``; ``seconds`` on this worker.

    References
    ----------
    .. [1] Python ``concurrent.futures``: a task's return value travels back to the driver;
       catching here keeps one poison item from failing the whole run.
    """
    started = time.perf_counter()
    row = {"index": task["index"], "id": task["id"], "seed": task["seed"], "params": task["params"]}
    try:
        _set_render_threads(task.get("render_threads"))
        config = scene_from_dict(task["scene"])
        meta = _write_item(config, Path(task["path"]), task)
        row.update(status="done", files=meta["files"], error=None, exposure_s=meta["sensor"]["exposure_s"])
    except Exception as exc:  # a poison item: record it, never take the run down
        row.update(status="failed", files=[], error=f"{type(exc).__name__}: {exc}",
                   traceback=traceback.format_exc(limit=8))
    row["seconds"] = time.perf_counter() - started
    row["worker_pid"] = os.getpid()
    return row


# ----------------------------------------------------------------------------- executors
class _InlineExecutor(cf.Executor):
    """Runs each task at submission, in this process (``--scheduler inline``)."""

    _max_workers = 1

    def submit(self, fn, /, *args, **kwargs):
        future: cf.Future = cf.Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # noqa: BLE001 - handed to the future like any executor
            future.set_exception(exc)
        return future


def _usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


@contextlib.contextmanager
def local_cluster(workers: int | None = None, **worker_kwargs) -> Iterator[Any]:
    """A Dask ``LocalCluster`` for dataset items, yielding its ``Client``.

    Worker processes are spawned (not forked: Mitsuba's and drjit's thread pools do not
    survive a fork), one Dask thread each so each worker renders one item at a time, and
    the scheduler hands out one task per thread (``worker-saturation`` 1.0) and reports a
    worker's death at once (``allowed_failures`` 0), so :func:`generate_dataset` resubmits
    exactly the item that was running. The workers' numerical libraries get the worker's
    share of the cores (``OMP_NUM_THREADS`` …), and Dask's default
    ``MALLOC_TRIM_THRESHOLD_`` is not set: it turns off glibc's dynamic mmap threshold, so
    every large NumPy temporary is mapped and faulted in anew (measured: the per-band
    diffraction FFTs ran 3× slower).

    Parameters
    ----------
    workers
        Worker processes (default :func:`default_workers`: one per usable core).
    **worker_kwargs
        Passed to ``LocalCluster`` (e.g. ``env={...}``, ``memory_limit="8GB"``).

    References
    ----------
    .. [1] Dask.distributed documentation: LocalCluster, Nanny, scheduler configuration
       (``distributed.scheduler.worker-saturation``, ``allowed-failures``,
       ``distributed.nanny.pre-spawn-environ``).
    .. [2] glibc manual, §3.2.3.7 "Memory Allocation Tunables" (setting M_TRIM_THRESHOLD
       disables the dynamic mmap threshold).
    """
    try:
        import dask
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise ConfigError("the Dask executor needs dask.distributed: pip install 'spectral_cam[dask]' "
                          "(or run with --scheduler inline)") from None
    workers = default_workers() if workers is None else workers
    if not isinstance(workers, int) or workers < 1:
        raise ConfigError(f"--workers {workers!r}: must be a whole number >= 1")
    share = str(max(1, _usable_cores() // workers))
    settings = {"distributed.worker.multiprocessing-method": "spawn",
                "distributed.scheduler.worker-saturation": 1.0,
                "distributed.nanny.pre-spawn-environ": {"MALLOC_TRIM_THRESHOLD_": None, "OMP_NUM_THREADS": share,
                                                        "MKL_NUM_THREADS": share, "OPENBLAS_NUM_THREADS": share}}
    with dask.config.set(settings):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               scheduler_kwargs={"allowed_failures": 0, "dashboard": False},
                               **worker_kwargs)
        try:
            client = Client(cluster)
        except BaseException:  # never leave spawned workers behind
            cluster.close()
            raise
    try:
        yield client
    finally:
        client.close()
        cluster.close()


def default_workers() -> int:
    """LocalCluster workers by default: one per usable core, each rendering with one Mitsuba
    thread. Measured on 2 cores at 256 × 256 px / 16 spp, two single-threaded workers
    rendered 115 items/min against 90 for one worker with two threads (the sensor, ISP and
    file stages run in parallel too); with large frames, fewer workers bound the memory
    (``--workers``)."""
    return max(1, _usable_cores())


# ----------------------------------------------------------------------------- progress
class ProgressBar:
    """Items done of a total, failures, rate and ETA, on one stderr line.

    Redrawn in place on a terminal; elsewhere (logs, CI) a line every ``every_s`` seconds
    and at the end. The rate counts items processed by workers in this run (not resumed
    items, not items whose values were rejected before rendering).
    """

    def __init__(self, total: int, *, resumed: int = 0, rejected: int = 0, enabled: bool = True,
                 stream=None, every_s: float = 10.0, width: int = 28):
        self.total, self.resumed, self.rejected, self.enabled = total, resumed, rejected, enabled
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.every_s, self.width = every_s, width
        self.started = time.perf_counter()
        self.done = self.failed = 0
        self._last_print = -math.inf
        self._last_line: str | None = None

    @property
    def finished(self) -> int:
        return self.resumed + self.rejected + self.done + self.failed

    def line(self) -> str:
        """The status line: bar, counts, items per minute and ETA."""
        elapsed = time.perf_counter() - self.started
        processed = self.done + self.failed
        rate = processed / elapsed * 60.0 if elapsed > 0 and processed else 0.0
        remaining = self.total - self.finished
        filled = int(round(self.width * self.finished / self.total)) if self.total else self.width
        parts = [f"dataset [{'#' * filled}{'-' * (self.width - filled)}] {self.finished}/{self.total} items"]
        if self.resumed:
            parts.append(f"{self.resumed} resumed")
        if self.failed + self.rejected:
            parts.append(f"{self.failed + self.rejected} failed")
        if rate:
            parts.append(f"{rate:.1f} items/min")
        if remaining:
            parts.append(f"ETA {_duration(remaining / (rate / 60.0))}" if rate else "ETA ?")
        else:
            parts.append(f"{_duration(elapsed)}")
        return " · ".join(parts)

    def update(self, *, done: int = 0, failed: int = 0) -> None:
        """Count finished items and redraw (on a terminal) or log (every ``every_s``)."""
        self.done += done
        self.failed += failed
        if not self.enabled:
            return
        now = time.perf_counter()
        if self.tty:
            print("\r" + self.line(), end="", file=self.stream, flush=True)
        elif now - self._last_print >= self.every_s:
            self._print(self.line())
            self._last_print = now

    def close(self) -> None:
        """Print the final line (ending the redrawn one on a terminal)."""
        if not self.enabled:
            return
        if self.tty:
            print("\r" + self.line(), file=self.stream, flush=True)
        else:
            self._print(self.line())

    def _print(self, line: str) -> None:
        if line != self._last_line:
            print(line, file=self.stream, flush=True)
            self._last_line = line


def _duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    seconds = int(round(seconds))
    if seconds < 60:
        return f"{seconds} s"
    if seconds < 3600:
        return f"{seconds // 60} min {seconds % 60:02d} s"
    return f"{seconds // 3600} h {seconds % 3600 // 60:02d} min"


# ----------------------------------------------------------------------------- the run
@dataclass
class DatasetSummary:
    """What a :func:`generate_dataset` run did.

    Attributes
    ----------
    output
        The dataset folder.
    items
        Items in the dataset.
    rendered, resumed, failed
        Items rendered in this run, found complete and skipped, and failed.
    retried
        Resubmissions after a worker died.
    seconds
        Wall time of the run.
    manifest
        The manifest file.
    errors
        ``{item id: error}`` of the failed items.
    """

    output: Path
    items: int
    rendered: int = 0
    resumed: int = 0
    failed: int = 0
    retried: int = 0
    seconds: float = 0.0
    manifest: Path | None = None
    errors: dict = field(default_factory=dict)

    @property
    def items_per_minute(self) -> float:
        return 60.0 * self.rendered / self.seconds if self.seconds > 0 else 0.0


def _read_meta(item_dir: Path) -> dict | None:
    try:
        return json.loads((item_dir / "meta.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _finished(item_dir: Path, spec_hash: str, outputs: Sequence[str], plan) -> dict | None:
    """The item's meta when its folder is complete for this spec, this item's planned seed
    and parameters (a sweep re-plans items when ``-n`` changes), and these outputs."""
    meta = _read_meta(item_dir)
    if not meta or not isinstance(meta.get("dataset"), dict):
        return None
    if meta["dataset"].get("spec_hash") != spec_hash or not set(outputs) <= set(meta["dataset"].get("outputs", [])):
        return None
    if meta["dataset"].get("seed") != plan.seed or meta["dataset"].get("params") != _jsonable(plan.params):
        return None
    if not all((item_dir / name).is_file() for name in meta.get("files", [])):
        return None
    return meta


def _remove_partials(items_dir: Path, item_id: str | None = None) -> None:
    """Remove staging leftovers (``.<id>.partial-*``, ``.<id>.old-*``) of dead attempts."""
    if not items_dir.is_dir():
        return
    pattern = re.compile(rf"^\.{re.escape(item_id) if item_id else '[0-9]+'}\.(partial|old)-")
    for entry in items_dir.iterdir():
        if pattern.match(entry.name):
            shutil.rmtree(entry, ignore_errors=True) if entry.is_dir() else entry.unlink(missing_ok=True)


@contextlib.contextmanager
def _lock(output: Path) -> Iterator[None]:
    import fcntl

    output.mkdir(parents=True, exist_ok=True)
    handle = open(output / ".dataset.lock", "w")
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise ConfigError(f"another spectral-cam dataset run is writing {output}; wait for it or "
                              f"choose another -o") from None
        yield
    finally:
        handle.close()


def _write_manifest(path: Path, rows: Mapping[int, dict]) -> None:
    keep = ("index", "id", "status", "resumed", "seed", "params", "files", "error", "attempts", "seconds",
            "exposure_s", "path")
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as handle:
            for index in sorted(rows):
                row = {k: rows[index].get(k) for k in keep}
                handle.write(json.dumps(_jsonable(row), ensure_ascii=False, default=str) + "\n")


def generate_dataset(
    spec: DatasetSpec,
    output: str | Path,
    *,
    n: int | None = None,
    executor: cf.Executor | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    retries: int = 2,
    force: bool = False,
    progress: bool = True,
    render_threads: int | None = None,
) -> DatasetSummary:
    """Render a dataset: plan every item, skip finished ones, run the rest, write the manifest.

    Parameters
    ----------
    spec
        From :func:`load_spec`.
    output
        Dataset folder (created; resumed when it holds a dataset of the same spec).
    n
        Items (per grid point when the spec sweeps); default the spec's ``[dataset] n``.
    executor
        Any ``concurrent.futures.Executor`` (e.g. ``dask.distributed.Client.get_executor(
        pure=False)``, a ``ProcessPoolExecutor`` with the spawn context); not shut down here.
    scheduler
        Without ``executor``: a Dask scheduler address (``tcp://host:8786``), ``"inline"``
        (this process, one item after another), or None for a new ``LocalCluster``.
    workers
        LocalCluster worker processes (default :func:`default_workers`).
    retries
        Resubmissions of an item whose worker died (any exception from the executor
        itself; exceptions inside the item are recorded, not retried).
    force
        Render every item again, and accept a folder made from another spec.
    progress
        Show the progress bar on stderr.
    render_threads
        Mitsuba threads per item on the workers; default: the usable cores over the
        workers for a new LocalCluster, else Mitsuba's own default (every core).

    Returns
    -------
    DatasetSummary

    Raises
    ------
    ConfigError
        For an invalid count, a folder holding another spec's dataset (without ``force``),
        or a folder another run is writing.

    References
    ----------
    .. [1] Python ``concurrent.futures`` (PEP 3148); Dask ``Client.get_executor``.
    """
    started = time.perf_counter()
    output = Path(output).resolve()
    total = spec.item_count(n)
    per_point = total // spec.grid_size
    if not isinstance(retries, int) or retries < 0:
        raise ConfigError(f"--retries {retries!r}: must be a whole number >= 0")
    if render_threads is not None and (not isinstance(render_threads, int) or render_threads < 1):
        raise ConfigError(f"render_threads {render_threads!r}: must be a whole number >= 1 (or None)")
    items_dir = output / "items"
    summary = DatasetSummary(output=output, items=total)
    with _lock(output):
        info_path = output / "dataset.json"
        previous = _read_json(info_path)
        if previous and previous.get("spec_hash") != spec.hash and not force:
            raise ConfigError(
                f"{output} holds a dataset of another spec (hash {str(previous.get('spec_hash'))[:12]}, this spec "
                f"{spec.hash[:12]}); choose a new -o, or pass --force to render every item again")
        _write_json(info_path, {"spec_hash": spec.hash, "items": total, "per_grid_point": per_point,
                                "spec": spec.to_dict()})
        _remove_partials(items_dir)
        if force and items_dir.is_dir():  # items of an earlier, larger run are not this dataset's
            for stale in items_dir.iterdir():
                if stale.is_dir() and stale.name.isdigit() and int(stale.name) >= total:
                    shutil.rmtree(stale, ignore_errors=True)

        rows: dict[int, dict] = {}
        tasks = []
        for index in range(total):
            plan = spec.plan_item(index, per_point)
            item_dir = items_dir / plan.id
            base = {"index": index, "id": plan.id, "seed": plan.seed, "params": plan.params,
                    "path": f"items/{plan.id}", "attempts": 0}
            if plan.scene is None:
                rows[index] = {**base, "status": "failed", "resumed": False, "files": [], "error": plan.error}
                continue
            meta = None if force else _finished(item_dir, spec.hash, spec.outputs, plan)
            if meta is not None:
                rows[index] = {**base, "status": "done", "resumed": True,
                               "files": [f"items/{plan.id}/{name}" for name in meta["files"]],
                               "error": None, "exposure_s": meta.get("sensor", {}).get("exposure_s"),
                               "seconds": meta.get("timings_s", {}).get("total")}
                continue
            tasks.append(item_task(spec, plan, output))
            # until a worker reports, the manifest (rewritten every MANIFEST_EVERY_S) says pending
            rows[index] = {**base, "status": "pending", "resumed": False, "files": [], "error": None}
        summary.resumed = sum(1 for r in rows.values() if r.get("resumed"))
        bar = ProgressBar(total, resumed=summary.resumed, enabled=progress,
                          rejected=sum(1 for r in rows.values() if r["status"] == "failed"))
        bar.update()
        manifest = output / "manifest.jsonl"
        try:
            if tasks:
                with _executor(executor, scheduler, workers) as (pool, window, threads):
                    for task in tasks:
                        task["render_threads"] = render_threads or threads
                    _run_tasks(pool, tasks, rows, items_dir, window=window, retries=retries,
                               bar=bar, summary=summary, manifest=manifest)
        finally:
            _write_manifest(manifest, rows)
            summary.manifest = manifest
        bar.close()
        summary.failed = sum(1 for r in rows.values() if r["status"] == "failed")
        summary.errors = {r["id"]: r["error"] for r in sorted(rows.values(), key=lambda r: r["index"])
                          if r["status"] == "failed"}
        _write_summaries(spec, output, rows)
    summary.seconds = time.perf_counter() - started
    return summary


def _read_json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _write_json(path: Path, data: dict) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(_jsonable(data), indent=2, ensure_ascii=False) + "\n", encoding="utf-8")


@contextlib.contextmanager
def _executor(executor, scheduler, workers) -> Iterator[tuple[cf.Executor, int, int | None]]:
    """(executor, tasks kept in flight, Mitsuba threads per item) for the run."""
    if executor is not None:
        window = 2 * max(1, int(getattr(executor, "_max_workers", 0) or _dask_threads(executor) or 4))
        yield executor, window, None
        return
    if scheduler == "inline":
        yield _InlineExecutor(), 1, None
        return
    if scheduler:
        try:
            from dask.distributed import Client
        except ImportError:
            raise ConfigError("--scheduler needs dask.distributed: pip install 'spectral_cam[dask]'") from None
        try:
            client = Client(scheduler, timeout="30s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise ConfigError(f"cannot reach the Dask scheduler at {scheduler!r} ({exc}); give its address "
                              f"as tcp://HOST:PORT, or 'inline', or leave --scheduler out for a local "
                              f"cluster") from None
        try:
            yield client.get_executor(pure=False), 2 * max(1, sum(client.nthreads().values())), None
        finally:
            client.close()
        return
    workers = default_workers() if workers is None else workers
    with local_cluster(workers) as client:
        threads = max(1, _usable_cores() // workers)
        yield client.get_executor(pure=False), 2 * workers, threads


def _dask_threads(executor) -> int:
    client = getattr(executor, "_client", None)
    try:
        return sum(client.nthreads().values()) if client is not None else 0
    except Exception:  # a closed client: fall back to the default window
        return 0


def _run_tasks(pool, tasks, rows, items_dir, *, window, retries, bar, summary, manifest) -> None:
    pending = collections.deque(tasks)
    attempts: collections.Counter = collections.Counter()
    in_flight: dict[cf.Future, dict] = {}
    last_manifest = time.perf_counter()
    try:
        while pending or in_flight:
            while pending and len(in_flight) < window:
                task = pending.popleft()
                attempts[task["index"]] += 1
                _remove_partials(items_dir, task["id"])
                in_flight[pool.submit(render_item, task)] = task
            done, _ = cf.wait(list(in_flight), timeout=1.0, return_when=cf.FIRST_COMPLETED)
            for future in done:
                task = in_flight.pop(future)
                index = task["index"]
                try:
                    row = future.result()
                except Exception as exc:  # the worker died (KilledWorker, BrokenProcessPool, ...)
                    if attempts[index] <= retries:
                        summary.retried += 1
                        pending.appendleft(task)
                        continue
                    row = {"status": "failed", "files": [],
                           "error": f"worker lost {attempts[index]} times; last: {type(exc).__name__}: {exc}"}
                row = {**row, "index": index, "id": task["id"], "seed": task["seed"], "params": task["params"],
                       "path": f"items/{task['id']}", "resumed": False, "attempts": attempts[index]}
                if row["status"] == "done":
                    row["files"] = [f"items/{task['id']}/{name}" for name in row["files"]]
                    summary.rendered += 1
                rows[index] = row
                bar.update(done=int(row["status"] == "done"), failed=int(row["status"] != "done"))
            if not done:
                bar.update()
            if time.perf_counter() - last_manifest > MANIFEST_EVERY_S:
                _write_manifest(manifest, rows)
                last_manifest = time.perf_counter()
    finally:
        for future in in_flight:
            future.cancel()


# ----------------------------------------------------------------------------- sheets, charts
def _format_value(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.0f}" if abs(value) >= 100 else f"{value:.3g}"
    if isinstance(value, list):
        return "[" + ", ".join(_format_value(v) for v in value) + "]"
    return str(value)


def _label(params: Mapping[str, Any], keys: Sequence[str], *, per_line: int = 1) -> str:
    """``key=value`` of the given parameters (short key names), ``per_line`` to a line."""
    parts = [f"{key.split('.', 1)[1]}={_format_value(params.get(key))}" for key in keys]
    return "\n".join("  ".join(parts[i:i + per_line]) for i in range(0, len(parts), per_line))


def _thumbnail(path: Path) -> np.ndarray:
    """An 8-bit RGB array of a developed image (PNG 8/16-bit, JPEG, TIFF)."""
    import cv2

    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ConfigError(f"{path} is not a readable image")
    if image.dtype == np.uint16:
        image = (image // 257).astype(np.uint8)
    if image.ndim == 2:
        return np.repeat(image[..., None], 3, axis=-1)
    return np.ascontiguousarray(image[..., 2::-1])


def write_contact_sheet(output: str | Path, path: str | Path | None = None, *,
                        columns: int | None = None, limit: int = CONTACT_SHEET_MAX,
                        keys: Sequence[str] | None = None) -> Path | None:
    """A PNG grid of the items' developed images, labelled with their swept/sampled values.

    Parameters
    ----------
    output
        The dataset folder (reads manifest.jsonl and dataset.json).
    path
        The PNG (default ``<output>/contact_sheet.png``).
    columns
        Grid columns (default: the last sweep axis' length for a two-axis sweep, else up
        to 6).
    limit
        Items shown at most (the first ones).
    keys
        Parameters in each label (default: the sweep keys, else the sampled keys; at most
        six, two to a line).

    Returns
    -------
    pathlib.Path or None
        The PNG, or None when the items have no developed images.

    References
    ----------
    .. [1] Matplotlib ``Figure.subplots`` and ``imshow`` (Agg backend).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    output = Path(output)
    path = Path(path) if path else output / "contact_sheet.png"
    rows = _manifest_rows(output)[:limit]
    info = _read_json(output / "dataset.json") or {}
    sweeps = info.get("spec", {}).get("sweeps", [])
    if keys is None:
        keys = [s["key"] for s in sweeps] or sorted(info.get("spec", {}).get("distributions", {}))
    keys = list(keys)[:6]
    images = []
    for row in rows:
        names = {Path(f).name: f for f in row.get("files") or []}
        found = [names[n] for n in ("image.png", "image.jpg", "image.16bit.png", "image.tif") if n in names]
        images.append(output / found[0] if found else None)
    if not any(images):
        return None
    if columns is None:
        two_axes = len(sweeps) == 2 and info.get("per_grid_point") == 1
        columns = len(sweeps[-1]["values"]) if two_axes else min(6, len(rows))
    columns = max(1, min(columns, len(rows)))
    lines = max(1, (len(rows) + columns - 1) // columns)
    sample = _thumbnail(next(p for p in images if p))
    aspect = sample.shape[0] / sample.shape[1]
    label_lines = (len(keys) + 1) // 2
    fig, axes = plt.subplots(lines, columns, squeeze=False,
                             figsize=(2.4 * columns, (2.4 * aspect + 0.15 * (label_lines + 1) + 0.1) * lines))
    for ax in axes.ravel():
        ax.axis("off")
    for ax, row, image in zip(axes.ravel(), rows, images):
        if image is not None:
            ax.imshow(_thumbnail(image), interpolation="nearest")
        else:
            ax.text(0.5, 0.5, "failed" if row.get("status") == "failed" else "missing", ha="center",
                    va="center", color="crimson", transform=ax.transAxes)
        title = f"#{row['id']}"
        if keys:
            title += "\n" + _label(row.get("params") or {}, keys, per_line=2)
        ax.set_title(title, fontsize=6.5)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path


def write_blur_chart(output: str | Path, *, png: str | Path | None = None,
                     csv_path: str | Path | None = None) -> Path | None:
    """Measured blur against depth beside the thin-lens prediction, one series per item.

    Reads each finished item's ``meta.json`` ``blur`` rows (from :func:`measure_scene_blur`)
    and draws the predicted |CoC|(z) curve of its lens with the measured diameters as markers;
    writes the numbers as CSV too.

    Parameters
    ----------
    output
        The dataset folder.
    png, csv_path
        Outputs (default ``<output>/blur_vs_depth.png`` and ``.csv``).

    Returns
    -------
    pathlib.Path or None
        The PNG, or None when no item measured its blur.

    References
    ----------
    .. [1] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10.
    """
    import csv

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    from .optics import ThinLens
    from .scene import scene_from_dict as _config

    output = Path(output)
    png = Path(png) if png else output / "blur_vs_depth.png"
    csv_path = Path(csv_path) if csv_path else output / "blur_vs_depth.csv"
    info = _read_json(output / "dataset.json") or {}
    keys = [s["key"] for s in info.get("spec", {}).get("sweeps", [])]
    series = []
    for row in _manifest_rows(output):
        if row.get("status") != "done":
            continue
        meta = _read_meta(output / row["path"])
        if not meta or not meta.get("blur"):
            continue
        series.append((row, meta))
    if not series:
        return None
    table = []
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.9, len(series)))
    for (row, meta), colour in zip(series, colours):
        config = _config(meta["config"])
        lens = ThinLens.from_config(config.lens, config.sensor)
        depths = [b["depth_m"] for b in meta["blur"]]
        z = np.geomspace(min(depths) * 0.8, max(depths) * 1.25, 200)
        label = _label(row.get("params") or {}, keys).replace("\n", ", ") or f"#{row['id']}"
        ax.plot(z, lens.coc_diameter_px(z), color=colour, lw=1.2, label=f"{label} (thin lens)")
        measured = [(b["depth_m"], b["measured_coc_px"]) for b in meta["blur"] if b["measured_coc_px"] is not None]
        if measured:
            ax.plot(*zip(*measured), "o", color=colour, ms=5, mfc="none")
        for b in meta["blur"]:
            table.append({"id": row["id"], **{k: (row.get("params") or {}).get(k) for k in keys},
                          "depth_m": b["depth_m"], "predicted_coc_px": b["predicted_coc_px"],
                          "measured_coc_px": b["measured_coc_px"], "pixels": b["pixels"]})
    ax.plot([], [], "o", color="grey", mfc="none", label="measured (rendered image vs. all-in-focus)")
    ax.set_xscale("log")
    ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax.xaxis.set_minor_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax.tick_params(axis="x", which="minor", labelsize=7)
    ax.set_xlabel("depth z (m)")
    ax.set_ylabel("blur diameter |CoC| (pixels)")
    ax.set_title("Measured defocus blur vs. thin-lens prediction")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6.5, ncol=2 if len(series) > 6 else 1)
    fig.tight_layout()
    with atomic_path(png) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
    with atomic_path(csv_path) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(table[0]))
            writer.writeheader()
            writer.writerows(table)
    return png


def _manifest_rows(output: Path) -> list[dict]:
    path = output / "manifest.jsonl"
    if not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]


def _write_summaries(spec: DatasetSpec, output: Path, rows: Mapping[int, dict]) -> None:
    """Contact sheet for every dataset; blur chart for sweeps of the blur presets."""
    if not any(r["status"] == "done" for r in rows.values()):
        return
    write_contact_sheet(output)
    if spec.sweeps:
        write_blur_chart(output)


# ----------------------------------------------------------------------------- CLI
def configure_parser(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``spectral-cam dataset``."""
    parser.add_argument("spec", help="dataset spec (.toml): a scene file whose values may be distributions, "
                                     "plus a [dataset] table")
    parser.add_argument("-n", type=int, default=None, metavar="N",
                        help="items (per grid point with --sweep); default: the spec's [dataset] n, or 1 per "
                             "grid point")
    parser.add_argument("-o", "--output", required=True, help="dataset folder (resumed when it exists)")
    parser.add_argument("--sweep", action="append", metavar="SECTION.KEY=START:STOP:COUNT[:log]",
                        help="grid axis, e.g. --sweep lens.focus_distance_m=0.5:5:10 or "
                             "--sweep 'lens.f_number=[1.4, 2.8, 5.6]' (repeatable: their product)")
    parser.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE",
                        help="fix a scene key for every item (repeatable)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="Dask scheduler address (tcp://HOST:8786), or 'inline' to render in this "
                             "process; default: a new local Dask cluster")
    parser.add_argument("--workers", type=int, default=None, metavar="K",
                        help=f"local cluster worker processes, one render each (default {default_workers()} "
                             f"here: one per core; fewer bound the memory for large frames)")
    parser.add_argument("--retries", type=int, default=2,
                        help="resubmissions of an item whose worker died (default 2)")
    parser.add_argument("--force", action="store_true",
                        help="render every item again (also when the folder holds another spec's dataset)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """``spectral-cam dataset``: exit 0 when every item is done, 1 when some failed (they are
    listed in the manifest; finished items are kept)."""
    if args.scheduler and args.workers is not None:
        raise ConfigError("--workers sizes the local cluster; with --scheduler the cluster decides")
    spec = load_spec(args.spec, sweeps=args.sweep or [], overrides=args.set or [])
    summary = generate_dataset(spec, args.output, n=args.n, scheduler=args.scheduler, workers=args.workers,
                               retries=args.retries, force=args.force, progress=not args.quiet)
    if not args.quiet:
        print(f"dataset {summary.output}: {summary.items} items, {summary.rendered} rendered, "
              f"{summary.resumed} resumed, {summary.failed} failed in {_duration(summary.seconds)} "
              f"({summary.items_per_minute:.1f} items/min); manifest {summary.manifest}", file=sys.stderr)
        for item_id, error in list(summary.errors.items())[:5]:
            print(f"  failed {item_id}: {error}", file=sys.stderr)
        if len(summary.errors) > 5:
            print(f"  ... {len(summary.errors) - 5} more failures in the manifest", file=sys.stderr)
    return 0 if summary.failed == 0 else 1

