"""Reading and writing scene files: TOML or a dict, with overrides → validated, frozen
:class:`SceneConfig`, and back to TOML.

A scene file says only what differs from the defaults; any key can be overridden with
``section.key=value`` strings (the CLI's ``--set``) or an ``overrides`` mapping. Each section is
a frozen dataclass assembled from the keys declared by their owners (:mod:`.section`,
:mod:`.sections`); :meth:`SceneConfig.to_dict` round-trips through :func:`scene_from_dict`, so
each output's ``meta.json`` can reproduce its render.

References
----------
.. [1] TOML v1.0.0, https://toml.io/en/v1.0.0 (read with the standard library's tomllib).
.. [2] docs/design.md, "Scene file" (the key names are a contract).
"""

from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Mapping

from .. import spectra
from ..errors import ConfigError
from ..isp.config import ISPConfig as ISPSection
from .section import fail as _fail
from .section import section_class, section_keys

__all__ = ["SceneConfig", "load_scene", "scene_from_dict", "parse_override", "read_toml", "section_from_table",
           "SECTION_NAMES", "physical_ranges"]

#: The sections of a scene file, in the order they are written.
SECTION_NAMES = ("scene", "illuminant", "sky", "lens", "sensor", "exposure", "motion", "render", "isp")


def _section_type(name: str) -> type:
    return ISPSection if name == "isp" else section_class(name)


def physical_ranges() -> dict[str, tuple[float, float, str]]:
    """The valid range of every physical key, (low, high, unit), as its owner declares it: a camera or
    scene outside it is not one this simulator models (its arithmetic would overflow or underflow),
    so it is refused before anything runs. The same table is in docs/design.md ("Scene file")."""
    return {f"{name}.{key.name}": key.range for name in SECTION_NAMES if name != "isp"
            for _, key in section_keys(name) if key.range is not None}


def _default(name: str):
    return field(default_factory=lambda: _section_type(name)())


@dataclass(frozen=True)
class SceneConfig:
    """A whole, validated scene: one frozen section per TOML table (their keys: ``spectral-cam keys``)."""

    scene: Any = _default("scene")
    illuminant: Any = _default("illuminant")
    sky: Any = _default("sky")
    lens: Any = _default("lens")
    sensor: Any = _default("sensor")
    exposure: Any = _default("exposure")
    motion: Any = _default("motion")
    render: Any = _default("render")
    isp: Any = _default("isp")

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Plain, JSON/TOML-serialisable dict (tuples become lists)."""
        out = {}
        for name in SECTION_NAMES:
            section = dataclasses.asdict(getattr(self, name))
            out[name] = {k: list(v) if isinstance(v, tuple) else v for k, v in section.items()}
        out["scene"]["assets"] = [spec.to_table() for spec in self.scene.assets]
        out["scene"]["scatter"] = [spec.to_table() for spec in self.scene.scatter]
        return out

    def to_toml(self) -> str:
        """The whole resolved scene as a TOML scene file (``load_scene`` reads it back equal)."""
        lines = ["# spectral_cam scene, every key resolved"]
        for name, table in self.to_dict().items():
            lines.append(f"\n[{name}]")
            lines += [f"{key} = {_toml_value(value)}" for key, value in table.items()]
        return "\n".join(lines) + "\n"

    def replace(self, **overrides: Any) -> "SceneConfig":
        """A copy with ``"section.key": value`` overrides applied and validated."""
        # its instance budget was reckoned when it was read: copies that move only the focus, the
        # light or the lens (the capture plan's) are not reckoned again, each with a lens of its own
        return scene_from_dict(_CheckedDict(self.to_dict()), overrides=overrides)


def _budget_reckoned(data: Mapping[str, Any], overrides: Mapping[str, Any] | None) -> bool:
    """Whether ``scene_from_dict`` must reckon the scatter's instance budget: always for a scene
    read from a file or a dict, and for a copy whose overrides change what the count depends on
    (the copies, the ground in view: :data:`_BUDGET_KEYS`, any ``[sensor]`` key)."""
    if not isinstance(data, _CheckedDict):
        return True
    return any(str(key) in _BUDGET_KEYS or str(key).startswith("sensor.") for key in (overrides or {}))


#: The keys besides ``[sensor]`` that change how many copies a scene holds.
_BUDGET_KEYS = frozenset({"scene.scatter", "scene.assets", "scene.preset", "scene.distance_m", "scene.view_pitch_deg",
                          "scene.layout_seed", "lens.focal_length_mm"})


class _CheckedDict(dict):
    """A config's own dict, whose instance budget was reckoned when it was read."""


