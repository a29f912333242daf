"""CIE colorimetry without importing colour-science: its datasets as package data, and the
few formulas a render, an exposure and a develop need.

``import colour`` costs 0.5–1 s and ~77 MB (it loads pandas and scipy.interpolate) on every
run, twice what Mitsuba itself takes to render a small scene (docs/design.md, "Fixed cost"). The
arrays here are colour-science's own, written by ``tools/make_colour_tables.py`` into
``data/colour_science/tables.npz`` (provenance and licences in that folder's README); the
formulas are the textbook ones, each checked against colour-science's implementation in
tests/test_cie.py. Analyses that use more of colour-science (ΔE2000, the validation report,
the stress studies) still import it.

All spectra are :class:`~spectral_cam.spectra.Spectrum` objects on colour-science's own
wavelength grids; chromaticities are CIE 1931 2° unless named otherwise.

References
----------
.. [1] CIE 15:2004, Colorimetry, 3rd ed. (CMFs, standard illuminants, the daylight series).
.. [2] Mansencal, T., et al. (2024). Colour 0.4.x, colour-science.org (the datasets; BSD-3-Clause).
.. [3] Robertson, A. R. (1968). Computation of correlated color temperature and distribution
   temperature. JOSA 58(11), 1528–1535.
.. [4] Finlayson, G. D., Mackiewicz, M., & Hurlbert, A. (2015). Color correction using
   root-polynomial regression. IEEE TIP 24(5), 1460–1470.
.. [5] Lam, K. M. (1985). Metamerism and colour constancy. PhD thesis, University of Bradford.
"""

from __future__ import annotations

import functools
from importlib import resources

import numpy as np

__all__ = [
    "D50_WHITE_XYZ",
    "BRADFORD",
    "SRGB_TO_XYZ",
    "SRGB_WHITE_XY",
    "XYZ_TO_SRGB",
    "camera_curves",
    "bradford_adaptation",
    "blackbody",
    "cct_robertson1968",
    "cmfs_1931",
    "daylight",
    "dataset",
    "dataset_names",
    "illuminant_xy",
    "root_polynomial_terms",
    "xy_to_uv_1960",
    "xy_to_xyz",
    "xyz_d65_white",
    "xyz_to_xy",
]

#: Bradford cone-response matrix (Lam 1985; CIE 159:2004, non-linear part dropped).
BRADFORD = np.array([[0.8951, 0.2664, -0.1614],
                     [-0.7502, 1.7135, 0.0367],
                     [0.0389, -0.0685, 1.0296]])

#: sRGB white (CIE 1931 xy), IEC 61966-2-1:1999 Table 1.
SRGB_WHITE_XY = np.array([0.3127, 0.3290])
#: IEC 61966-2-1:1999 eq. (7) and its amendment's inverse, as the standard tabulates them
#: (4 decimals; the two are not exact inverses, and the standard, like colour-science, keeps both).
SRGB_TO_XYZ = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]])
XYZ_TO_SRGB = np.array([[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]])

#: Radiation constants of Planck's law: c1 = 2πhc² (CODATA 2018, W·m²; colour-science truncates
#: it to 3.741771e-16, a constant factor 2.3e-7 that no relative SPD sees) and c2 = 1.4388e-2 m·K
#: (ITS-90, as CIE 15:2004 §3.1 prescribes).
PLANCK_C1_W_M2, PLANCK_C2_M_K = 3.741771852e-16, 1.4388e-2


@functools.lru_cache(maxsize=1)
def _tables() -> dict[str, np.ndarray]:
    path = resources.files("spectral_cam") / "data" / "colour_science" / "tables.npz"
    with path.open("rb") as handle, np.load(handle, allow_pickle=False) as npz:
        return {key: npz[key] for key in npz.files}


def dataset_names(key: str) -> tuple[str, ...]:
    """The spectra's names of a shipped set (``"illuminants"``, ``"light_sources"``,
    ``"colorchecker"``, ``"rawtoaces"``, ``"cie2017"``, ``"cri"``, ``"cqs"``), in
    colour-science's order."""
    return tuple(str(n) for n in _tables()[f"{key}__names"])


@functools.lru_cache(maxsize=None)
def dataset(key: str) -> tuple:
    """The spectra of a shipped set as :class:`~spectral_cam.spectra.Spectrum` objects, in
    colour-science's order (see :func:`dataset_names`)."""
    from .spectrum import Spectrum

    tables = _tables()
    names = dataset_names(key)
    if f"{key}__values" in tables:
        wavelengths, values = tables[f"{key}__wavelengths"], tables[f"{key}__values"]
        return tuple(Spectrum(wavelengths, values[i], name) for i, name in enumerate(names))
    return tuple(Spectrum(tables[f"{key}__{i}__wavelengths"], tables[f"{key}__{i}__values"], name)
                 for i, name in enumerate(names))


