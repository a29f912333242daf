"""Wavelength bands and the spectra a scene names: illuminants, reflectances, camera sensitivities,
filters.

Everything here is a plain function returning :class:`Spectrum` objects (tabulated
wavelengths and values, ``.to_colour()`` for colour-science), or NumPy arrays sampled on a band
grid. Wavelengths are in nm throughout.

Nothing here imports colour-science (0.5–1 s and ~77 MB per process): its datasets are package
data read by :mod:`spectral_cam.cie`. The ``validate_*`` functions check a name, number or CSV
the way the loaders would, without building a spectrum; colour-science's names are written
out for them (:data:`COLOUR_ILLUMINANT_KEYS`, :data:`COLOUR_LIGHT_SOURCE_KEYS`,
:data:`COLORCHECKER_PATCH_NAMES`, :data:`COLOUR_CAMERA_KEYS`); tests/test_spectra.py checks
them and the spectra against colour-science.

Sources
-------
- Illuminants and light sources: colour-science's datasets (CIE 15:2004 tables and others).
- ColorChecker reflectances: BabelColor average of 30 charts (colour-science
  ``SDS_COLOURCHECKERS["BabelColor Average"]``).
- Camera sensitivities: the 17 measured cameras shipped in ``spectral_cam/data/cameras``
  (pbrt-v4 / PhysLight data, see the README there) and colour-science's two NPL cameras; their
  sensors' published figures (full well, read noise, bit depth, pitch, size, base ISO) with a
  source each, in ``sensor_figures.csv`` there (:func:`camera_figures`). They live in
  :mod:`spectral_cam.cameras` and are importable from here.

References
----------
.. [1] CIE 15:2004, Colorimetry, 3rd edition.
.. [2] Pascale, D. (2006). RGB coordinates of the Macbeth ColorChecker. BabelColor.
.. [3] Langlands, A., & Fascione, L. (2020). PhysLight: An end-to-end pipeline for
   scene-referred lighting. DigiPro '20.
"""

from __future__ import annotations

import csv
import functools
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import ConfigError
from .spectrum import Spectrum, as_colour, interpolate
# the measured cameras, importable from here as before
from .cameras import (COLOUR_CAMERA_KEYS, FIGURES_FILE, SENSOR_FIGURE_KEYS, CameraFigure,  # noqa: F401
                      camera_figures, camera_names, camera_sensitivities, figure_record, validate_camera,
                      with_camera_figures)

__all__ = [
    "Spectrum",
    "as_colour",
    "BandGrid",
    "parse_bands",
    "illuminant",
    "illuminant_names",
    "validate_illuminant",
    "validate_reflectance",
    "validate_transmission",
    "validate_camera",
    "COLOUR_ILLUMINANT_KEYS",
    "COLOUR_LIGHT_SOURCE_KEYS",
    "COLORCHECKER_PATCH_NAMES",
    "absolute_irradiance",
    "reflectance",
    "colorchecker_reflectances",
    "camera_sensitivities",
    "camera_names",
    "CameraFigure",
    "camera_figures",
    "with_camera_figures",
    "figure_record",
    "SENSOR_FIGURE_KEYS",
    "transmission",
    "ir_cut_filter",
    "load_spectrum_csv",
    "sample",
    "band_integrals",
    "MITSUBA_RANGE_NM",
    "K_M_LM_PER_W",
]

#: Wavelength range Mitsuba 3's spectral variants sample (nm).
MITSUBA_RANGE_NM = (360.0, 830.0)
#: Most bands a render may ask for (one per 0.5 nm over Mitsuba's range).
MAX_BANDS = 941
#: The band grid ``render.bands = "auto"`` resolves to (``scene.SPECTRAL_BANDS_DEFAULT``; here so the sensor
#: reads it without importing the scene).
SPECTRAL_BANDS_DEFAULT = "400:700:10"
#: Maximum luminous efficacy of photopic vision (lm/W), CIE 15:2004.
K_M_LM_PER_W = 683.0
COLORCHECKER_SET = "BabelColor Average"