def _toml_value(value: Any) -> str:
    """A TOML literal for the value types scene sections hold."""
    import json

    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a JSON string is a valid TOML basic string
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(item) for item in value) + "]"
    if isinstance(value, Mapping):  # an inline table ([[scene.assets]] entries, distributions)
        return "{" + ", ".join(f"{key} = {_toml_value(item)}" for key, item in value.items()) + "}"
    raise ConfigError(f"cannot write {value!r} ({type(value).__name__}) to TOML")


# ----------------------------------------------------------------------------- coercion
def _coerce(key: str, value: Any, default: Any, annotation: str) -> Any:
    """Check a TOML value against a field's type and convert int->float, list->tuple."""
    kinds = annotation.replace(" ", "").split("|")
    if isinstance(value, bool):
        if "bool" in kinds:
            return value
    elif isinstance(value, int) and "int" in kinds:
        return value
    elif isinstance(value, (int, float)) and "float" in kinds:
        return float(value)
    elif isinstance(value, float) and "int" in kinds and value.is_integer():
        return int(value)
    elif isinstance(value, str) and "str" in kinds:
        return value
    elif isinstance(value, (list, tuple)) and any(k.startswith("tuple") for k in kinds):
        inner = "float" if "float" in annotation else "str"
        items = []
        for item in value:
            if inner == "float" and isinstance(item, (int, float)) and not isinstance(item, bool):
                items.append(float(item))
            elif inner == "str" and isinstance(item, str):
                items.append(item)
            else:
                _fail(key, value, f"must be a list of {inner} values")
        return tuple(items)
    expected = " or ".join("a list" if k.startswith("tuple") else k for k in kinds)
    _fail(key, value, f"has the wrong type; expected {expected} (default {default!r})")


def _resolve_path(value: Any, base_dir: Path) -> Any:
    """Make a relative file path (CSV, XML) relative to the scene file's folder."""
    if isinstance(value, str) and (value.lower().endswith((".csv", ".xml"))):
        path = Path(value).expanduser()
        if not path.is_absolute():
            path = base_dir / path
        return str(path.resolve())
    return value


def _shading_table_path(value: str, base_dir: Path) -> str:
    """``isp.shading``: ``"off"``, or a table's path resolved against the scene file's folder and
    read now, so a missing or broken table is refused at load, not after the render (issue 39 #24)."""
    if value == "off" or not value:
        return value  # ISPSection names what is valid for an empty one
    from ..isp.shading import load_shading_table

    path = Path(value).expanduser()
    path = (path if path.is_absolute() else base_dir / path).resolve()
    load_shading_table(path)
    return str(path)


def parse_override(text: str) -> tuple[str, Any]:
    """Split ``"section.key=value"``; the value is read as a TOML value, else a string."""
    if "=" not in text:
        raise ConfigError(f"override {text!r}: use section.key=value, e.g. lens.f_number=2.8")
    key, raw = (part.strip() for part in text.split("=", 1))
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key, value


