"""The measured cameras: their r, g, b spectral sensitivities and their sensors' published
figures (full well, read noise, bit depth, pitch, size, base ISO), each figure with its source.

Curves: the 17 cameras shipped in ``spectral_cam/data/cameras`` (pbrt-v4 / PhysLight data, see
the README there) and colour-science's two NPL cameras (package data read by
:mod:`spectral_cam.cie`, without importing colour). Figures: ``sensor_figures.csv`` beside the
curves. A camera is named by its slug (``"Nikon D850"`` → ``"nikon_d850"``). Everything here is
importable from :mod:`spectral_cam.spectra` as well.

References
----------
.. [1] Langlands, A., & Fascione, L. (2020). PhysLight: An end-to-end pipeline for
   scene-referred lighting. DigiPro '20.
.. [2] EMVA Standard 1288, Release 4.0 (2021): full-well capacity and read noise in electrons.
"""

from __future__ import annotations

import csv
import functools
import re
from dataclasses import dataclass
from importlib import resources

import numpy as np

from .errors import ConfigError
from .spectrum import Spectrum

__all__ = ["COLOUR_CAMERA_KEYS", "camera_names", "camera_sensitivities", "validate_camera", "CameraFigure",
           "camera_figures", "with_camera_figures", "figure_record", "SENSOR_FIGURE_KEYS", "FIGURES_FILE"]


def _slug(name: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", name.casefold()).strip("_")


#: The keys of colour-science's ``MSDS_CAMERA_SENSITIVITIES``, written out so that listing the
#: cameras (``spectral-cam cameras``) does not import colour (~1 s, it loads matplotlib);
#: tests/test_spectra.py checks the list against colour-science.
COLOUR_CAMERA_KEYS = ("Nikon 5100 (NPL)", "Sigma SDMerill (NPL)")


@functools.lru_cache(maxsize=1)
def _camera_sources() -> dict[str, object]:
    """slug -> packaged CSV resource or colour-science dataset key."""
    sources: dict[str, object] = {}
    folder = resources.files("spectral_cam") / "data" / "cameras"
    for entry in folder.iterdir():
        if entry.name.endswith(".csv") and entry.name != FIGURES_FILE:
            sources[entry.name[:-4]] = entry
    for key in COLOUR_CAMERA_KEYS:
        sources[_slug(key)] = key
    return dict(sorted(sources.items()))


def camera_names() -> list[str]:
    """The measured cameras available as ``sensor.model`` (plus ``"ideal"``)."""
    return list(_camera_sources())


@functools.lru_cache(maxsize=None)
def _camera_sensitivities_cached(slug: str) -> Spectrum:
    from . import cie

    source = _camera_sources()[slug]
    if isinstance(source, str):
        curves = cie.camera_curves(source.split(" (")[0].lower().replace(" ", "_"))
        return Spectrum(curves.wavelengths, curves.values, slug, labels=("r", "g", "b"))
    with source.open() as handle:
        rows = list(csv.reader(handle))
    header, body = rows[0], np.asarray(rows[1:], dtype=float)
    # The 720 nm row of the pbrt-v4 data holds one fill value in r, g and b (see the
    # data README): it is not a measurement, so the curves end at 710 nm.
    body = body[body[:, 0] <= 710.0]
    return Spectrum(body[:, 0], body[:, 1:], slug, labels=tuple(header[1:]))


def camera_sensitivities(name: str) -> Spectrum:
    """Relative spectral sensitivities (per unit energy) of a measured camera's r, g, b
    channels.

    Parameters
    ----------
    name
        One of :func:`camera_names` (case and punctuation insensitive, e.g.
        ``"nikon_d850"`` or ``"Nikon D850"``).
    """
    return _camera_sensitivities_cached(validate_camera(name)).copy()


def validate_camera(name: str) -> str:
    """The slug of a measured camera (``"Nikon D850"`` -> ``"nikon_d850"``), without loading
    its curves or importing colour-science.

    Raises
    ------
    ConfigError
        An unknown camera; the message lists :func:`camera_names`.
    """
    slug = _slug(str(name))
    if slug not in _camera_sources():
        raise ConfigError(
            f"unknown camera {name!r}; valid: 'ideal' or one of {', '.join(camera_names())}"
        )
    return slug


#: The table of each camera's sensor figures, beside the curves (one row per camera and figure,
#: with its unit and source).
FIGURES_FILE = "sensor_figures.csv"

#: The figures a named ``sensor.model`` sets when the scene leaves them unset: table figure ->
#: ``[sensor]`` key.
SENSOR_FIGURE_KEYS = {"full_well_e": "full_well_e", "read_noise_e": "read_noise_e", "bit_depth": "bit_depth",
                      "pixel_pitch_um": "pixel_pitch_um", "base_iso": "base_iso"}


@dataclass(frozen=True)
class CameraFigure:
    """One published (or assumed) figure of a camera's sensor: value, unit, and where it comes
    from (``source`` starts with ``"assumed:"`` where no published figure was found, saying why
    the value was chosen)."""

    value: float
    unit: str
    source: str


@functools.lru_cache(maxsize=1)
def _figure_table() -> dict[str, dict[str, CameraFigure]]:
    folder = resources.files("spectral_cam") / "data" / "cameras"
    table: dict[str, dict[str, CameraFigure]] = {}
    with (folder / FIGURES_FILE).open(encoding="utf-8") as handle:
        for row in csv.DictReader(handle):
            value = float(row["value"])
            table.setdefault(row["camera"], {})[row["figure"]] = CameraFigure(
                int(value) if row["figure"] in ("bit_depth", "width_px", "height_px") else value,
                row["unit"], row["source"])
    return table


def camera_figures(name: str) -> dict[str, CameraFigure]:
    """The published figures of a measured camera's sensor (``spectral_cam/data/cameras/
    sensor_figures.csv``): ``full_well_e`` (e⁻ at base ISO), ``read_noise_e`` (e⁻ at base ISO),
    ``bit_depth``, ``pixel_pitch_um`` (µm, the sensor's width over its columns), ``width_px``,
    ``height_px`` (effective pixels), ``sensor_width_mm``, ``sensor_height_mm`` and
    ``base_iso``, each a :class:`CameraFigure` with its source.

    Raises
    ------
    ConfigError
        An unknown camera (the message lists :func:`camera_names`), or ``"ideal"``, which is no
        camera and has no figures.

    Examples
    --------
    >>> camera_figures("Nikon D850")["base_iso"].value
    64.0
    """
    slug = validate_camera(name)
    return dict(_figure_table()[slug])


def with_camera_figures(table: dict, *, default_size_px: tuple[int, int]) -> dict:
    """A ``[sensor]`` table with its named camera's figures filled in for the keys it leaves
    unset (:data:`SENSOR_FIGURE_KEYS`; explicit keys win), and with ``keep_field_of_view`` the
    pitch that spreads ``width_px`` × ``height_px`` over the camera's published sensor (the
    largest that fits both sides, so the frame is the biggest of its aspect ratio on the
    sensor, as a camera's aspect modes are). A table that names no model (or ``"ideal"``) keeps
    the generic defaults (:func:`figure_record` says afterwards which figure came from where).
    ``default_size_px`` is the frame (width, height) a table that leaves it unset gets (the
    scene's defaults: passed in, since this layer sits below ``scene``).

    Raises
    ------
    ConfigError
        ``keep_field_of_view`` with an ``"ideal"`` model (no published size) or with a
        ``pixel_pitch_um`` that disagrees with the derived one.
    """
    model = table.get("model")
    if not isinstance(model, str) or model == "ideal":
        if table.get("keep_field_of_view") is True:
            raise ConfigError("sensor.keep_field_of_view = true needs a camera's published sensor size: name "
                              f"sensor.model (one of {', '.join(camera_names())}); 'ideal' has none")
        return table
    figures = camera_figures(model)
    filled = {key: figures[figure].value for figure, key in SENSOR_FIGURE_KEYS.items() if key not in table}
    out = dict(table, **filled)
    # which keys the camera set, kept by a resolved scene.toml (where every key is written out)
    earlier = table.get("model_figures", ())
    earlier = set(earlier) if isinstance(earlier, (list, tuple)) else set()
    out["model_figures"] = tuple(key for key in SENSOR_FIGURE_KEYS.values() if key in earlier | set(filled))
    if table.get("keep_field_of_view") is True:
        pitch = _pitch_keeping_view(figures, out, default_size_px)
        given = table.get("pixel_pitch_um")
        number = isinstance(given, (int, float)) and not isinstance(given, bool)
        if number and abs(given - pitch.value) > 1e-6 * pitch.value:
            raise ConfigError(f"sensor.pixel_pitch_um = {given!r} with sensor.keep_field_of_view = true: the pitch is "
                              f"then the camera's sensor over the pixels ({pitch.value:.6g} µm); set one of them")
        out["pixel_pitch_um"] = pitch.value
    return out


def _pitch_keeping_view(figures: dict[str, CameraFigure], table: dict,
                        default_size_px: tuple[int, int]) -> CameraFigure:
    """The pitch (µm) that puts ``width_px`` × ``height_px`` on the camera's published sensor."""
    width, height = table.get("width_px", default_size_px[0]), table.get("height_px", default_size_px[1])
    if not all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in (width, height)):
        return figures["pixel_pitch_um"]  # SensorSection refuses the size itself
    size_w, size_h = figures["sensor_width_mm"].value, figures["sensor_height_mm"].value
    pitch = min(size_w / width, size_h / height) * 1e3  # the widest frame of this aspect on the sensor
    return CameraFigure(pitch, "um", f"keep_field_of_view: the {size_w:g} × {size_h:g} mm sensor over "
                                     f"{width} × {height} px ({figures['sensor_width_mm'].source})")