def camera_curves(slug: str):
    """colour-science's measured camera sensitivities (``"nikon_5100"``, ``"sigma_sdmerill"``) as
    a three-channel :class:`~spectral_cam.spectra.Spectrum` (labels r, g, b)."""
    from .spectrum import Spectrum

    tables = _tables()
    return Spectrum(tables[f"camera__{slug}__wavelengths"], tables[f"camera__{slug}__values"], slug,
                    labels=("r", "g", "b"))


@functools.lru_cache(maxsize=1)
def cmfs_1931():
    """The CIE 1931 2° colour-matching functions x̄, ȳ, z̄ (360–830 nm, 1-nm steps) as a
    three-channel :class:`~spectral_cam.spectra.Spectrum`.

    References
    ----------
    .. [1] CIE 15:2004, Table T.4.
    """
    from .spectrum import Spectrum

    tables = _tables()
    return Spectrum(tables["cmfs_1931__wavelengths"], tables["cmfs_1931__values"],
                    "CIE 1931 2 Degree Standard Observer", labels=("x_bar", "y_bar", "z_bar"))


def illuminant_xy(name: str) -> np.ndarray:
    """CIE 1931 2° chromaticity of a named illuminant as CIE 15:2004 tabulates it
    (colour-science's ``CCS_ILLUMINANTS``), e.g. D65 = (0.31270, 0.32900)."""
    tables = _tables()
    names = [str(n) for n in tables["illuminant_xy__names"]]
    return np.array(tables["illuminant_xy__values"][names.index(name)])


def xy_to_xyz(xy) -> np.ndarray:
    """CIE xy → XYZ at Y = 1 (works on (..., 2) arrays)."""
    xy = np.asarray(xy, dtype=np.float64)
    x, y = xy[..., 0], xy[..., 1]
    return np.stack([x / y, np.ones_like(x), (1.0 - x - y) / y], axis=-1)


#: The PCS white of ICC profiles and DNG forward matrices: CIE D50, Y = 1 (ICC.1:2010 §7.2.16).
D50_WHITE_XYZ = np.array([0.9642, 1.0, 0.8249])


def xyz_d65_white() -> np.ndarray:
    """CIE XYZ of the sRGB (D65) white point, Y = 1.

    References
    ----------
    .. [1] IEC 61966-2-1:1999 (white point x = 0.3127, y = 0.3290).
    """
    return xy_to_xyz(SRGB_WHITE_XY)


def xyz_to_xy(xyz) -> np.ndarray:
    """CIE XYZ → xy chromaticity (works on (..., 3) arrays)."""
    xyz = np.asarray(xyz, dtype=np.float64)
    return xyz[..., :2] / xyz.sum(axis=-1, keepdims=True)


def xy_to_uv_1960(xy) -> np.ndarray:
    """CIE 1931 xy → CIE 1960 UCS uv: u = 4x/(−2x + 12y + 3), v = 6y/(−2x + 12y + 3)."""
    xy = np.asarray(xy, dtype=np.float64)
    x, y = xy[..., 0], xy[..., 1]
    denominator = -2.0 * x + 12.0 * y + 3.0
    return np.stack([4.0 * x / denominator, 6.0 * y / denominator], axis=-1)


def bradford_adaptation(xyz_source_white, xyz_target_white) -> np.ndarray:
    """(3, 3) von Kries adaptation in Bradford cone space from one white to another (colour-
    science's ``matrix_chromatic_adaptation_VonKries(..., transform="Bradford")``).

    References
    ----------
    .. [1] Lam (1985); CIE 159:2004.
    """
    source = BRADFORD @ np.asarray(xyz_source_white, dtype=np.float64)
    target = BRADFORD @ np.asarray(xyz_target_white, dtype=np.float64)
    return np.linalg.inv(BRADFORD) @ np.diag(target / source) @ BRADFORD


def cct_robertson1968(uv) -> tuple[float, float]:
    """Correlated colour temperature (K) and Duv of a CIE 1960 uv chromaticity by Robertson's
    isotemperature lines (31 lines from 10⁶/K = 0 to 600), interpolated between the two
    lines the point lies between; Duv is signed as colour-science's (positive above the
    Planckian locus).

    References
    ----------
    .. [1] Robertson (1968), JOSA 58(11), 1528–1535; Wyszecki & Stiles (2000), Color Science,
       2nd ed., §3.11 (the table).
    """
    u, v = (float(c) for c in np.asarray(uv, dtype=np.float64).reshape(2))
    reciprocal, u_line, v_line, slope = _tables()["robertson1968"].T  # 10⁶/K, u, v, slope per line
    length = np.hypot(1.0, slope)
    du, dv = 1.0 / length, slope / length  # unit direction of each isotemperature line
    distance = -(u - u_line) * dv + (v - v_line) * du  # signed distance of the point from each line
    crossed = np.flatnonzero(distance[1:] <= 0.0)
    i = int(crossed[0]) + 1 if crossed.size else len(reciprocal) - 1  # the first line past the point
    current = -min(distance[i], 0.0)
    f = 0.0 if i == 1 else current / (distance[i - 1] + current)
    cct = 1.0e6 / (reciprocal[i - 1] * f + reciprocal[i] * (1.0 - f))
    direction = np.array([du[i] * (1.0 - f) + du[i - 1] * f, dv[i] * (1.0 - f) + dv[i - 1] * f])
    direction /= np.hypot(*direction)
    offset = np.array([u - (u_line[i - 1] * f + u_line[i] * (1.0 - f)), v - (v_line[i - 1] * f + v_line[i] * (1.0 - f))])
    return float(cct), float(-offset @ direction)