def scene_from_dict(
    data: Mapping[str, Any],
    *,
    overrides: Mapping[str, Any] | None = None,
    base_dir: str | Path = ".",
) -> SceneConfig:
    """Build and validate a :class:`SceneConfig` from nested dicts (as read from TOML).

    Parameters
    ----------
    data
        ``{"section": {"key": value}}``; missing keys take their defaults.
    overrides
        ``{"section.key": value}`` applied on top (values as Python objects or strings).
    base_dir
        Folder that relative CSV/XML paths are resolved against.

    Raises
    ------
    ConfigError
        For an unknown section or key (listing the valid ones) or an invalid value.
    """
    base_dir = Path(base_dir)
    merged: dict[str, dict[str, Any]] = {}
    for section, table in data.items():
        if section not in SECTION_NAMES:
            raise ConfigError(f"unknown section [{section}]; valid: {', '.join(SECTION_NAMES)}")
        if not isinstance(table, Mapping):
            raise ConfigError(f"[{section}] must be a table of key = value pairs")
        merged[section] = dict(table)
    for dotted, value in (overrides or {}).items():
        section, _, key = str(dotted).partition(".")
        if section not in SECTION_NAMES or not key:
            raise ConfigError(
                f"override {dotted!r}: use section.key with a section among {', '.join(SECTION_NAMES)}"
            )
        merged.setdefault(section, {})[key] = value
    merged["sensor"] = _sensor_table(merged.get("sensor", {}), data, overrides)
    sections = {name: section_from_table(name, merged.get(name, {}), base_dir) for name in SECTION_NAMES
                if name not in ("lens", "exposure")}
    # an ISO left unset is the sensor's base ISO (a named camera's own: 64 for a D850), as a camera
    # leaves it until the light asks for more; the generic sensor's base is 100, as before
    exposure = dict(merged.get("exposure", {}))
    exposure.setdefault("iso", sections["sensor"].base_iso)
    sections["exposure"] = section_from_table("exposure", exposure, base_dir)
    # the prescription first: it sees what the user gave, not a default filled in for an XML camera
    lens_table = _lens_for_prescription(dict(merged.get("lens", {})), base_dir)
    lens_table = _lens_for_xml_camera(lens_table, sections["scene"], sections["sensor"])
    sections["lens"] = section_from_table("lens", lens_table, base_dir)
    copies = sections["scene"].scatter or any(a.count > 1 for a in sections["scene"].assets)
    if copies and _budget_reckoned(data, overrides):
        from ..optics import ThinLens
        from ..presets.scatter import check_instance_budget

        check_instance_budget(SceneConfig(**sections), ThinLens.from_config(sections["lens"], sections["sensor"]))
    if sections["motion"].moving:
        if sections["exposure"].time_s == "auto":
            _fail("exposure.time_s", "auto", "motion blur needs a fixed exposure time (the blur is velocity × time); "
                  "give exposure.time_s in seconds")
        if sections["render"].spp == "auto":
            _fail("render.spp", "auto", "motion blur splits the samples between sub-frames; give render.spp")
    return SceneConfig(**sections)


def _sensor_table(table: Mapping[str, Any], data: Mapping[str, Any], overrides: Mapping[str, Any] | None) -> dict:
    """The ``[sensor]`` table with a named camera's figures for the keys left unset (issue 39 #9:
    a D850 and an α7 III got the same full well). A copy (:meth:`SceneConfig.replace`) holds the
    figures its first model filled in, and the pitch its frame derived: a new model or frame size
    fills and derives them again, unless the overrides set them."""
    given = {str(key).partition(".")[2] for key in (overrides or {}) if str(key).startswith("sensor.")}
    table = dict(table)
    if isinstance(data, _CheckedDict):
        from_model = set(table.get("model_figures", ())) - given
        if table.get("model") != data.get("sensor", {}).get("model"):
            if not from_model:  # the first named no camera: its generic figures give way too
                from_model = {key for key in spectra.SENSOR_FIGURE_KEYS.values()
                              if key not in given and table.get(key) == getattr(section_class("sensor"), key)}
            for key in from_model:  # the first camera's figures: the new camera's take their place
                table.pop(key, None)
            from_model = set()
        table["model_figures"] = [key for key in table.get("model_figures", ()) if key in from_model]
        if table.get("keep_field_of_view") is True and "pixel_pitch_um" not in given:
            table.pop("pixel_pitch_um", None)
    return spectra.with_camera_figures(table, default_size_px=(section_class("sensor").width_px,
                                                                      section_class("sensor").height_px))


