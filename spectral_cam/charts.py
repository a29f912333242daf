"""Synthetic test targets and reflectance sets: what the studies, validation and benchmarks
put in front of the sensor without a render.

- reflectance sets (:func:`reflectance_set`): the ColorChecker, the 190 rawtoaces training
  spectra, the 99 CIE 2017 samples, the CIE 13.3 and NIST CQS samples, or a CSV;
- :func:`lambertian_radiance`: band radiance L_b = ∫_b ρ(λ)·E(λ)/π dλ of reflectances under
  an illuminant scaled to an illuminance;
- :func:`synthetic_chart`: a chart of flat patches of that radiance, with the patch
  positions and a white reference;
- :func:`narrow_band_flat`: a flat field of radiance in one band (EMVA 1288 measurements).

References
----------
.. [1] McCluney, W. R. (2014). Introduction to Radiometry and Photometry, 2nd ed., §1.6
   (Lambertian radiance L = ρE/π).
.. [2] CIE 15:2004 (illuminance from spectral irradiance, K_m = 683 lm/W).
.. [3] CIE 224:2017 (colour fidelity samples); CIE 13.3-1995 (test colour samples); Davis, W.,
   & Ohno, Y. (2010), Optical Engineering 49(3) (NIST CQS 9.0); AMPAS rawtoaces training
   data; Pascale, D. (2006), BabelColor ColorChecker averages.
.. [4] EMVA 1288 Release 4.0, §6 (flat fields of narrow-band light).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from . import spectra
from .colorimetry import WHITE_PATCH, white_patch_index
from .errors import ConfigError
from .image import SpectralImage
from .presets import Patch
from .scene import SPECTRAL_BANDS_DEFAULT

__all__ = ["REFLECTANCE_SETS", "ReflectanceSet", "reflectance_set", "Chart", "synthetic_chart",
           "lambertian_radiance", "narrow_band_flat", "uniform_image", "default_bands", "FRAME_REFLECTANCE"]

#: Reflectance of a chart's frame (about that of a real ColorChecker's black frame).
FRAME_REFLECTANCE = 0.03


def default_bands() -> spectra.BandGrid:
    """The default spectral band grid (``render.bands`` 400:700:10: 31 bands of 10 nm)."""
    return spectra.parse_bands(SPECTRAL_BANDS_DEFAULT)


def lambertian_radiance(illuminant, reflectances, *, illuminance_lux: float = 1000.0, bands=None) -> np.ndarray:
    """Band radiance of Lambertian reflectors facing the light: L_b = ∫_b ρ(λ)·E(λ)/π dλ.

    Parameters
    ----------
    illuminant : str
        Illuminant name, ``"blackbody:<K>"`` or CSV path (:func:`spectral_cam.spectra.illuminant`).
    reflectances : sequence
        Spectra (colour.SpectralDistribution) or flat reflectances (numbers). Spectra are
        interpolated linearly and hold their end values outside their tables (as the scene
        presets hand them to Mitsuba); negative values (round-off in some tables) are 0.
    illuminance_lux : float
        Illuminance on the reflectors, lx.
    bands : spectra.BandGrid or str, optional
        Band grid (default :func:`default_bands`).

    Returns
    -------
    numpy.ndarray
        (N, B) band integrals of radiance, W·m⁻²·sr⁻¹.

    References
    ----------
    .. [1] McCluney (2014), §1.6; CIE 15:2004.
    """
    grid = default_bands() if bands is None else (spectra.parse_bands(bands) if isinstance(bands, str) else bands)
    wavelengths, irradiance = spectra.absolute_irradiance(illuminant, illuminance_lux)
    rho = np.stack([np.full_like(wavelengths, float(r)) if np.ndim(r) == 0 and not hasattr(r, "values")
                    else np.maximum(spectra.sample(r, wavelengths), 0.0) for r in reflectances])
    return spectra.band_integrals(rho * irradiance / np.pi, wavelengths, grid)


def uniform_image(spectrum, shape: tuple[int, int], bands=None) -> SpectralImage:
    """A SpectralImage of ``shape`` (H, W) pixels all holding the band values ``spectrum``."""
    grid = default_bands() if bands is None else bands
    values = np.asarray(spectrum, dtype=np.float32)
    data = np.ascontiguousarray(np.broadcast_to(values, (*shape, len(values))))
    return SpectralImage(data, np.asarray(grid.centres_nm, float), np.asarray(grid.edges_nm, float))


def narrow_band_flat(shape: tuple[int, int], band_radiance: float, wavelength_nm: float = 550.0,
                     bands=None) -> SpectralImage:
    """A flat field whose only light is ``band_radiance`` (W·m⁻²·sr⁻¹) in the band nearest
    ``wavelength_nm``: monochromatic light as EMVA 1288 measures with.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §6 (flat fields of narrow-band light).
    """
    grid = default_bands() if bands is None else bands
    spectrum = np.zeros(len(grid), np.float32)
    spectrum[int(np.argmin(np.abs(np.asarray(grid.centres_nm) - wavelength_nm)))] = band_radiance
    return uniform_image(spectrum, shape, grid)


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
    sds : tuple of colour.SpectralDistribution
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


def _rawtoaces():
    import colour

    msds = colour.characterisation.read_training_data_rawtoaces_v1()
    sds = msds.to_sds()
    return [sd.name for sd in sds], sds


def _cie2017():
    from colour.quality import cfi2017

    msds = cfi2017.load_TCS_CIE2017(cfi2017.SPECTRAL_SHAPE_CIE2017)
    sds = msds.to_sds()
    return [sd.name for sd in sds], sds


def _named_mapping(mapping, key: str):
    table = mapping[key] if key in mapping else mapping  # colour-science < 0.4.5 had a flat table
    return list(table.keys()), [sd.copy() for sd in table.values()]


def _cri():
    import colour

    return _named_mapping(colour.quality.SDS_TCS, "CIE 1995")


def _cqs():
    import colour

    return _named_mapping(colour.quality.SDS_VS, "NIST CQS 9.0")


#: Built-in reflectance sets: name -> (description, loader).
REFLECTANCE_SETS: dict[str, tuple[str, Callable]] = {
    "colorchecker": ("24 ColorChecker patches, BabelColor average of 30 charts (Pascale 2006)", _colorchecker),
    "rawtoaces": ("190 training reflectances of AMPAS rawtoaces (colour-science)", _rawtoaces),
    "cie2017": ("99 colour samples of the CIE 2017 colour fidelity index (CIE 224:2017)", _cie2017),
    "cri": ("14 test colour samples of CIE 13.3-1995 (colour rendering index)", _cri),
    "cqs": ("15 samples of the NIST colour quality scale 9.0 (Davis & Ohno 2010)", _cqs),
}


def _csv_set(path: Path) -> tuple[list[str], list]:
    """A reflectance table: ``wavelength_nm, name1, name2, ...`` with a header row."""
    import colour

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
    sds = [colour.SpectralDistribution(dict(zip(body[:, 0], values[:, i])), name=name)
           for i, name in enumerate(names)]
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
    description, loader = REFLECTANCE_SETS[key]
    names, sds = loader()
    return ReflectanceSet(key, description, tuple(str(n) for n in names), tuple(sds))


# ============================================================================ the chart
@dataclass
class Chart:
    """A chart image and where its patches are.

    Attributes
    ----------
    radiance : SpectralImage
        (H, W, B) band integrals of radiance, W·m⁻²·sr⁻¹.
    patches : list of Patch
        Every patch (the set's first, then an appended white reference if any).
    n_set : int
        The first ``n_set`` patches are the set's (their statistics are reported).
    white_index : int
        Index (into ``patches``) of the white reference.
    sds : list
        Reflectance of every patch (for the ground truth).
    source : str
        ``"synthetic"`` or ``"render"``.
    """

    radiance: Any
    patches: list
    n_set: int
    white_index: int
    sds: list
    source: str


def _with_white_reference(refset: ReflectanceSet) -> tuple[list[str], list, int]:
    """Patch names and spectra with the white reference; its index."""
    names, sds = list(refset.names), list(refset.sds)
    if refset.name == "colorchecker" and WHITE_PATCH in names:
        return names, sds, white_patch_index(names)
    names.append(f"reference: {WHITE_PATCH}")
    sds.append(spectra.colorchecker_reflectances()[WHITE_PATCH])
    return names, sds, len(names) - 1


def _grid_columns(count: int) -> int:
    """Columns of a chart of ``count`` patches: 6 for a ColorChecker, else about 3:2."""
    if count <= 24:
        return min(count, 6)
    return int(math.ceil(math.sqrt(1.5 * count)))


def synthetic_chart(
    refset: ReflectanceSet,
    illuminant: str,
    *,
    illuminance_lux: float = 1000.0,
    bands: str = "400:700:10",
    patch_px: int = 16,
    gap_px: int = 4,
    margin_px: int = 0,
) -> Chart:
    """Radiance of flat Lambertian patches facing the camera under an illuminant.

    Each patch is a ``patch_px`` square of constant band radiance
    ``L_b = ∫_b ρ(λ)·E(λ)/π dλ`` (trapezoid rule on 0.1-nm steps of the 1-nm tables),
    E the illuminant's spectral irradiance scaled to ``illuminance_lux``; patches sit
    ``gap_px`` apart on a frame of reflectance 0.03. Reflectances are interpolated linearly
    and hold their end values outside their tables (as the scene presets hand them to
    Mitsuba); negative values (round-off in some tables) are set to 0.

    Parameters
    ----------
    refset : ReflectanceSet
        The patches (a white reference is appended unless it is the ColorChecker).
    illuminant : str
        Illuminant name, ``"blackbody:<K>"`` or CSV path (:func:`spectral_cam.spectra.illuminant`).
    illuminance_lux : float
        Illuminance on the chart, lx.
    bands : str
        Band centres ``"start:stop:step"`` in nm (each band ``step`` wide).
    patch_px, gap_px : int
        Patch size and spacing, pixels.
    margin_px : int
        Pixels of the chart's surround added on every side outside the frame (even: the
        CFA phase is kept), stated as the image's ``frame``: a sensor's crop margin, so the
        RAW's default crop is the chart frame and developers interpolate its edges from data.

    Returns
    -------
    Chart

    References
    ----------
    .. [1] McCluney, W. R. (2014). Introduction to Radiometry and Photometry, 2nd ed.,
       §1.6 (Lambertian radiance L = ρE/π).
    .. [2] CIE 15:2004 (illuminance from spectral irradiance, K_m = 683 lm/W).
    """

    if not (isinstance(patch_px, int) and patch_px >= 4):
        raise ConfigError(f"patch_px = {patch_px!r}: must be a whole number of pixels >= 4")
    if not (isinstance(gap_px, int) and gap_px >= 0):
        raise ConfigError(f"gap_px = {gap_px!r}: must be a whole number of pixels >= 0")
    if not (isinstance(margin_px, int) and margin_px >= 0 and margin_px % 2 == 0):
        raise ConfigError(f"margin_px = {margin_px!r}: must be an even whole number of pixels >= 0")
    grid = spectra.parse_bands(bands)
    names, sds, white = _with_white_reference(refset)
    columns = _grid_columns(len(sds))
    rows = int(math.ceil(len(sds) / columns))
    pitch = patch_px + gap_px
    width, height = columns * pitch + gap_px, rows * pitch + gap_px
    width, height = width + width % 2, height + height % 2  # whole Bayer tiles
    patch_radiance = lambertian_radiance(illuminant, sds, illuminance_lux=illuminance_lux, bands=grid)
    frame_radiance = lambertian_radiance(illuminant, [FRAME_REFLECTANCE], illuminance_lux=illuminance_lux,
                                         bands=grid)[0]
    data = np.empty((height, width, len(grid)), dtype=np.float32)
    data[:] = frame_radiance.astype(np.float32)
    patches = []
    for index, name in enumerate(names):
        row, column = divmod(index, columns)
        top, left = gap_px + row * pitch, gap_px + column * pitch
        data[top:top + patch_px, left:left + patch_px] = patch_radiance[index].astype(np.float32)
        patches.append(Patch(name, left + patch_px / 2, top + patch_px / 2, patch_px / 2, patch_px / 2))
    frame = None
    if margin_px:
        data = np.pad(data, ((margin_px, margin_px), (margin_px, margin_px), (0, 0)), mode="edge")
        frame = (margin_px, margin_px, height, width)
    image = SpectralImage(data, np.asarray(grid.centres_nm), np.asarray(grid.edges_nm),
                          meta={"chart": "synthetic", "illuminant": illuminant, "illuminance_lux": illuminance_lux},
                          frame=frame)
    return Chart(image, patches, len(refset), white, sds, "synthetic")
