"""Measured surface spectra by set name, to put in front of the sensor (charts, dataset presets,
validation): the ColorChecker, 190 rawtoaces training spectra, 99 CIE 2017 samples, the CIE 13.3
and NIST CQS samples, USGS leaves and soils (``spectral_cam/data/usgs_splib07``), or a CSV table.

References
----------
.. [1] CIE 224:2017 (colour fidelity samples); CIE 13.3-1995 (test colour samples); Davis, W.,
   & Ohno, Y. (2010), Optical Engineering 49(3) (NIST CQS 9.0); AMPAS rawtoaces training
   data; Pascale, D. (2006), BabelColor ColorChecker averages.
.. [2] Kokaly, R. F., et al. (2017). USGS Spectral Library Version 7. U.S. Geological Survey
   Data Series 1035, doi:10.3133/ds1035.
"""

from __future__ import annotations

import csv
import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from . import spectra
from .errors import ConfigError

__all__ = ["REFLECTANCE_SETS", "ReflectanceSet", "reflectance_set"]


@dataclass(frozen=True)
class ReflectanceSet:
    """Named reflectance spectra (fractions, per wavelength in nm).

    Attributes
    ----------
    name : str
        Set name as the plan gives it.
    description : str
        Provenance.
    names : tuple of str
        Patch names.
    sds : tuple of spectral_cam.spectra.Spectrum
        The reflectances.
    """

    name: str
    description: str
    names: tuple[str, ...]
    sds: tuple

    def __len__(self) -> int:
        return len(self.sds)


def _colorchecker():
    patches = spectra.colorchecker_reflectances()
    return list(patches.keys()), list(patches.values())


def _shipped(key: str):
    """A set of colour-science's, shipped as package data (:func:`spectral_cam.cie.dataset`)."""
    from . import cie

    sds = [sd.copy() for sd in cie.dataset(key)]
    return [sd.name for sd in sds], sds


USGS_FOLDER = Path(__file__).parent / "data" / "usgs_splib07"


def _usgs(prefixes: tuple[str, ...]):
    """The USGS splib07 spectra whose files start with one of ``prefixes``, named by file."""
    names, sds = [], []
    for path in sorted(USGS_FOLDER.glob("*.csv")):
        if path.name.startswith(prefixes):
            data = np.loadtxt(path, delimiter=",", skiprows=1)
            names.append(path.stem)
            sds.append(spectra.Spectrum(data[:, 0], data[:, 1], path.stem))
    return names, sds


#: Built-in reflectance sets: name -> (description, loader).
REFLECTANCE_SETS: dict[str, tuple[str, Callable]] = {
    "colorchecker": ("24 ColorChecker patches, BabelColor average of 30 charts (Pascale 2006)", _colorchecker),
    "rawtoaces": ("190 training reflectances of AMPAS rawtoaces (colour-science)",
                  functools.partial(_shipped, "rawtoaces")),
    "cie2017": ("99 colour samples of the CIE 2017 colour fidelity index (CIE 224:2017)", functools.partial(_shipped, "cie2017")),
    "cri": ("14 test colour samples of CIE 13.3-1995 (colour rendering index)", functools.partial(_shipped, "cri")),
    "cqs": ("15 samples of the NIST colour quality scale 9.0 (Davis & Ohno 2010)", functools.partial(_shipped, "cqs")),
    "usgs_vegetation": ("4 green and 2 dry leaf/grass spectra, 350-1000 nm, USGS splib07 (Kokaly et al. 2017)",
                        functools.partial(_usgs, ("green_", "dry_"))),
    "usgs_soils": ("3 soils (dry sand, wet sand, dry playa mud), 350-1000 nm, USGS splib07 (Kokaly et al. 2017)",
                   functools.partial(_usgs, ("soil_",))),
    "usgs_wood": ("2 pine woods (a 2x4 beam, plywood), 350-1000 nm, USGS splib07 (Kokaly et al. 2017)",
                  functools.partial(_usgs, ("wood_",))),
    "usgs_stone": ("3 stones (limestone, weathered basalt, road concrete), 350-1000 nm, USGS splib07 "
                   "(Kokaly et al. 2017)", functools.partial(_usgs, ("stone_",))),
}


def _csv_set(path: Path) -> tuple[list[str], list]:
    """A reflectance table: ``wavelength_nm, name1, name2, ...`` with a header row."""
    if not path.is_file():
        raise ConfigError(f"reflectance set {str(path)!r}: file does not exist")
    try:
        with path.open(newline="", encoding="utf-8") as handle:
            rows = [row for row in csv.reader(handle) if row and not row[0].strip().startswith("#")]
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"reflectance set {path}: cannot read it as a text CSV ({exc})") from None
    if len(rows) < 3 or len(rows[0]) < 2:
        raise ConfigError(f"reflectance set {path}: need a header 'wavelength_nm,name1,...' and >= 2 rows")
    header = [cell.strip() for cell in rows[0]]
    try:
        body = np.array([[float(cell) for cell in row] for row in rows[1:]], dtype=float)
    except ValueError as exc:
        raise ConfigError(f"reflectance set {path}: non-numeric value ({exc})") from None
    if body.shape[1] != len(header) or not np.all(np.isfinite(body)):
        raise ConfigError(f"reflectance set {path}: every row needs {len(header)} finite numbers")
    body = body[np.argsort(body[:, 0])]
    values = body[:, 1:]
    if np.any(values < 0) or np.any(values > 2):
        raise ConfigError(f"reflectance set {path}: reflectances must be fractions in [0, 2] "
                          "(per cent? divide by 100)")
    names = header[1:]
    sds = [spectra.Spectrum(body[:, 0], values[:, i], name) for i, name in enumerate(names)]
    return names, sds


def reflectance_set(name: str, *, base_dir: str | Path = ".") -> ReflectanceSet:
    """Load a built-in reflectance set or a CSV table.

    Parameters
    ----------
    name : str
        One of :data:`REFLECTANCE_SETS` (``"colorchecker"``, ``"rawtoaces"``,
        ``"cie2017"``, ``"cri"``, ``"cqs"``) or the path of a CSV file whose header is
        ``wavelength_nm,<patch name>,...`` and whose values are reflectance fractions.
    base_dir : str or path-like
        Folder relative CSV paths are resolved against.

    Returns
    -------
    ReflectanceSet

    Raises
    ------
    ConfigError
        For an unknown name (listing the valid ones) or an unreadable CSV.

    References
    ----------
    .. [1] See the module references (CIE 224:2017, CIE 13.3-1995, Davis & Ohno 2010,
       rawtoaces, Pascale 2006).
    """
    text = str(name).strip()
    if text.lower().endswith(".csv") or "/" in text:
        path = Path(text).expanduser()
        if not path.is_absolute():
            path = Path(base_dir) / path
        names, sds = _csv_set(path)
        return ReflectanceSet(text, f"reflectances from {path.name}", tuple(names), tuple(sds))
    key = text.casefold()
    if key not in REFLECTANCE_SETS:
        raise ConfigError(f"unknown reflectance set {name!r}; valid: {', '.join(REFLECTANCE_SETS)} "
                          "or a CSV path (wavelength_nm, one column per patch)")
    return _built_in_set(key)


@functools.lru_cache(maxsize=None)
def _built_in_set(key: str) -> ReflectanceSet:
    """A built-in set, loaded once per process (colour-science parses the CIE 2017 table in
    0.5 s, and a render builds its scene up to three times: light, depth, radiance)."""
    description, loader = REFLECTANCE_SETS[key]
    names, sds = loader()
    return ReflectanceSet(key, description, tuple(str(n) for n in names), tuple(sds))
