"""Synthetic test targets and reflectance sets: what the studies, validation and benchmarks
put in front of the sensor without a render.

- reflectance sets (:func:`reflectance_set`, from :mod:`spectral_cam.reflectance_sets`): the
  ColorChecker, the 190 rawtoaces training spectra, the 99 CIE 2017 samples, the CIE 13.3 and
  NIST CQS samples, or a CSV;
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

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import spectra
from .colour_ground_truth import WHITE_PATCH, white_patch_index
from .errors import ConfigError
from .image import SpectralImage
from .presets import Patch
from .reflectance_sets import REFLECTANCE_SETS, ReflectanceSet, reflectance_set  # noqa: F401  (re-exported)
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