def _lens_for_prescription(lens: dict[str, Any], base_dir: Path) -> dict[str, Any]:
    """For ``model = "prescription"``: the focal length is the prescription's (paraxial EFL), the
    f-number the one asked (the stop is closed to it when rendered), or unset the design's own
    (traced: the focal length over the widest axial bundle that passes every aperture); one
    faster than the design's is refused. A relative CSV path is resolved against the scene
    file's folder here, once, before it is read (issue 39 #12: it was read from the working
    directory, then resolved again)."""
    if "prescription" in lens:
        lens = dict(lens, prescription=_resolve_path(lens["prescription"], base_dir))
    if lens.get("model") != "prescription":
        return lens
    from ..optics.prescription import focal_length_and_f_number

    name = str(lens.get("prescription", "dgauss_50mm"))
    focal_m, own_f_number = focal_length_and_f_number(name)
    asked = lens.get("f_number")
    if not (isinstance(asked, (int, float)) and not isinstance(asked, bool)):
        asked = own_f_number if asked is None else asked  # a wrong type: LensSection says so
    elif asked < own_f_number * (1 - 1e-4):
        _fail("lens.f_number", asked, f"lens.prescription {name!r} opens to f/{own_f_number:.4g} at most: valid "
              f"f-numbers are >= {own_f_number:.4g} (the stop is closed to a slower one), or leave it unset")
    given = lens.get("focal_length_mm")
    number = isinstance(given, (int, float)) and not isinstance(given, bool)
    if number and abs(given - focal_m * 1e3) > 1e-6 * focal_m * 1e3:
        import warnings  # a prescription is a real lens: said, not done silently (issue 25 #15)

        from ..errors import SceneWarning

        warnings.warn(f"lens.prescription {name!r} replaces lens.focal_length_mm = {given!r} by its "
                      f"{focal_m * 1e3:.4g} (a prescription's focal length is its own); leave it unset",
                      SceneWarning, stacklevel=4)
    return dict(lens, focal_length_mm=focal_m * 1e3, f_number=asked)


def _lens_for_xml_camera(lens: dict[str, Any], scene, sensor) -> dict[str, Any]:
    """The lens table with ``focal_length_mm`` resolved: for a user's XML scene left unset (or
    ``"auto"``) it keeps the XML camera's horizontal field of view on this sensor
    (:func:`spectral_cam.xml_scene.focal_length_for_fov`); a value given is kept (the render
    records, and warns, when it replaces the XML camera's field of view). Without an XML camera
    (or for a preset) ``"auto"`` is the default 8 mm."""
    from ..xml_scene import focal_length_for_fov, xml_field_of_view

    given = lens.get("focal_length_mm", "auto")
    if given != "auto":
        return lens
    fov = xml_field_of_view(scene.mitsuba_xml) if scene.mitsuba_xml else None
    defaults = section_class("lens")
    focus = lens.get("focus_distance_m", defaults.focus_distance_m)
    if fov is None or not isinstance(focus, (int, float)) or isinstance(focus, bool) or focus <= 0:
        lens["focal_length_mm"] = defaults.focal_length_mm  # the section reports a bad focus
        return lens
    width_m = sensor.width_px * sensor.pixel_pitch_um * 1e-6
    lens["focal_length_mm"] = focal_length_for_fov(fov.fov_x_deg, width_m, float(focus))
    return lens


