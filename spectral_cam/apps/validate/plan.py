"""Validation plans: a TOML file → a checked, frozen :class:`Plan`.

A plan names a matrix of illuminants × cameras × exposures × reflectance sets and the
pipelines to evaluate on it::

    [validate]
    illuminants = ["D65", "A"]            # colour-science names, "blackbody:<K>", CSV paths
    cameras = ["nikon_d850", "sony_ilce_7m3"]
    reflectance_sets = ["colorchecker", "cie2017"]   # or CSV files (wavelength_nm, one column per patch)
    [validate.thresholds]                 # a cell passes when all of these hold
    mean_delta_e = 3.0
    [[exposure]]                          # one table per exposure (default: auto, ISO of [sensor])
    iso = 100
    [[pipeline]]                          # a type of spectral_cam.apps.validate.pipelines.PIPELINES
    name = "ours"
    type = "ours"
    isp = { demosaic = "menon2007" }
    [sensor]                              # any scene-file [sensor]/[lens]/[scene]/[render] key
    read_noise_e = 2.5

Every key is checked here, before anything runs: unknown sections, keys and names raise a
:class:`~spectral_cam.errors.ConfigError` that lists the valid ones, and every cell's scene
configuration is validated (docs/design.md, "Scene file" and "Registries").
"""

from __future__ import annotations

import copy
import dataclasses
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

from ...radiance_targets import Chart, ReflectanceSet, reflectance_set
from ...errors import ConfigError
from .pipelines import PIPELINES

__all__ = ["Plan", "Thresholds", "ExposureSpec", "load_plan", "plan_from_dict", "check_keys",
           "CHART_SOURCES", "SWATCH_MODES"]

#: Chart sources: analytic radiance blocks, or a Mitsuba render of the ColorChecker preset.
CHART_SOURCES = ("synthetic", "render")
#: Report swatch selection.
SWATCH_MODES = ("all", "failing", "none")
#: Keys of ``[validate]``.
VALIDATE_KEYS = ("illuminants", "cameras", "reflectance_sets", "chart", "bands", "patch_px", "gap_px",
                 "swatches", "thresholds", "seeds", "compare")
#: Keys of an ``[[exposure]]`` table.
EXPOSURE_KEYS = ("name", "time_s", "iso", "auto_fraction", "metering")
#: Scene-file tables a plan may hold (shared by every cell).
SCENE_SECTIONS = ("scene", "lens", "sensor", "render", "illuminant")
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]*$")


@dataclass(frozen=True)
class Thresholds:
    """Pass criteria of a cell (all must hold).

    Attributes
    ----------
    mean_delta_e, p95_delta_e, max_delta_e : float
        Largest allowed mean, 95th-percentile and maximum ΔE2000 over the set's patches.
    wb_angular_error_deg : float
        Largest allowed angle (degrees) between the pipeline's and the ground truth's white
        reference in linear sRGB.
    """

    mean_delta_e: float = 3.0
    p95_delta_e: float = 6.0
    max_delta_e: float = 10.0
    wb_angular_error_deg: float = 3.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
                raise ConfigError(f"validate.thresholds.{f.name} = {value!r}: must be a number > 0 (inf disables it)")
            object.__setattr__(self, f.name, float(value))

    def failures(self, stats: Mapping[str, float]) -> list[str]:
        """Names of the criteria a cell's statistics break."""
        checks = (("mean_delta_e", "delta_e_mean"), ("p95_delta_e", "delta_e_p95"),
                  ("max_delta_e", "delta_e_max"), ("wb_angular_error_deg", "wb_angular_error_deg"))
        return [f"{stat} {stats[stat]:.3g} > {getattr(self, limit):g}" for limit, stat in checks
                if not stats[stat] <= getattr(self, limit)]


