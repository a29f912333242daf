"""The one ground truth for colour accuracy: XYZ of spectra under a light, and its linear sRGB.

One definition everywhere (docs/design.md, "Ground truth"): CIE 1931 2° XYZ of the spectral radiance under
the scene illuminant → Bradford chromatic adaptation from the illuminant's white to D65
→ linear sRGB, unclipped, exposure-matched on the white patch. Two routes:

- :func:`groundtruth_linear_srgb`: from a rendered :class:`~spectral_cam.image.SpectralImage`
  (band integrals of radiance; each band weighted by the CMFs averaged over the band);
- :func:`patch_linear_srgb`: analytically, from reflectance spectra and the illuminant's
  SPD (CIE 15's integration on a 1-nm grid, equal to colour-science's ``sd_to_XYZ_integration``:
  tests/test_cie.py), for the ColorChecker patches.

Both are scaled so the perfect reflecting diffuser under the illuminant has Y = 1 (so a
ColorChecker white patch has Y ≈ 0.9): the spectral route by matching its white patch to
the analytic one.

References
----------
.. [1] CIE 15:2004, Colorimetry, 3rd ed., §7 (tristimulus values), §9 (CIELAB).
.. [2] Lam, K. M. (1985). Metamerism and colour constancy. PhD thesis, University of
   Bradford; CIE 160:2004 (the Bradford chromatic adaptation transform).
.. [3] IEC 61966-2-1:1999, sRGB (XYZ → linear RGB matrix, D65 white).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from . import spectra
from .errors import ConfigError

__all__ = [
    "CMFS_NAME",
    "WHITE_PATCH",
    "band_cmfs",
    "spectral_to_xyz",
    "illuminant_white_xyz",
    "adapt_to_d65",
    "xyz_to_linear_srgb",
    "reflectance_xyz",
    "illuminant_sd",
    "reflectance_list",
    "white_patch_index",
    "patch_linear_srgb",
    "groundtruth_linear_srgb",
    "match_exposure",
]

CMFS_NAME = "CIE 1931 2 Degree Standard Observer"
#: Name of the ColorChecker's white patch (the exposure reference).
WHITE_PATCH = "white 9.5 (.05 D)"


def white_patch_index(names=None) -> int:
    """Index of the ColorChecker's white patch (:data:`WHITE_PATCH`) among patch names.

    Parameters
    ----------
    names : sequence of str, optional
        Patch names; default the 24 ColorChecker patches in chart order.

    Raises
    ------
    ConfigError
        If the white patch is not among the names.

    Examples
    --------
    >>> white_patch_index()
    18
    """
    names = list(spectra.colorchecker_reflectances()) if names is None else list(names)
    if WHITE_PATCH not in names:
        raise ConfigError(f"no ColorChecker white patch {WHITE_PATCH!r} among the patches")
    return names.index(WHITE_PATCH)
_GRID_NM = np.arange(360.0, 831.0, 1.0)


def _cmfs():
    from . import cie

    return cie.cmfs_1931()


def band_cmfs(band_edges_nm) -> np.ndarray:
    """CIE 1931 2° colour-matching functions averaged over each band.

    Parameters
    ----------
    band_edges_nm
        (B + 1,) increasing band edges, nm.

    Returns
    -------
    numpy.ndarray
        (B, 3) mean x̄, ȳ, z̄ over each band (trapezoid rule on a 0.1-nm grid, CMFs
        linearly interpolated from colour-science's 1-nm table, zero outside 360–830 nm).

    References
    ----------
    .. [1] CIE 15:2004, Table T.4 (CIE 1931 standard colorimetric observer).
    """
    edges = np.asarray(band_edges_nm, dtype=float)
    cmfs = _cmfs()
    wl = np.asarray(cmfs.wavelengths, dtype=float)
    values = np.asarray(cmfs.values, dtype=float)
    out = np.empty((len(edges) - 1, 3))
    for i, (lo, hi) in enumerate(zip(edges[:-1], edges[1:])):
        grid = np.linspace(lo, hi, max(int(round((hi - lo) / 0.1)), 2) + 1)
        for c in range(3):
            out[i, c] = np.trapezoid(np.interp(grid, wl, values[:, c], left=0.0, right=0.0), grid) / (hi - lo)
    return out


def spectral_to_xyz(image) -> np.ndarray:
    """CIE 1931 2° XYZ of a spectral radiance image (photometric scale: Y in cd·m⁻²).

    ``X = K_m Σ_b L_b · x̄_b`` with L_b the band integral of radiance (W·m⁻²·sr⁻¹),
    x̄_b the CMF averaged over band b and K_m = 683 lm/W.

    Parameters
    ----------
    image
        :class:`~spectral_cam.image.SpectralImage` (``.data`` (H, W, B) band integrals,
        ``.band_edges_nm``).

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float64 XYZ; Y is luminance in cd·m⁻².

    References
    ----------
    .. [1] CIE 15:2004, §7.1; K_m from CIE 18.2:1983 / SI (683 lm/W).
    """
    channels = getattr(image, "channels", None)
    if channels:  # a camera-film render carries the CMF channels themselves
        index = [list(channels).index(name) for name in ("X", "Y", "Z")]
        return np.asarray(image.data[..., index], dtype=np.float64) * spectra.K_M_LM_PER_W
    weights = band_cmfs(image.band_edges_nm) * spectra.K_M_LM_PER_W
    return np.asarray(image.data, dtype=np.float64) @ weights


def illuminant_sd(illuminant_spd):
    """An illuminant name, ``blackbody:<K>`` or CSV path as a :class:`~spectral_cam.spectrum.Spectrum`
    (a spectrum object, ours or colour-science's, passes through)."""
    return spectra.illuminant(illuminant_spd) if isinstance(illuminant_spd, str) else illuminant_spd


def reflectance_list(reflectances) -> list:
    """Reflectances as a list of spectra: None gives the 24 ColorChecker patches (chart
    order); a mapping gives its values; numbers and names go through
    :func:`spectral_cam.spectra.reflectance`."""
    if reflectances is None:
        return list(spectra.colorchecker_reflectances().values())
    if isinstance(reflectances, Mapping):
        return list(reflectances.values())
    return [spectra.reflectance(r) if isinstance(r, (str, int, float)) else r for r in reflectances]


def _xyz_of(rho: np.ndarray, power: np.ndarray) -> np.ndarray:
    """XYZ = Σ ρ·S·x̄ / Σ S·ȳ on the CMFs' 1-nm grid: CIE 15:2004's integration as colour-science's
    ``sd_to_XYZ_integration`` computes it on that grid (tests/test_cie.py compares the two)."""
    if not np.any(power > 0):
        raise ConfigError("the illuminant has no power in 360–830 nm")
    cmfs = spectra.sample(_cmfs(), _GRID_NM, outside=0.0)
    weighted = power[:, None] * cmfs
    return (np.asarray(rho, dtype=np.float64) @ weighted) / weighted[:, 1].sum()


def reflectance_xyz(illuminant_spd, reflectances=None) -> np.ndarray:
    """CIE 1931 2° XYZ of reflectances under an illuminant (perfect white: Y = 1).

    Parameters
    ----------
    illuminant_spd : str or Spectrum
        Illuminant name or SPD (zero outside its table).
    reflectances : mapping, sequence or None
        As in :func:`camera_responses`; default the 24 ColorChecker patches.

    Returns
    -------
    numpy.ndarray
        (N, 3) XYZ, by CIE 15's integration on the CMFs' 1-nm grid (360–830 nm; colour-science's
        ``sd_to_XYZ_integration`` gives the same); reflectances hold their end values outside
        their tables.

    References
    ----------
    .. [1] CIE 15:2004, Colorimetry, §7.1.
    """
    power = spectra.sample(illuminant_sd(illuminant_spd), _GRID_NM, outside=0.0)
    rho = np.stack([spectra.sample(sd, _GRID_NM) for sd in reflectance_list(reflectances)])
    return _xyz_of(rho, power)


def illuminant_white_xyz(illuminant_spd) -> np.ndarray:
    """XYZ of the perfect diffuser under an illuminant, Y = 1 (the illuminant's white).

    References
    ----------
    .. [1] CIE 15:2004, Colorimetry, §7.1.
    """
    return reflectance_xyz(illuminant_spd, [1.0])[0]


def adapt_to_d65(xyz: np.ndarray, white_xyz) -> np.ndarray:
    """Bradford (von Kries) chromatic adaptation from an illuminant's white to D65.

    Parameters
    ----------
    xyz
        (..., 3) XYZ under the illuminant.
    white_xyz
        (3,) XYZ of the illuminant's white (any scale).

    Returns
    -------
    numpy.ndarray
        (..., 3) corresponding XYZ under D65 (the sRGB white, x = 0.3127, y = 0.3290).

    References
    ----------
    .. [1] Lam (1985); CIE 160:2004. colour-science ``chromatic_adaptation(...,
       method="Von Kries", transform="Bradford")``.
    """
    from . import cie

    white = np.asarray(white_xyz, dtype=float)
    return np.asarray(xyz, dtype=float) @ cie.bradford_adaptation(white / white[1], cie.xyz_d65_white()).T


def xyz_to_linear_srgb(xyz: np.ndarray) -> np.ndarray:
    """XYZ (D65) → linear sRGB, unclipped (colour-science sRGB colourspace matrix).

    References
    ----------
    .. [1] IEC 61966-2-1:1999.
    """
    from . import cie

    return np.asarray(xyz, dtype=float) @ cie.XYZ_TO_SRGB.T


def patch_linear_srgb(illuminant_spd, reflectances=None) -> np.ndarray:
    """Analytic ground truth per patch: XYZ → Bradford to D65 → linear sRGB (unclipped).

    Parameters
    ----------
    illuminant_spd
        Illuminant name or spectrum (ours or colour-science's).
    reflectances
        As in :func:`reflectance_xyz`; default the 24 ColorChecker patches.

    Returns
    -------
    numpy.ndarray
        (N, 3) linear sRGB, perfect diffuser at Y = 1.

    References
    ----------
    .. [1] CIE 15:2004; Lam (1985); IEC 61966-2-1:1999.
    """
    xyz = reflectance_xyz(illuminant_spd, reflectances)
    return xyz_to_linear_srgb(adapt_to_d65(xyz, illuminant_white_xyz(illuminant_spd)))


def _luminance_weights() -> np.ndarray:
    """Y row of colour-science's sRGB → XYZ matrix (≈ 0.2126, 0.7152, 0.0722)."""
    from . import cie

    return cie.SRGB_TO_XYZ[1].copy()


def match_exposure(image: np.ndarray, reference: np.ndarray, region) -> np.ndarray:
    """Scale a linear RGB image so its mean luminance over a region equals the reference's.

    Parameters
    ----------
    image
        (H, W, 3) linear sRGB (or (N, 3) patch means with ``region`` an index).
    reference
        Same layout as ``image``.
    region
        Index into the leading axes (e.g. the (row slice, column slice) of the white
        patch's interior, or a patch index).

    Returns
    -------
    numpy.ndarray
        The scaled image (float64).

    References
    ----------
    .. [1] IEC 61966-2-1:1999 (luminance Y ≈ 0.2126 R + 0.7152 G + 0.0722 B).
    """
    weights = _luminance_weights()
    image = np.asarray(image, dtype=float)
    y_image = float(np.mean(image[region] @ weights))
    y_ref = float(np.mean(np.asarray(reference, dtype=float)[region] @ weights))
    if not y_image > 0:
        raise ValueError("the exposure reference region is black in the image")
    return image * (y_ref / y_image)


def groundtruth_linear_srgb(image, illuminant_spd, *, white_region=None, white_reflectance=None) -> np.ndarray:
    """The ideal colorimetric linear sRGB image of a spectral render.

    XYZ of the radiance (:func:`spectral_to_xyz`) → Bradford from the illuminant's white
    to D65 → linear sRGB, unclipped. With ``white_region`` the image is scaled so that
    region's Y equals the analytic Y of ``white_reflectance`` (default the ColorChecker
    white patch) under the illuminant, i.e. the perfect diffuser reads Y = 1; otherwise it
    stays in photometric units (Y in cd·m⁻²).

    Parameters
    ----------
    image
        :class:`~spectral_cam.image.SpectralImage`.
    illuminant_spd
        The scene illuminant (name or SPD).
    white_region
        (row slice, column slice) of a white reference, e.g. the white patch's interior.
    white_reflectance
        Reflectance SD of that reference; default the ColorChecker white patch.

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float64 linear sRGB.

    References
    ----------
    .. [1] CIE 15:2004; Lam (1985); IEC 61966-2-1:1999.
    """
    white = illuminant_white_xyz(illuminant_spd)
    rgb = xyz_to_linear_srgb(adapt_to_d65(spectral_to_xyz(image), white))
    if white_region is not None:
        if white_reflectance is None:
            white_reflectance = spectra.colorchecker_reflectances()[WHITE_PATCH]
        target = patch_linear_srgb(illuminant_spd, [white_reflectance])[0]
        weights = _luminance_weights()
        rgb = rgb * (float(target @ weights) / float(np.mean(rgb[white_region] @ weights)))
    return rgb