def blackbody(temperature_k: float, wavelengths_nm) -> np.ndarray:
    """Spectral radiance of a blackbody by Planck's law, W·sr⁻¹·m⁻²·nm⁻¹ (n = 1: colour-
    science's ``sd_blackbody``).

    References
    ----------
    .. [1] CIE 15:2004, §3.1 (Planck's law with c2 = 1.4388·10⁻² m·K).
    """
    metres = np.asarray(wavelengths_nm, dtype=np.float64) * 1e-9
    return PLANCK_C1_W_M2 / (np.pi * metres ** 5) / np.expm1(PLANCK_C2_M_K / (metres * temperature_k)) * 1e-9


def daylight(cct_k: float):
    """The CIE daylight illuminant of a correlated colour temperature (4000–25 000 K) on 1-nm
    steps over 360–830 nm: S = S0 + M1·S1 + M2·S2 on the basis's 5-nm grid, linearly
    interpolated, with the chromaticity of the daylight locus (the nominal temperature scaled by
    1.4388/1.4380, M1 and M2 rounded to three decimals, as CIE 15:2004 and colour-science compute
    them).

    References
    ----------
    .. [1] CIE 15:2004, §3.1, eqs. 3.3–3.6 and Table T.2.
    """
    from .spectrum import Spectrum

    t = cct_k * 1.4388 / 1.4380
    if t <= 7000.0:
        x = -4.607e9 / t ** 3 + 2.9678e6 / t ** 2 + 0.09911e3 / t + 0.244063
    else:
        x = -2.0064e9 / t ** 3 + 1.9018e6 / t ** 2 + 0.24748e3 / t + 0.23704
    y = -3.0 * x ** 2 + 2.87 * x - 0.275
    m = 0.0241 + 0.2562 * x - 0.7341 * y
    m1 = np.around((-1.3515 - 1.7703 * x + 5.9114 * y) / m, 3)
    m2 = np.around((0.0300 - 31.4424 * x + 30.0717 * y) / m, 3)
    tables = _tables()
    basis = tables["daylight_basis__values"]  # S0, S1, S2 on their 5-nm grid
    wavelengths = np.arange(360.0, 831.0)
    # linear interpolation of the 5-nm values, as CIE 15:2004 §3.1 prescribes (colour-science too)
    values = np.interp(wavelengths, tables["daylight_basis__wavelengths"],
                       basis[:, 0] + m1 * basis[:, 1] + m2 * basis[:, 2])
    return Spectrum(wavelengths, values, f"daylight:{cct_k:g}")


def root_polynomial_terms(rgb, degree: int) -> np.ndarray:
    """The root-polynomial expansion of (..., 3) RGB of ``degree`` 1–4: 3, 6, 13 or 22 terms,
    each of degree one in the RGB scale (so exposure invariant), in colour-science's order
    (``polynomial_expansion_Finlayson2015(..., root_polynomial_expansion=True)``).

    References
    ----------
    .. [1] Finlayson, Mackiewicz & Hurlbert (2015), IEEE TIP 24(5), Table 1.
    """
    rgb = np.asarray(rgb, dtype=np.float64)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]

    def spow(value, exponent):  # sign-preserving power (noisy RGB can be negative)
        return np.sign(value) * np.abs(value) ** exponent

    terms = [r, g, b]
    if degree >= 2:
        terms += [spow(r * g, 1 / 2), spow(g * b, 1 / 2), spow(r * b, 1 / 2)]
    if degree >= 3:
        terms += [spow(r * g ** 2, 1 / 3), spow(g * b ** 2, 1 / 3), spow(r * b ** 2, 1 / 3), spow(g * r ** 2, 1 / 3),
                  spow(b * g ** 2, 1 / 3), spow(b * r ** 2, 1 / 3), spow(r * g * b, 1 / 3)]
    if degree >= 4:
        terms += [spow(r ** 3 * g, 1 / 4), spow(r ** 3 * b, 1 / 4), spow(g ** 3 * r, 1 / 4), spow(g ** 3 * b, 1 / 4),
                  spow(b ** 3 * r, 1 / 4), spow(b ** 3 * g, 1 / 4), spow(r ** 2 * g * b, 1 / 4),
                  spow(g ** 2 * r * b, 1 / 4), spow(b ** 2 * r * g, 1 / 4)]
    return np.stack(terms, axis=-1)