def figure_record(sensor) -> dict:
    """Where each of a sensor's figures came from (meta.json ``sensor_figures``): for every
    :data:`SENSOR_FIGURE_KEYS` key its value and ``"camera table (<model>): <source>"`` when the
    named camera set it (``sensor.model_figures``), ``"keep_field_of_view: ..."`` for a pitch
    derived from the camera's size, ``"default"`` for the generic default of a sensor that names
    no camera, else ``"scene"``."""
    import dataclasses

    defaults = {field.name: field.default for field in dataclasses.fields(sensor)}  # the section's own
    figures = {} if sensor.model == "ideal" else camera_figures(sensor.model)
    size = (sensor.width_px, sensor.height_px)
    view = (_pitch_keeping_view(figures, {"width_px": size[0], "height_px": size[1]}, size)
            if figures and getattr(sensor, "keep_field_of_view", False) else None)
    from_model = set(getattr(sensor, "model_figures", ()))
    record = {}
    for figure, key in SENSOR_FIGURE_KEYS.items():
        value = getattr(sensor, key)
        if view is not None and key == "pixel_pitch_um" and _same(value, view.value):
            origin = view.source
        elif key in from_model and _same(value, figures[figure].value):
            origin = f"camera table ({sensor.model}): {figures[figure].source}"
        elif not from_model and value == defaults[key]:
            origin = "default" + (" (generic: name sensor.model for the camera's own)" if figures else "")
        else:
            origin = "scene"
        record[key] = {"value": value, "from": origin}
    return record


def _same(a: float, b: float) -> bool:
    return abs(float(a) - float(b)) <= 1e-9 * max(abs(float(b)), 1e-300)