def section_from_table(name: str, table: Mapping[str, Any], base_dir: str | Path = ".") -> Any:
    """One validated section (``[isp]``, ``[lens]``, …) from a table of its keys, defaults for
    the rest: what :func:`scene_from_dict` does per section, for callers that need only one
    (``spectral-cam develop`` builds its ``[isp]`` without validating a whole scene).

    Raises
    ------
    ConfigError
        For an unknown section or key (listing the valid ones) or an invalid value.

    Examples
    --------
    >>> section_from_table("isp", {"demosaic": "bilinear", "denoise": 1}).denoise
    1.0
    """
    if name not in SECTION_NAMES:
        raise ConfigError(f"unknown section [{name}]; valid: {', '.join(SECTION_NAMES)}")
    cls = _section_type(name)
    known = {f.name: f for f in fields(cls)}
    unknown = sorted(set(table) - set(known))
    if unknown:
        raise ConfigError(
            f"unknown key(s) {', '.join(f'{name}.{k}' for k in unknown)}; valid keys of "
            f"[{name}]: {', '.join(known)}"
        )
    entry_lists = {} if name == "isp" else {key.name: key.entries for _, key in section_keys(name) if key.entries}
    base_dir = Path(base_dir)
    kwargs = {key: _coerce(f"{name}.{key}", _resolve_path(value, base_dir), known[key].default, str(known[key].type))
              for key, value in table.items() if key not in entry_lists}
    for key, parse in entry_lists.items():
        if key in table:
            kwargs[key] = _entry_list(f"{name}.{key}", table[key], parse, base_dir)
    if name == "isp" and isinstance(kwargs.get("shading"), str):
        kwargs["shading"] = _shading_table_path(kwargs["shading"], base_dir)
    try:
        return cls(**kwargs)
    except ConfigError:
        raise
    except (TypeError, ValueError) as exc:  # e.g. a comparison with a wrong type
        raise ConfigError(f"[{name}]: {exc}") from None


def _entry_list(key: str, value: Any, parse, base_dir: Path) -> tuple:
    if isinstance(value, Mapping):  # a single table given with --set
        value = [value]
    if not isinstance(value, (list, tuple)):
        _fail(key, value, f"give an array of tables ([[{key}]] in the scene file)")
    return tuple(parse(table, k, base_dir) for k, table in enumerate(value))


def read_toml(path: str | Path, what: str) -> dict:
    """Read a TOML file (a scene file, validation plan, dataset spec, ...) into a dict.

    Raises
    ------
    ConfigError
        Naming ``what`` when the file is missing, unreadable (or its path holds a NUL byte),
        not UTF-8, or not valid TOML.
    """
    try:
        path = Path(path)
        if not path.is_file():
            raise ConfigError(f"{what} {str(path)!r} does not exist or is not a file")
        text = path.read_text(encoding="utf-8")
    except (OSError, ValueError) as exc:  # unreadable, not UTF-8, or a path with a NUL byte
        if isinstance(exc, ConfigError):
            raise
        raise ConfigError(f"cannot read {what} {str(path)!r}: {exc}") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path} is not a valid TOML {what}: {exc}") from None


def load_scene(path: str | Path, overrides: Mapping[str, Any] | list[str] | None = None) -> SceneConfig:
    """Read a scene file, apply overrides and validate.

    Parameters
    ----------
    path
        The ``.toml`` scene file, or a Mitsuba 3 ``.xml`` scene: it is then the scene as
        ``[scene] mitsuba_xml = path`` with every other key at its default (its camera's pose and
        field of view kept, :func:`_lens_for_xml_camera`); overrides set the rest.
    overrides
        ``{"lens.f_number": 2.8}`` or a list of ``"section.key=value"`` strings.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "scene.toml").write_text("lens = { f_number = 4.0 }")
    >>> scene = load_scene(folder / "scene.toml", overrides={"sensor.width_px": 64})
    >>> scene.lens.f_number, scene.sensor.width_px, scene.scene.preset
    (4.0, 64, 'colorchecker')
    """
    path = Path(path)
    if path.suffix.lower() == ".xml":  # a user's Mitsuba scene needs no wrapper TOML (issue 39 #18)
        if not path.is_file():
            raise ConfigError(f"scene file {str(path)!r} does not exist; give a .toml scene file or a "
                              "Mitsuba 3 .xml scene")
        data: dict[str, Any] = {"scene": {"mitsuba_xml": str(path.resolve())}}
    else:
        data = read_toml(path, "scene file")
    if isinstance(overrides, (list, tuple)):
        overrides = dict(parse_override(item) for item in overrides)
    return scene_from_dict(data, overrides=overrides, base_dir=path.parent)