@dataclass(frozen=True)
class ExposureSpec:
    """One exposure setting of the plan.

    Attributes
    ----------
    name : str
        Label in the report (default from the settings, e.g. ``"auto0.8_iso100"``).
    time_s : float or "auto"
        Exposure time, s; ``"auto"`` puts the brightest patch at ``auto_fraction`` of
        saturation.
    iso : float
        ISO speed (gain K = K_base·iso/base_iso).
    auto_fraction : float
        Fraction of saturation for auto exposure.
    metering : str
        ``exposure.metering``: ``"etr"`` (default: a colour-measurement shot exposed for the
        brightest patch) or a camera meter mode (``average``, ...).
    """

    name: str
    time_s: float | str = "auto"
    iso: float = 100.0
    auto_fraction: float = 0.8
    metering: str = "etr"


@dataclass(frozen=True)
class Plan:
    """A validated validation plan (see the module docstring for the TOML layout).

    Attributes
    ----------
    illuminants, cameras : tuple of str
        The matrix axes.
    reflectance_sets : tuple of ReflectanceSet
    exposures : tuple of ExposureSpec
    pipelines : tuple of Pipeline
        One object per ``[[pipeline]]`` (a type of :data:`~spectral_cam.apps.validate.pipelines.PIPELINES`).
    thresholds : Thresholds
    chart : str
        ``"synthetic"`` or ``"render"``.
    bands : str
        Synthetic chart band centres, nm.
    patch_px, gap_px : int
        Synthetic chart patch size and spacing, pixels.
    swatches : str
        Report swatches for ``"all"`` cells, only ``"failing"`` ones, or ``"none"``.
    sections : dict
        Scene-file tables shared by every cell (``scene``, ``lens``, ``sensor``,
        ``render``, ``illuminant``).
    source : str
        The plan file (or ``"<dict>"``).
    base_dir : str
        Folder relative paths in ``sections`` are resolved against.
    skipped_pipelines : tuple of str
        Optional pipelines left out because their program is not installed, each with why.
    seeds : int
        Noise realisations per cell (temporal noise seeds ``render.seed`` … ``+ seeds − 1``): a
        cell's statistics are their means, with a 95 % confidence interval of the mean ΔE.
    compare : tuple of (str, str)
        Pipeline pairs whose per-cell difference in mean ΔE is tested (paired over the seeds).
    """

    illuminants: tuple[str, ...]
    cameras: tuple[str, ...]
    reflectance_sets: tuple[ReflectanceSet, ...]
    exposures: tuple[ExposureSpec, ...]
    pipelines: tuple
    thresholds: Thresholds = Thresholds()
    chart: str = "synthetic"
    bands: str = "400:700:10"
    patch_px: int = 16
    gap_px: int = 4
    swatches: str = "all"
    sections: dict = field(default_factory=dict)
    source: str = "<dict>"
    base_dir: str = "."
    skipped_pipelines: tuple = ()
    seeds: int = 1
    compare: tuple = ()

    @property
    def illuminance_lux(self) -> float:
        return float(self.sections.get("illuminant", {}).get("illuminance_lux", 1000.0))

    def scene_config(self, illuminant: str, camera: str, exposure: ExposureSpec, chart: Chart | None = None):
        """The validated SceneConfig of one cell.

        Parameters
        ----------
        illuminant, camera : str
            The cell's illuminant and camera.
        exposure : ExposureSpec
        chart : Chart, optional
            A synthetic chart fixes the sensor size (and vignetting defaults to off: the chart
            is a flat target, and lens fall-off would count as colour error).

        Returns
        -------
        SceneConfig
        """
        from ...scene import scene_from_dict

        data = {name: dict(table) for name, table in self.sections.items()}
        overrides: dict[str, Any] = {
            "illuminant.spd": illuminant, "sensor.model": camera,
            "exposure.time_s": exposure.time_s, "exposure.iso": exposure.iso,
            "exposure.auto_fraction": exposure.auto_fraction, "exposure.metering": exposure.metering,
        }
        if chart is not None and chart.source == "synthetic":
            height, width = chart.radiance.data.shape[:2]
            overrides.update({"sensor.width_px": width, "sensor.height_px": height})
            if "vignetting" not in data.get("sensor", {}):
                overrides["sensor.vignetting"] = False
        return scene_from_dict(data, overrides=overrides, base_dir=Path(self.base_dir))

    def to_dict(self) -> dict:
        """JSON-friendly description (written as ``plan.json`` next to the report)."""
        return {
            "source": self.source,
            "illuminants": list(self.illuminants),
            "cameras": list(self.cameras),
            "reflectance_sets": [{"name": s.name, "patches": len(s), "description": s.description}
                                 for s in self.reflectance_sets],
            "exposures": [dataclasses.asdict(e) for e in self.exposures],
            "pipelines": [p.to_dict() for p in self.pipelines],
            "thresholds": {k: v if math.isfinite(v) else "inf" for k, v in dataclasses.asdict(self.thresholds).items()},
            "chart": self.chart, "bands": self.bands, "patch_px": self.patch_px, "gap_px": self.gap_px,
            "swatches": self.swatches,
            "sections": self.sections,
            "skipped_pipelines": list(self.skipped_pipelines),
            "seeds": self.seeds, "compare": [list(pair) for pair in self.compare],
        }