# ----------------------------------------------------------------------------- bands
@dataclass(frozen=True)
class BandGrid:
    """Contiguous wavelength bands given by their centres and edges (nm).

    ``edges_nm`` has ``len(centres_nm) + 1`` entries; band *i* covers
    ``[edges_nm[i], edges_nm[i + 1]]``.
    """

    centres_nm: tuple[float, ...]
    edges_nm: tuple[float, ...]

    @property
    def widths_nm(self) -> np.ndarray:
        return np.diff(np.asarray(self.edges_nm))

    def __len__(self) -> int:
        return len(self.centres_nm)


def parse_bands(spec: str) -> BandGrid:
    """Parse ``"start:stop:step"`` (band CENTRES in nm, each band ``step`` wide).

    ``"400:700:10"`` gives 31 bands centred on 400, 410, ..., 700 nm, each ±5 nm.

    Raises
    ------
    ConfigError
        If the string is malformed or the bands leave Mitsuba's 360–830 nm range.
    """
    match = re.fullmatch(r"\s*(\d+(?:\.\d+)?)\s*:\s*(\d+(?:\.\d+)?)\s*:\s*(\d+(?:\.\d+)?)\s*", str(spec))
    if not match:
        raise ConfigError(
            f"render.bands = {spec!r} is not valid: use 'start:stop:step' band centres in nm "
            "(e.g. '400:700:10') or 'camera'"
        )
    start, stop, step = (float(g) for g in match.groups())
    if step <= 0 or stop < start:
        raise ConfigError(f"render.bands = {spec!r}: need step > 0 and stop >= start")
    steps = (stop - start) / step
    if abs(steps - round(steps)) > 1e-6:
        raise ConfigError(f"render.bands = {spec!r}: stop − start must be a whole number of steps "
                          f"(e.g. '{start:g}:{start + step * int(steps):g}:{step:g}')")
    count = int(round(steps)) + 1
    if count > MAX_BANDS:
        raise ConfigError(f"render.bands = {spec!r} asks for {count} bands; at most {MAX_BANDS} "
                          "(use a larger step)")
    centres = start + step * np.arange(count)
    edges = np.concatenate([centres - step / 2, [centres[-1] + step / 2]])
    lo, hi = MITSUBA_RANGE_NM
    if edges[0] < lo or edges[-1] > hi:
        raise ConfigError(
            f"render.bands = {spec!r} spans {edges[0]:g}–{edges[-1]:g} nm; Mitsuba samples "
            f"{lo:g}–{hi:g} nm only"
        )
    return BandGrid(tuple(float(c) for c in centres), tuple(float(e) for e in edges))


# ----------------------------------------------------------------------------- CSV
def _looks_like_path(spec: str) -> bool:
    return spec.lower().endswith(".csv") or Path(spec).is_file()


def load_spectrum_csv(path: str | Path, *, maximum: float | None = None) -> Spectrum:
    """Read a two-column CSV ``wavelength_nm,value``.

    A header line is allowed before the data: a first line whose first cell is not a
    number. Refused with a message naming the file and the row: a data row that does not
    parse (a corrupt first row is not taken for a header), repeated wavelengths, fewer than
    two wavelengths, negative or non-finite values, values above ``maximum`` (a reflectance
    or transmission is at most 1), fields too long for a CSV, non-text files.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "ramp.csv"
    >>> _ = path.write_text("wavelength_nm,value\\n400,0.1\\n700,0.9\\n")
    >>> sd = load_spectrum_csv(path, maximum=1.0)
    >>> sd.wavelengths.tolist(), sd.values.tolist()
    ([400.0, 700.0], [0.1, 0.9])
    """
    path = Path(path)
    wavelengths, values = _read_spectrum_csv(path, maximum=maximum)
    return Spectrum(wavelengths, values, path.stem)


