"""Lens prescriptions as files: the bundled designs (:data:`PRESCRIPTION_NAMES`,
``spectral_cam/data/lenses``, their format in the README there) and users' CSV files in the same
format, read into a :class:`~spectral_cam.optics.sequential_lens.Prescription` with their rows
checked, blank clear apertures derived from the stated pupil and field, and a stop closed to a
scene's f-number (:func:`load_prescription`); a lens's focal length and f-number computed once
per file version for scene validation (:func:`focal_length_and_f_number`).

The lens itself (paraxial optics, real rays) is :mod:`spectral_cam.optics.sequential_lens`, its
surfaces :mod:`spectral_cam.optics.surfaces`; both are importable from here as well.

References
----------
.. [1] Smith, W. J. (2008). Modern Optical Engineering, 4th ed., §6.2 (stops, pupils,
   f-number); Zemax/CODE V-style surface tables.
"""

from __future__ import annotations

import csv
import functools
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from .glass import glass as catalogue_glass
# the lens and its surfaces, importable from here as before (render/prescription_lens.py imports
# Prescription and sag_and_slope from this module)
from .sequential_lens import Prescription
from .surfaces import AIR, ModelGlass, Surface, asphere_sag, sag_and_slope  # noqa: F401

__all__ = ["Surface", "Prescription", "load_prescription", "PRESCRIPTION_NAMES", "ModelGlass", "sag_and_slope",
           "focal_length_and_f_number"]

FOLDER = Path(__file__).resolve().parent.parent / "data" / "lenses"
#: The bundled prescriptions (``lens.prescription``).
PRESCRIPTION_NAMES = tuple(sorted(p.stem for p in FOLDER.glob("*.csv")))


# ----------------------------------------------------------------------------- files
def _header_number(path: Path, info: dict, key: str, scale: float) -> float | None:
    """A number from a prescription's header (``# key: value``), None when absent; a value that
    is no positive number is refused naming the line (issue 25 #12: it raised ValueError)."""
    if key not in info:
        return None
    try:
        value = float(info[key])
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise ConfigError(f"lens prescription {path}: header line '# {key}: {info[key]}' needs a positive number")
    return value * scale


def _header(lines: list[str]) -> dict:
    info = {"title": lines[0].lstrip("# ").strip() if lines else ""}
    for line in lines:
        text = line.lstrip("# ").strip()
        for key in ("source", "stated_focal_length_mm", "stated_f_number", "entrance_pupil_diameter_mm",
                    "half_field_deg"):
            if text.startswith(key + ":"):
                info[key] = text.split(":", 1)[1].strip()
    return info


#: Margin added to the traced heights when a prescription's clear apertures are derived.
APERTURE_MARGIN = 1.01


def _clear_apertures(path: Path, surfaces: list[Surface], info: dict) -> list[Surface]:
    """Semi-diameters for a prescription that gives none, from its entrance pupil and half field
    (header lines ``entrance_pupil_diameter_mm`` and ``half_field_deg``): the stop sized so the
    paraxial entrance pupil has that diameter, every other surface just large enough (× 1.01) for
    every ray of the axial and full-field bundles filling that pupil — a lens without vignetting
    to its stated field."""
    try:
        pupil = float(info["entrance_pupil_diameter_mm"]) * 1e-3 / 2
        field = float(info["half_field_deg"])
    except KeyError:
        raise ConfigError(f"lens prescription {path}: blank semi-diameters need the header lines "
                          "'# entrance_pupil_diameter_mm: D' and '# half_field_deg: θ' to derive them") from None
    wide = [replace(s, semi_diameter_m=1.0) for s in surfaces]  # 1 m: nothing clips yet
    draft = Prescription(path.stem, "", "", tuple(wide))
    stop = draft.stop_index()
    _, unit_pupil = draft.entrance_pupil()
    wide[stop] = replace(wide[stop], semi_diameter_m=pupil / unit_pupil * wide[stop].semi_diameter_m)
    draft = Prescription(path.stem, "", "", tuple(wide))
    pupil_z, _ = draft.entrance_pupil()
    axis = np.linspace(-pupil, pupil, 41)
    gx, gy = (a.ravel() for a in np.meshgrid(axis, axis))
    keep = gx * gx + gy * gy <= pupil * pupil
    rim = np.linspace(0.0, 2 * np.pi, 721)[:-1]  # the pupil's edge itself, where rays reach farthest
    px, py = np.concatenate([gx[keep], pupil * np.cos(rim)]), np.concatenate([gy[keep], pupil * np.sin(rim)])
    reach = np.zeros(len(wide))
    for angle in (0.0, field, -field):
        tilt = np.radians(angle)
        direction = np.tile([0.0, np.sin(tilt), np.cos(tilt)], (len(px), 1))
        origins = np.stack([px, py, np.full(len(px), pupil_z)], axis=1) - direction * (pupil_z + 1.0)
        heights: list = []
        draft.trace(origins, direction, heights=heights)
        reach = np.maximum(reach, [h.max() for h in heights])
    return [s if i == stop else replace(s, semi_diameter_m=float(reach[i]) * APERTURE_MARGIN)
            for i, s in enumerate(wide)]


def _prescription_path(name: str) -> Path:
    path = Path(name) if str(name).lower().endswith(".csv") else FOLDER / f"{name}.csv"
    if not path.is_file():
        raise ConfigError(f"lens.prescription = {name!r}: no such prescription; bundled: "
                          f"{', '.join(PRESCRIPTION_NAMES)}, or a CSV path (spectral_cam/data/lenses/README.md)")
    return path


def focal_length_and_f_number(name: str) -> tuple[float, float]:
    """(paraxial focal length in m, traced f-number) of a prescription, computed once per file
    version: scene validation asks for them every time a scene is built or changed."""
    path = _prescription_path(name)
    return _optics(str(path.resolve()), path.stat().st_mtime_ns)