# ============================================================================ checking
def check_keys(where: str, table: Mapping, valid: Sequence[str]) -> None:
    """Raise a :class:`ConfigError` naming the keys of ``table`` not in ``valid`` (and the valid ones).

    Examples
    --------
    >>> check_keys("[validate]", {"cameras": []}, VALIDATE_KEYS)
    >>> check_keys("[validate]", {"colour": "red"}, ("illuminants", "cameras"))
    Traceback (most recent call last):
    ...
    spectral_cam.errors.ConfigError: unknown key(s) colour in [validate]; valid: illuminants, cameras
    """
    unknown = sorted(set(table) - set(valid))
    if unknown:
        raise ConfigError(f"unknown key(s) {', '.join(unknown)} in {where}; valid: {', '.join(valid)}")


def _table(where: str, table: Any) -> Mapping:
    if not isinstance(table, Mapping):
        raise ConfigError(f"{where} must be a table of key = value pairs")
    return table


def _tables(value: Any) -> Any:
    """An array of tables as a list (one table given alone becomes a list of one)."""
    return [value] if isinstance(value, Mapping) else value


def _check_name(where: str, name: Any) -> str:
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise ConfigError(f"{where}: name = {name!r}; use letters, digits, '_', '.', '+', '-'")
    return name


def _unique(what: str, names: Sequence[str]) -> None:
    if len(set(names)) != len(names):
        raise ConfigError(f"{what} names must be unique: " + ", ".join(names))


def _string_list(key: str, value: Any) -> tuple[str, ...]:
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, (list, tuple)) or not value or not all(isinstance(v, str) and v.strip() for v in value):
        raise ConfigError(f"{key} = {value!r}: give a non-empty list of names")
    if len(set(value)) != len(value):
        raise ConfigError(f"{key} = {value!r}: names must not repeat")
    return tuple(v.strip() for v in value)


def _exposure(table: Any, index: int, default_iso: float) -> ExposureSpec:
    from ...scene import ExposureSection

    where = f"[[exposure]] #{index + 1}"
    check_keys(where, _table(where, table), EXPOSURE_KEYS)
    time_s = table.get("time_s", "auto")
    iso = table.get("iso", default_iso)
    fraction = table.get("auto_fraction", 0.8)
    metering = table.get("metering", "etr")
    for key, value in (("iso", iso), ("auto_fraction", fraction)):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{where}: {key} = {value!r} must be a number")
    if time_s != "auto" and (isinstance(time_s, bool) or not isinstance(time_s, (int, float))):
        raise ConfigError(f"{where}: time_s = {time_s!r}; give seconds or 'auto'")
    section = ExposureSection(time_s=time_s if time_s == "auto" else float(time_s), iso=float(iso),
                              auto_fraction=float(fraction), metering=metering)
    if "name" in table:
        name = table["name"]
    elif time_s == "auto":
        name = f"auto{section.auto_fraction:g}_iso{section.iso:g}"
    else:
        name = f"{section.time_s:g}s_iso{section.iso:g}"
    return ExposureSpec(_check_name(where, name), section.time_s, section.iso, section.auto_fraction, section.metering)