def _read_spectrum_csv(path: Path, *, maximum: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The checked (wavelengths_nm, values) of a spectrum CSV, sorted by wavelength, without
    colour-science (the checks and messages of :func:`load_spectrum_csv`)."""
    if not path.is_file():
        raise ConfigError(f"spectrum file {str(path)!r} does not exist")
    rows = []
    try:
        with path.open(newline="") as handle:
            for number, row in enumerate(csv.reader(handle), start=1):
                if not row or row[0].strip().startswith("#"):
                    continue
                try:
                    rows.append((float(row[0]), float(row[1])))
                except (ValueError, IndexError):
                    if rows or _is_number(row[0]):  # a header only before the data, and not numeric
                        raise ConfigError(f"{path}, line {number}: unreadable row {row!r}; need "
                                          "'wavelength_nm,value' numbers") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path} is not a text CSV file: {exc}") from None
    except csv.Error as exc:
        raise ConfigError(f"{path} is not a readable CSV file: {exc}") from None
    data = np.asarray(sorted(rows)).reshape(-1, 2)
    wavelengths = data[:, 0]
    if len(np.unique(wavelengths)) < 2:
        raise ConfigError(f"{path}: need at least two 'wavelength_nm,value' rows at different wavelengths")
    if np.any(np.diff(wavelengths) == 0):
        repeated = sorted(set(wavelengths[1:][np.diff(wavelengths) == 0]))
        raise ConfigError(f"{path}: wavelength(s) {', '.join(f'{w:g}' for w in repeated)} nm given twice; "
                          "give each wavelength once")
    if not np.all(np.isfinite(data)) or np.any(data[:, 1] < 0):
        raise ConfigError(f"{path}: values must be finite and non-negative")
    if maximum is not None and np.any(data[:, 1] > maximum):
        raise ConfigError(f"{path}: values must lie in [0, {maximum:g}] (largest {data[:, 1].max():g}; "
                          "per cent? divide by 100)")
    return wavelengths, data[:, 1]


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _prefixed_number(spec: str, prefix: str) -> float | None:
    """The number in ``"<prefix>:<number>"`` (prefix in any case), −1 where it is no number (out
    of every range, so refused with the form's message), None where ``spec`` has another form."""
    if not spec.strip().lower().startswith(prefix + ":"):
        return None
    try:
        return float(spec.split(":", 1)[1])
    except ValueError:
        return -1.0


# ----------------------------------------------------------------------------- illuminants
#: The keys of colour-science's ``SDS_ILLUMINANTS`` (CIE 15:2004 illuminants and others), written
#: out so that validating ``illuminant.spd`` does not import colour; tests/test_spectra.py checks
#: them against colour-science.
COLOUR_ILLUMINANT_KEYS = (
    "A", "B", "C", "D50", "D55", "D60", "D65", "D75", "E", "FL1", "FL2", "FL3", "FL4", "FL5", "FL6", "FL7",
    "FL8", "FL9", "FL10", "FL11", "FL12", "FL3.1", "FL3.2", "FL3.3", "FL3.4", "FL3.5", "FL3.6", "FL3.7",
    "FL3.8", "FL3.9", "FL3.10", "FL3.11", "FL3.12", "FL3.13", "FL3.14", "FL3.15", "HP1", "HP2", "HP3", "HP4",
    "HP5", "LED-B1", "LED-B2", "LED-B3", "LED-B4", "LED-B5", "LED-BH1", "LED-RGB1", "LED-V1", "LED-V2",
    "ID65", "ID50", "ISO 7589 Photographic Daylight", "ISO 7589 Sensitometric Daylight",
    "ISO 7589 Studio Tungsten", "ISO 7589 Sensitometric Studio Tungsten", "ISO 7589 Photoflood",
    "ISO 7589 Sensitometric Photoflood", "ISO 7589 Sensitometric Printer",
)
#: The keys of colour-science's ``SDS_LIGHT_SOURCES`` (measured lamps), written out and checked
#: as :data:`COLOUR_ILLUMINANT_KEYS`. 25 hold a "/": they are names, never paths.
COLOUR_LIGHT_SOURCE_KEYS = (
    "Natural", "Philips TL-84", "SA", "SC", "T8 Luxline Plus White", "T8 Polylux 3000", "T8 Polylux 4000",
    "Thorn Kolor-rite", "Cool White FL", "Daylight FL", "HPS", "Incandescent", "LPS", "Mercury",
    "Metal Halide", "Neodimium Incandescent", "Super HPS", "Triphosphor FL", "3-LED-1 (457/540/605)",
    "3-LED-2 (473/545/616)", "3-LED-2 Yellow", "3-LED-3 (465/546/614)", "3-LED-4 (455/547/623)",
    "4-LED No Yellow", "4-LED Yellow", "4-LED-1 (461/526/576/624)", "4-LED-2 (447/512/573/627)",
    "Luxeon WW 2880", "PHOS-1", "PHOS-2", "PHOS-3", "PHOS-4", "Phosphor LED YAG", "60 A/W (Soft White)",
    "C100S54 (HPS)", "C100S54C (HPS)", "F32T8/TL830 (Triphosphor)", "F32T8/TL835 (Triphosphor)",
    "F32T8/TL841 (Triphosphor)", "F32T8/TL850 (Triphosphor)", "F32T8/TL865/PLUS (Triphosphor)",
    "F34/CW/RS/EW (Cool White FL)", "F34T12/LW/RS/EW", "F34T12WW/RS/EW (Warm White FL)",
    "F40/C50 (Broadband FL)", "F40/C75 (Broadband FL)", "F40/CWX (Broadband FL)", "F40/DX (Broadband FL)",
    "F40/DXTP (Delux FL)", "F40/N (Natural FL)", "H38HT-100 (Mercury)", "H38JA-100/DX (Mercury DX)",
    "MHC100/U/MP/3K", "MHC100/U/MP/4K", "SDW-T 100W/LV (Super HPS)", "Kinoton 75P",
)
#: Blackbody temperatures ``illuminant.spd = "blackbody:<K>"`` accepts (K).
BLACKBODY_RANGE_K = (500.0, 50000.0)
#: Correlated colour temperatures ``illuminant.spd = "daylight:<K>"`` accepts (K): the CIE
#: daylight locus is defined from 4000 to 25 000 K (CIE 15:2004 §3.1).
DAYLIGHT_RANGE_K = (4000.0, 25000.0)
#: The ``"<form>:<K>"`` forms of ``illuminant.spd`` and the temperatures each accepts (K).
KELVIN_FORMS = {"blackbody": BLACKBODY_RANGE_K, "daylight": DAYLIGHT_RANGE_K}


@functools.lru_cache(maxsize=1)
def _illuminant_table() -> dict[str, Spectrum]:
    from . import cie

    table = {}
    for key in ("light_sources", "illuminants"):  # an illuminant wins over a light source of its name
        for sd in cie.dataset(key):
            table[sd.name] = sd
    return table


@functools.lru_cache(maxsize=1)
def _illuminant_names_by_fold() -> dict[str, str]:
    """casefolded name -> colour-science's name (illuminants win over light sources)."""
    return {name.casefold(): name for name in (*COLOUR_LIGHT_SOURCE_KEYS, *COLOUR_ILLUMINANT_KEYS)}


def illuminant_names() -> list[str]:
    """Names accepted by :func:`illuminant` (besides ``blackbody:<K>`` and CSV paths)."""
    return sorted(_illuminant_names_by_fold().values(), key=str.casefold)


def _resolve_illuminant(spec: str) -> tuple[str, object]:
    """("blackbody", K) | ("name", colour-science's name) | ("csv", path), checked, without
    colour-science."""
    spec = str(spec).strip()
    if spec == "auto":  # a preset's own light; an XML scene's is resolved from its emitters first
        return "name", "D65"
    for kind, (low, high) in KELVIN_FORMS.items():
        kelvin = _prefixed_number(spec, kind)
        if kelvin is None:
            continue
        if not low <= kelvin <= high:
            raise ConfigError(f"illuminant {spec!r}: use '{kind}:<K>' with {low:g} <= K <= {high:g}")
        return kind, kelvin
    by_fold = _illuminant_names_by_fold()
    if spec.casefold() in by_fold:  # before paths: names like "F40/DX (Broadband FL)" hold a "/"
        return "name", by_fold[spec.casefold()]
    if _looks_like_path(spec):
        return "csv", spec
    raise ConfigError(
        f"unknown illuminant {spec!r}; valid: 'blackbody:<K>', 'daylight:<K>', a CSV path, or one of "
        + ", ".join(illuminant_names())
    )


def validate_illuminant(spec: str) -> None:
    """Refuse an ``illuminant.spd`` that :func:`illuminant` would refuse, with the same
    message, without importing colour-science (a CSV is read and checked).

    Raises
    ------
    ConfigError
        An unknown name (the message lists the valid ones), a blackbody temperature outside
        500–50000 K, or a CSV that :func:`load_spectrum_csv` refuses.
    """
    kind, value = _resolve_illuminant(spec)
    if kind == "csv":
        _read_spectrum_csv(Path(value))


def illuminant(spec: str) -> Spectrum:
    """Relative spectral power distribution of a named illuminant.

    Parameters
    ----------
    spec
        A colour-science illuminant or light-source name (``"D65"``, ``"A"``, ``"FL11"``,
        ``"LED-B1"``, ...), ``"blackbody:<temperature in K>"``, ``"daylight:<CCT in K>"`` (the
        CIE daylight series at that correlated colour temperature, 4000–25 000 K) or the path of
        a CSV file.

    References
    ----------
    .. [1] CIE 15:2004, Colorimetry, 3rd ed., §3 (standard illuminants, the daylight series,
       Planck's law): :func:`spectral_cam.cie.daylight`, :func:`spectral_cam.cie.blackbody`.
    """
    kind, value = _resolve_illuminant(spec)
    return _ILLUMINANT_BUILDERS[kind](value)


def _blackbody(kelvin: float) -> Spectrum:
    from . import cie

    wavelengths = np.arange(MITSUBA_RANGE_NM[0], MITSUBA_RANGE_NM[1] + 1.0)
    return Spectrum(wavelengths, cie.blackbody(kelvin, wavelengths), f"blackbody:{kelvin:g}")


def _daylight(kelvin: float) -> Spectrum:
    from . import cie

    return cie.daylight(kelvin)


def _named_illuminant(name: str) -> Spectrum:
    table = _illuminant_table()
    if name not in table:  # the written-out names and the shipped tables disagree
        raise ConfigError(f"illuminant {name!r} is not in the shipped colour-science tables; valid here: "
                          "'blackbody:<K>', 'daylight:<K>', a CSV path, or one of " + ", ".join(sorted(table)))
    return table[name].copy()


#: Each kind of ``illuminant.spd`` (:func:`_resolve_illuminant`) → its spectrum from the value.
_ILLUMINANT_BUILDERS = {"blackbody": _blackbody, "daylight": _daylight, "csv": load_spectrum_csv,
                        "name": _named_illuminant}


def absolute_irradiance(spec: str, illuminance_lux: float) -> tuple[np.ndarray, np.ndarray]:
    """Spectral irradiance (W·m⁻²·nm⁻¹) on 1-nm steps over Mitsuba's range for a given
    illuminance.

    The relative SPD S(λ) is scaled by k so that ``K_m ∫ k S(λ) ȳ(λ) dλ = E_v``
    (CIE 15:2004 eq. for luminous quantities, ȳ = CIE 1931 2° observer, K_m = 683 lm/W).

    Returns
    -------
    wavelengths_nm, irradiance_w_m2_nm
    """
    from . import cie

    if not np.isfinite(illuminance_lux) or illuminance_lux <= 0:
        raise ConfigError(f"illuminant.illuminance_lux = {illuminance_lux!r}: must be > 0")
    wavelengths = np.arange(MITSUBA_RANGE_NM[0], MITSUBA_RANGE_NM[1] + 1.0)
    relative = sample(illuminant(spec), wavelengths, outside=0.0)
    ybar = sample(cie.cmfs_1931(), wavelengths, outside=0.0)[:, 1]
    luminous = K_M_LM_PER_W * np.sum(relative * ybar)  # 1-nm steps
    if luminous <= 0:
        raise ConfigError(f"illuminant {spec!r} has no visible power; cannot set its illuminance")
    return wavelengths, relative * (illuminance_lux / luminous)


# ----------------------------------------------------------------------------- reflectances
#: The 24 patches of colour-science's ``SDS_COLOURCHECKERS["BabelColor Average"]`` in chart
#: reading order (McCamy et al. 1976), written out so that validating a patch name does not
#: import colour; tests/test_spectra.py checks them against colour-science.
#: Names of the built-in reflectance sets (:data:`spectral_cam.reflectance_sets.REFLECTANCE_SETS`, which
#: loads them), here so that validating a scene loads none; tests/test_radiance_targets.py
#: keeps the two equal.
REFLECTANCE_SET_NAMES = ("colorchecker", "rawtoaces", "cie2017", "cri", "cqs", "usgs_vegetation", "usgs_soils",
                         "usgs_wood", "usgs_stone")

COLORCHECKER_PATCH_NAMES = (
    "dark skin", "light skin", "blue sky", "foliage", "blue flower", "bluish green", "orange",
    "purplish blue", "moderate red", "purple", "yellow green", "orange yellow", "blue", "green", "red",
    "yellow", "magenta", "cyan", "white 9.5 (.05 D)", "neutral 8 (.23 D)", "neutral 6.5 (.44 D)",
    "neutral 5 (.70 D)", "neutral 3.5 (1.05 D)", "black 2 (1.5 D)",
)


def colorchecker_reflectances() -> dict[str, Spectrum]:
    """The 24 ColorChecker patches (BabelColor average), in chart reading order."""
    from . import cie

    return {sd.name: sd.copy() for sd in cie.dataset("colorchecker")}


def _resolve_reflectance(spec: float | str) -> tuple[str, object]:
    """("flat", value) | ("patch", name) | ("csv", path), checked, without colour-science."""
    if isinstance(spec, (int, float)) and not isinstance(spec, bool):
        value = float(spec)
        if not 0.0 <= value <= 1.0:
            raise ConfigError(f"reflectance {value!r} must lie in [0, 1]")
        return "flat", value
    spec = str(spec)
    by_fold = {name.casefold(): name for name in COLORCHECKER_PATCH_NAMES}
    if spec.casefold() in by_fold:  # before paths, as for illuminant names
        return "patch", by_fold[spec.casefold()]
    if _looks_like_path(spec):
        return "csv", spec
    raise ConfigError(
        f"unknown reflectance {spec!r}; valid: a number in [0, 1], a CSV path, or a "
        f"ColorChecker patch name: {', '.join(COLORCHECKER_PATCH_NAMES)}"
    )


def validate_reflectance(spec: float | str) -> None:
    """Refuse a reflectance that :func:`reflectance` would refuse, with the same message,
    without importing colour-science (a CSV is read and checked, values at most 1).

    Raises
    ------
    ConfigError
        A number outside [0, 1], an unknown patch name (the message lists the 24), or a CSV
        that :func:`load_spectrum_csv` refuses with ``maximum=1``.
    """
    kind, value = _resolve_reflectance(spec)
    if kind == "csv":
        _read_spectrum_csv(Path(value), maximum=1.0)


def reflectance(spec: float | str) -> Spectrum:
    """A reflectance spectrum: a number in [0, 1] (flat), a ColorChecker patch name
    (``"dark skin"`` ... ``"black 2 (1.5 D)"``) or a CSV path."""
    kind, value = _resolve_reflectance(spec)
    return _REFLECTANCE_BUILDERS[kind](value)


def _flat(value: float) -> Spectrum:
    return Spectrum([360.0, 830.0], [value, value], f"flat {value:g}")


def _patch(name: str) -> Spectrum:
    return colorchecker_reflectances()[name]


#: Each kind of reflectance (:func:`_resolve_reflectance`) → its spectrum from the value.
_REFLECTANCE_BUILDERS = {"flat": _flat, "csv": functools.partial(load_spectrum_csv, maximum=1.0), "patch": _patch}


# ----------------------------------------------------------------------------- filters
def ir_cut_filter(cutoff_nm: float, *, width_nm: float = 8.0) -> Spectrum:
    """An idealised IR-cut (hot-mirror) filter: T(λ) = 1 / (1 + exp((λ − λ_c)/w)), 50 % at
    ``cutoff_nm``, falling from 90 % to 10 % over 4.4·w nm (typical camera filters cut at
    630–670 nm with a 20–40 nm slope)."""
    wavelengths = np.arange(MITSUBA_RANGE_NM[0], MITSUBA_RANGE_NM[1] + 1.0)
    values = 1.0 / (1.0 + np.exp((wavelengths - cutoff_nm) / width_nm))
    return Spectrum(wavelengths, values, f"ir_cut:{cutoff_nm:g}")


def _resolve_transmission(spec: float | str | None) -> tuple[str, object]:
    """("none", None) | ("ir_cut", nm) | ("flat", value) | ("csv", path), checked, without
    colour-science."""
    if spec is None or (isinstance(spec, (int, float)) and float(spec) == 1.0):
        return "none", None
    if isinstance(spec, str) and spec.strip().lower() in ("", "none", "1"):
        return "none", None
    cutoff = _prefixed_number(spec, "ir_cut") if isinstance(spec, str) else None
    if cutoff is not None:
        if not 500 <= cutoff <= 800:
            raise ConfigError(f"transmission {spec!r}: use 'ir_cut:<cut-off nm>' with 500 <= nm <= 800")
        return "ir_cut", cutoff
    if isinstance(spec, str) and not _looks_like_path(spec):
        raise ConfigError(f"unknown transmission {spec!r}; valid: a number in (0, 1], a CSV path, "
                          "or 'ir_cut:<cut-off nm>' (e.g. 'ir_cut:650')")
    if isinstance(spec, (int, float)) and not 0.0 < float(spec) <= 1.0:
        raise ConfigError(f"transmission {spec!r} must lie in (0, 1] (0 would let no light through)")
    if isinstance(spec, (int, float)):
        return "flat", spec
    return "csv", spec


def _check_transmission_values(spec, values: np.ndarray) -> None:
    if np.max(values) > 1.0 + 1e-9:
        raise ConfigError(f"transmission {spec!r} exceeds 1; give a fraction in [0, 1]")


def validate_transmission(spec: float | str | None) -> None:
    """Refuse a lens transmission or IR-cut filter that :func:`transmission` would refuse,
    with the same message, without importing colour-science (a CSV is read and checked).

    Raises
    ------
    ConfigError
        A number outside (0, 1], an ``ir_cut:<nm>`` outside 500–800 nm, an unknown name, or
        a CSV that is unreadable or exceeds 1.
    """
    kind, value = _resolve_transmission(spec)
    if kind == "csv":
        _check_transmission_values(spec, _read_spectrum_csv(Path(value))[1])


def transmission(spec: float | str | None) -> Spectrum | None:
    """A filter/lens transmission: ``None``/``1`` (none), a number in (0, 1], a CSV path, or
    ``"ir_cut:<nm>"`` (an idealised IR-cut filter, see :func:`ir_cut_filter`)."""
    kind, value = _resolve_transmission(spec)
    return _TRANSMISSION_BUILDERS[kind](value)


def _no_filter(_value) -> None:
    return None


def _transmission_csv(path) -> Spectrum:
    sd = load_spectrum_csv(path)
    _check_transmission_values(path, np.asarray(sd.values))
    return sd


#: Each kind of transmission (:func:`_resolve_transmission`) → its spectrum (None: no filter).
_TRANSMISSION_BUILDERS = {"none": _no_filter, "ir_cut": ir_cut_filter, "flat": reflectance,
                          "csv": _transmission_csv}


# ----------------------------------------------------------------------------- sampling
def sample(sd, wavelengths_nm, *, outside: float | None = None) -> np.ndarray:
    """Linearly interpolate a spectral distribution at given wavelengths.

    Outside the tabulated range the end values are held (``outside=None``) or replaced by
    ``outside`` (:func:`spectral_cam.spectrum.interpolate`); ``sd`` is our
    :class:`~spectral_cam.spectrum.Spectrum` or colour-science's.
    """
    return interpolate(sd.wavelengths, sd.values, wavelengths_nm, outside=outside)


def band_integrals(values_per_nm: np.ndarray, wavelengths_nm: np.ndarray, bands: BandGrid) -> np.ndarray:
    """Integrate a function tabulated on a fine grid over each band (trapezoid rule).

    Parameters
    ----------
    values_per_nm
        Values per nm (e.g. W·m⁻²·sr⁻¹·nm⁻¹), shape (..., n_wavelengths).
    wavelengths_nm
        Increasing sample wavelengths (nm); should be fine (≤ 1 nm) for accuracy.
    bands
        The bands to integrate over.

    Returns
    -------
    numpy.ndarray
        Shape (..., len(bands)), in the values' units times nm.
    """
    values_per_nm = np.asarray(values_per_nm, dtype=float)
    out = []
    for lo, hi in zip(bands.edges_nm[:-1], bands.edges_nm[1:]):
        grid = np.linspace(lo, hi, max(int(round((hi - lo) / 0.1)), 2) + 1)
        interp = np.apply_along_axis(lambda v: np.interp(grid, wavelengths_nm, v), -1, values_per_nm)
        out.append(np.trapezoid(interp, grid, axis=-1))
    return np.stack(out, axis=-1)