@functools.lru_cache(maxsize=32)
def _optics(path: str, _version: int) -> tuple[float, float]:
    design = load_prescription(path)
    with np.errstate(all="ignore"):
        focal, f_number = design.focal_length_m(), design.traced_f_number()
    if not (math.isfinite(focal) and focal > 0):  # issue 25 #13: it said "lens.focal_length_mm = …"
        raise ConfigError(f"lens prescription {path}: its paraxial focal length is {focal * 1e3:.4g} mm: "
                          "a lens forming a real image needs a positive, finite one (a diverging or afocal "
                          "design cannot be a camera lens)")
    if not (math.isfinite(f_number) and f_number > 0):
        raise ConfigError(f"lens prescription {path}: no ray of the axial bundle passes every surface (traced "
                          "f-number not finite): check the semi_diameter_mm and thickness_mm columns")
    return focal, f_number


@functools.lru_cache(maxsize=32)
def _stopped(path: str, _version: int, f_number: float) -> Prescription:
    return load_prescription(path).stopped_down(f_number)


def _check_rows(path: Path, surfaces: list) -> None:
    """Each surface's numbers where they can mean something, refused naming the row and the column
    (issue 25 #13: a negative thickness, an infinite semi-diameter, nd = 0 or a NaN radius surfaced as
    an f-number or a focal length the user never set)."""
    for row, s in enumerate(surfaces, start=1):
        problems = []
        if math.isnan(s.radius_m):
            problems.append(f"radius_mm = {s.radius_m * 1e3:g} (give a curvature radius, or 0 for a plane)")
        if not math.isfinite(s.thickness_m) or s.thickness_m < 0:
            problems.append(f"thickness_mm = {s.thickness_m * 1e3:g} (the distance to the next surface: >= 0)")
        index = getattr(s.medium, "nd", None)
        if index is not None and not (math.isfinite(index) and index >= 1.0):
            problems.append(f"nd = {index:g} (a refractive index >= 1)")
        if not math.isnan(s.semi_diameter_m) and not (math.isfinite(s.semi_diameter_m) and s.semi_diameter_m > 0):
            problems.append(f"semi_diameter_mm = {s.semi_diameter_m * 1e3:g} (a positive, finite clear radius)")
        if problems:
            raise ConfigError(f"lens prescription {path}, surface {row}: " + "; ".join(problems))


def _surface(row: dict) -> Surface:
    """One row of a prescription table (millimetres; asphere coefficients ``a4`` … ``a10`` in
    mm⁻³ …) as a :class:`Surface` in metres; a blank ``semi_diameter_mm`` is NaN (derived later).
    The ``glass`` cell names a catalogue glass, or ``STOP``; else ``nd`` and ``vd`` model one."""
    mm = 1e-3
    name_cell = (row.get("glass") or "").strip()
    stop = name_cell.upper() == "STOP"
    if name_cell and not stop:
        medium = catalogue_glass(name_cell)
    else:
        vd = (row.get("vd") or "").strip()
        medium = ModelGlass(float(row["nd"]), float(vd) if vd else None)
    conic = float(row.get("conic") or 0.0)
    aspheric = tuple(float(row.get(f"a{2 * k}") or 0.0) * 1e3 ** (2 * k - 1) for k in (2, 3, 4, 5))
    semi = (row.get("semi_diameter_mm") or "").strip()
    return Surface(float(row["radius_mm"]) * mm, float(row["thickness_mm"]) * mm, medium,
                   float(semi) * mm if semi else math.nan, stop, conic, aspheric if any(aspheric) else ())


def load_prescription(name: str, *, f_number: float | None = None) -> Prescription:
    """A bundled prescription (:data:`PRESCRIPTION_NAMES`) or a CSV file in the same format
    (``spectral_cam/data/lenses/README.md``), with its stop closed to ``f_number`` when given
    (:meth:`Prescription.stopped_down`; ``lens.f_number``, computed once per file version).

    Raises
    ------
    ConfigError
        For an unknown name, an unreadable table, a table without a stop or with a
        non-positive semi-diameter, or an ``f_number`` faster than the design's.
    """
    if f_number is not None:
        path = _prescription_path(name)
        return _stopped(str(path.resolve()), path.stat().st_mtime_ns, float(f_number))
    path = _prescription_path(name)
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError as exc:  # issue 25 #12
        raise ConfigError(f"lens prescription {path}: not UTF-8 text ({exc.reason} at byte {exc.start}); save the "
                          "CSV as UTF-8") from None
    comments = [line for line in lines if line.startswith("#")]
    body = [line for line in lines if line.strip() and not line.startswith("#")]
    try:
        surfaces = [_surface(row) for row in csv.DictReader(body)]
    except (KeyError, ValueError, TypeError) as exc:
        raise ConfigError(f"lens prescription {path}: cannot read its rows ({exc}); columns: radius_mm, "
                          "thickness_mm, nd, vd, glass, semi_diameter_mm") from None
    _check_rows(path, surfaces)
    info = _header(comments)
    if any(math.isnan(s.semi_diameter_m) for s in surfaces):
        surfaces = _clear_apertures(path, surfaces, info)
    if not surfaces or sum(s.stop for s in surfaces) != 1 or any(s.semi_diameter_m <= 0 for s in surfaces):
        raise ConfigError(f"lens prescription {path}: needs surfaces with positive semi-diameters and exactly one "
                          "STOP row")
    focal = _header_number(path, info, "stated_focal_length_mm", 1e-3)
    f_number = _header_number(path, info, "stated_f_number", 1.0)
    return Prescription(path.stem, info["title"], info.get("source", str(path)), tuple(surfaces), focal, f_number)