def _pipeline(table: Any, index: int, base_dir: Path):
    """The pipeline of one ``[[pipeline]]`` table: its type from :data:`PIPELINES`, its keys
    checked against the options that type declares."""
    where = f"[[pipeline]] #{index + 1}"
    kind = PIPELINES.check(_table(where, table).get("type"), key=f"{where}: type")
    name = _check_name(where, table.get("name", kind))
    PIPELINES.check_options(kind, table, common=("name", "type"), where=f"{where} (type = {kind!r})")
    options = {k: v for k, v in table.items() if k not in ("name", "type")}
    return PIPELINES[kind].function.from_table(name, options, base_dir=base_dir, where=where)


def _seeds(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 1000:
        raise ConfigError(f"validate.seeds = {value!r}: give a whole number of noise realisations per cell, 1..1000 "
                          "(a confidence interval needs at least 2)")
    return value


def _compare(value: Any, pipelines, skipped: Sequence[str] = ()) -> tuple:
    """``compare = [["a", "b"], ...]`` (or one pair ``["a", "b"]``) of pipeline names; a pair
    naming an optional pipeline left out (``skipped``) is left out too."""
    pairs = [value] if isinstance(value, list) and len(value) == 2 and all(isinstance(v, str) for v in value) \
        else value
    names = [p.name for p in pipelines]
    out = []
    for pair in pairs if isinstance(pairs, list) else [pairs]:
        if not (isinstance(pair, list) and len(pair) == 2 and all(isinstance(v, str) for v in pair)):
            raise ConfigError(f"validate.compare = {value!r}: give pairs of pipeline names, e.g. "
                              f"[[\"ours\", \"libraw\"]]; pipelines: {', '.join(names)}")
        if any(v in skipped for v in pair):
            continue
        missing = [v for v in pair if v not in names]
        if missing or pair[0] == pair[1]:
            raise ConfigError(f"validate.compare pair {pair}: name two different pipelines of the plan "
                              f"({', '.join(names)})")
        out.append(tuple(pair))
    return tuple(out)


def _set_dotted(data: dict, dotted: str, value: Any) -> None:
    parts = str(dotted).split(".")
    if len(parts) < 2 or not all(parts):
        raise ConfigError(f"override {dotted!r}: use section.key=value, e.g. validate.patch_px=12")
    table = data
    for part in parts[:-1]:
        table = table.setdefault(part, {})
        if not isinstance(table, dict):
            raise ConfigError(f"override {dotted!r}: {part!r} is not a table")
    table[parts[-1]] = value


def _illuminants(settings: Mapping, base_dir: Path) -> tuple[str, ...]:
    from ... import spectra

    resolved = []
    for name in _string_list("validate.illuminants", settings.get("illuminants", ["D65"])):
        if name.lower().endswith(".csv") and not Path(name).is_absolute():
            name = str((base_dir / name).resolve())
        spectra.illuminant(name)
        resolved.append(name)
    return tuple(resolved)


def _cameras(settings: Mapping) -> tuple[str, ...]:
    from ... import spectra

    cameras = _string_list("validate.cameras", settings.get("cameras", ["nikon_d850"]))
    for camera in cameras:
        if camera == "ideal":
            raise ConfigError("validate.cameras: 'ideal' has three identical channels and no colour; valid: "
                              + ", ".join(spectra.camera_names()))
        spectra.camera_sensitivities(camera)
    return cameras


def _scene_sections(data: Mapping, chart: str) -> dict:
    sections = {name: dict(_table(f"[{name}]", data.get(name, {}))) for name in SCENE_SECTIONS}
    if "spd" in sections["illuminant"]:
        raise ConfigError("[illuminant] spd comes from validate.illuminants; [illuminant] takes illuminance_lux only")
    if "model" in sections["sensor"]:
        raise ConfigError("[sensor] model comes from validate.cameras; remove it from [sensor]")
    if chart == "synthetic":
        fixed = [k for k in ("width_px", "height_px") if k in sections["sensor"]]
        if fixed:
            raise ConfigError(f"sensor.{fixed[0]} is set by the chart when validate.chart = 'synthetic'; "
                              "use validate.patch_px and validate.gap_px")
    return sections


def plan_from_dict(data: Mapping[str, Any], *, base_dir: str | Path = ".", source: str = "<dict>",
                   overrides: Mapping[str, Any] | None = None) -> Plan:
    """Build and validate a :class:`Plan` from nested dicts (as read from TOML).

    Parameters
    ----------
    data : mapping
        ``{"validate": {...}, "exposure": [...], "pipeline": [...], "sensor": {...}, ...}``.
    base_dir : str or path-like
        Folder relative paths (CSV sets and illuminants, python_path) are resolved against.
    source : str
        Where the plan came from (for the report).
    overrides : mapping, optional
        ``{"section.key": value}`` applied on top (e.g. ``{"validate.patch_px": 12}``).

    Returns
    -------
    Plan

    Raises
    ------
    ConfigError
        For unknown sections, keys or names (listing the valid ones) and invalid values;
        every cell's scene configuration is validated before anything runs.

    Examples
    --------
    >>> plan = plan_from_dict({"validate": {"illuminants": ["D65", "A"], "patch_px": 8},
    ...                        "pipeline": [{"type": "ours", "isp": {"tone": "linear"}}]})
    >>> plan.illuminants, plan.cameras, [p.name for p in plan.pipelines]
    (('D65', 'A'), ('nikon_d850',), ['ours'])
    >>> plan_from_dict({"validate": {}, "pipeline": [{"type": "darktable"}]})
    Traceback (most recent call last):
    ...
    spectral_cam.errors.ConfigError: [[pipeline]] #1: type = 'darktable': unknown pipeline type 'darktable'; valid: ours, rawpy, callable, command
    """
    from ... import spectra
    from ...scene import scene_from_dict

    base_dir = Path(base_dir)
    data = copy.deepcopy(dict(data))
    for dotted, value in (overrides or {}).items():
        _set_dotted(data, dotted, value)
    check_keys("the plan (sections)", data, ("validate", "exposure", "pipeline", *SCENE_SECTIONS))
    if "isp" in data:
        raise ConfigError("[isp] belongs to a pipeline: give [[pipeline]] type = 'ours' with isp = {...}")
    settings = data.get("validate")
    if not isinstance(settings, Mapping):
        raise ConfigError("the plan needs a [validate] table with illuminants, cameras and reflectance_sets")
    check_keys("[validate]", settings, VALIDATE_KEYS)
    illuminants = _illuminants(settings, base_dir)
    cameras = _cameras(settings)
    sets = tuple(reflectance_set(name, base_dir=base_dir)
                 for name in _string_list("validate.reflectance_sets", settings.get("reflectance_sets", ["colorchecker"])))
    chart = settings.get("chart", "synthetic")
    if chart not in CHART_SOURCES:
        raise ConfigError(f"validate.chart = {chart!r}; valid: {', '.join(CHART_SOURCES)}")
    if chart == "render" and any(s.name != "colorchecker" for s in sets):
        raise ConfigError("validate.chart = 'render' renders the ColorChecker preset only; use "
                          "reflectance_sets = ['colorchecker'] or chart = 'synthetic'")
    bands = settings.get("bands", "400:700:10")
    if not isinstance(bands, str):
        raise ConfigError(f"validate.bands = {bands!r}; give band centres 'start:stop:step' in nm")
    spectra.parse_bands(bands)
    swatches = settings.get("swatches", "all")
    if swatches not in SWATCH_MODES:
        raise ConfigError(f"validate.swatches = {swatches!r}; valid: {', '.join(SWATCH_MODES)}")
    thresholds_table = settings.get("thresholds", {})
    if not isinstance(thresholds_table, Mapping):
        raise ConfigError("validate.thresholds must be a table")
    check_keys("[validate.thresholds]", thresholds_table, [f.name for f in dataclasses.fields(Thresholds)])
    thresholds = Thresholds(**thresholds_table)
    sections = _scene_sections(data, chart)
    base = scene_from_dict(sections, overrides={"sensor.model": cameras[0]}, base_dir=base_dir)

    exposures_data = _tables(data.get("exposure", [{}]))
    if not isinstance(exposures_data, list) or not exposures_data:
        raise ConfigError("[[exposure]]: give one or more exposure tables")
    exposures = tuple(_exposure(table, i, base.exposure.iso) for i, table in enumerate(exposures_data))
    _unique("[[exposure]]", [e.name for e in exposures])

    pipelines_data = _tables(data.get("pipeline"))
    if not isinstance(pipelines_data, list) or not pipelines_data:
        raise ConfigError("the plan needs at least one [[pipeline]] table (type = "
                          + " | ".join(repr(t) for t in PIPELINES) + ")")
    pipelines = tuple(_pipeline(table, i, base_dir) for i, table in enumerate(pipelines_data))
    _unique("[[pipeline]]", [p.name for p in pipelines])
    # an optional tool that is not installed is left out, with a note in the report
    left_out = [p.name for p in pipelines if getattr(p, "optional", False) and not p.installed()]
    skipped = tuple(f"{p.name}: {p.program} is not installed" for p in pipelines if p.name in left_out)
    pipelines = tuple(p for p in pipelines if p.name not in left_out)
    if not pipelines:
        raise ConfigError("no pipeline of the plan can run: " + "; ".join(skipped))

    plan = Plan(illuminants=illuminants, cameras=cameras, reflectance_sets=sets, exposures=exposures,
                pipelines=pipelines, thresholds=thresholds, chart=chart, bands=bands,
                patch_px=settings.get("patch_px", 16), gap_px=settings.get("gap_px", 4), swatches=swatches,
                sections=sections, source=source, base_dir=str(base_dir), skipped_pipelines=skipped,
                seeds=_seeds(settings.get("seeds", 1)), compare=_compare(settings.get("compare", []), pipelines, left_out))
    if chart == "synthetic":  # patch sizes are checked by building one chart's geometry
        for key in ("patch_px", "gap_px"):
            value = getattr(plan, key)
            if isinstance(value, bool) or not isinstance(value, int) or value < (4 if key == "patch_px" else 0):
                raise ConfigError(f"validate.{key} = {value!r}: must be a whole number of pixels "
                                  f">= {4 if key == 'patch_px' else 0}")
    for exposure in exposures:  # every cell's scene settings are valid
        plan.scene_config(illuminants[0], cameras[0], exposure)
    return plan


def load_plan(path: str | Path, overrides: Mapping[str, Any] | Sequence[str] | None = None) -> Plan:
    """Read a TOML validation plan, apply overrides and validate it.

    Parameters
    ----------
    path : str or path-like
        The plan file.
    overrides : mapping or list of str, optional
        ``{"validate.patch_px": 12}`` or ``["validate.patch_px=12", ...]``.

    Returns
    -------
    Plan

    Raises
    ------
    ConfigError
        If the file is missing, not TOML, or invalid (see :func:`plan_from_dict`).

    Examples
    --------
    >>> plan = load_plan("plans/validate_example.toml", overrides=["validate.patch_px=8"])
    >>> plan.patch_px, [e.name for e in plan.exposures], [p.kind for p in plan.pipelines]
    (8, ['base', 'iso400-under'], ['ours', 'rawpy', 'command', 'command', 'command'])
    """
    from ...scene import parse_override, read_toml

    path = Path(path)
    data = read_toml(path, "plan file")
    if isinstance(overrides, (list, tuple)):
        overrides = dict(parse_override(item) for item in overrides)
    return plan_from_dict(data, base_dir=path.resolve().parent, source=str(path), overrides=overrides)
