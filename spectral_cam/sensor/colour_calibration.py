"""Spectral colour calibration of a camera: responses, XYZ, DNG colour matrix, colour correction.

Everything here is computed from spectra — the camera's measured channel sensitivities, an
illuminant's SPD and a set of reflectances — on a 1-nm grid, so the DNG writer (ColorMatrix1,
AsShotNeutral) and the ISP's fitted colour matrices rest on one definition.

The matrices are fitted on a training set (:data:`TRAINING_SET`: the 190 reflectances AMPAS
rawtoaces fits its input transforms on) that is not what a validation scores (the ColorChecker,
the CIE 2017 samples): fitted on the ColorChecker, every ColorChecker score was in sample and
optimistic (issue 28).

Conventions
-----------
- Camera curves ``S_c(λ)`` are relative responsivities *per unit energy* (as the packaged
  pbrt-v4 / PhysLight data are), so the photo-electrons of channel ``c`` for a surface of
  reflectance ρ under an illuminant of spectral power ``E`` are proportional to
  ``∫ ρ(λ)·E(λ)·T(λ)·S_c(λ) dλ``; that integral is what :func:`camera_responses` returns
  (relative units).
- ``camera = "ideal"`` is a sensor of flat quantum efficiency: per unit energy its
  responsivity is ∝ λ (three identical channels).
- XYZ are CIE 1931 2° tristimulus values scaled so that the perfect reflecting diffuser
  under the illuminant has Y = 1.

References
----------
.. [1] CIE 15:2004, Colorimetry, 3rd ed., §7 (tristimulus values by integration).
.. [2] Adobe (2023). Digital Negative (DNG) Specification 1.7.1.0, ch. 6 "Mapping Camera
   Color Space to CIE XYZ Space" (ColorMatrix, AsShotNeutral).
.. [3] Finlayson, G. D., & Drew, M. S. (1996). Constrained least-squares regression in
   color spaces. Journal of Electronic Imaging 6(4) (white-point preserving fits).
.. [4] Finlayson, G. D., Mackiewicz, M., & Hurlbert, A. (2015). Color Correction Using
   Root-Polynomial Regression. IEEE Trans. Image Processing 24(5), 1460–1470.
.. [5] Lam, K. M. (1985). Metamerism and colour constancy. PhD thesis, University of
   Bradford (the Bradford chromatic adaptation transform).
"""

from __future__ import annotations

import functools
from typing import Callable

import numpy as np

from .. import spectra
from ..colour_ground_truth import illuminant_sd, illuminant_white_xyz, reflectance_list, reflectance_xyz
from ..errors import ConfigError

__all__ = [
    "TRAINING_SET",
    "training_reflectances",
    "training_record",
    "camera_responses",
    "xyz_to_camera_matrix",
    "camera_to_xyz_d65",
    "as_shot_neutral",
    "RootPolynomialCorrection",
    "CORRECTION_METHODS",
    "fit_hue_sat_map",
    "forward_matrix_d50",
    "HUE_SAT_MAP_DIVISIONS",
]

#: Methods accepted by :func:`camera_to_xyz_d65`.
CORRECTION_METHODS = ("linear", "root_polynomial")
#: CIE 1931 integration grid (nm): the CMFs' own 1-nm table.
#: Wavelength range of the ideal (flat-QE) camera (nm).
_IDEAL_RANGE_NM = (360.0, 830.0)


# ----------------------------------------------------------------------------- inputs
def _camera_table(camera) -> tuple[np.ndarray, np.ndarray]:
    """(wavelengths_nm, (n, 3) per-energy responsivities) of a camera name or MSDS."""
    if isinstance(camera, str) and camera.strip().lower() == "ideal":
        wl = np.arange(_IDEAL_RANGE_NM[0], _IDEAL_RANGE_NM[1] + 1.0)
        values = np.repeat((wl / wl.max())[:, None], 3, axis=1)
        return wl, values
    msds = spectra.camera_sensitivities(camera) if isinstance(camera, str) else camera
    values = np.asarray(msds.values, dtype=float)
    if values.ndim != 2 or values.shape[1] != 3:
        raise ConfigError(f"camera {getattr(msds, 'name', camera)!r}: need three channels (r, g, b)")
    return np.asarray(msds.wavelengths, dtype=float), values


def _transmission_curve(transmission, wavelengths_nm: np.ndarray) -> np.ndarray:
    """Product of transmission curves (None, one SD/number/name, or a sequence) on a grid."""
    if transmission is None:
        return np.ones_like(wavelengths_nm)
    items = transmission if isinstance(transmission, (list, tuple)) else [transmission]
    curve = np.ones_like(wavelengths_nm)
    for item in items:
        sd = spectra.transmission(item) if isinstance(item, (str, int, float)) else item
        if sd is not None:
            curve = curve * spectra.sample(sd, wavelengths_nm)
    return curve


def _camera_grid(camera_wl: np.ndarray) -> np.ndarray:
    return np.arange(np.ceil(camera_wl.min()), np.floor(camera_wl.max()) + 1.0, 1.0)


# ----------------------------------------------------------------------------- responses
def camera_responses(
    camera,
    illuminant_spd,
    reflectances=None,
    *,
    transmission=None,
) -> np.ndarray:
    """Relative raw camera responses of reflectances under an illuminant.

    ``r_c = Σ_λ ρ(λ)·E(λ)·T(λ)·S_c(λ)·Δλ`` on a 1-nm grid over the camera curves' range,
    with ``S_c`` the per-energy channel responsivity, so ``r_c`` is proportional to the
    photo-electrons the channel collects.

    Parameters
    ----------
    camera : str or colour.MultiSpectralDistributions
        A measured camera name (:func:`spectral_cam.spectra.camera_names`), ``"ideal"``
        (flat quantum efficiency) or the curves themselves (relative, per unit energy).
    illuminant_spd : str or colour.SpectralDistribution
        Illuminant name (:func:`spectral_cam.spectra.illuminant`) or SPD (relative power
        per nm; zero outside its table).
    reflectances : mapping, sequence or None
        Reflectance spectra (SDs, numbers in [0, 1] or ColorChecker patch names);
        default the 24 BabelColor ColorChecker patches.
    transmission : optional
        Lens / filter transmission(s) T(λ) in [0, 1]: an SD, a name/number accepted by
        :func:`spectral_cam.spectra.transmission`, or a sequence of them (multiplied).

    Returns
    -------
    numpy.ndarray
        (N, 3) relative responses (arbitrary but common scale; nm × SPD units).

    References
    ----------
    .. [1] Pharr, Jakob & Humphreys (2023). Physically Based Rendering, 4th ed., §5.4.2
       (sensor response from measured RGB matching functions).
    """
    cam_wl, cam_values = _camera_table(camera)
    wl = _camera_grid(cam_wl)
    sens = np.stack([np.interp(wl, cam_wl, cam_values[:, i]) for i in range(3)], axis=-1)
    power = spectra.sample(illuminant_sd(illuminant_spd), wl, outside=0.0)
    power = power * _transmission_curve(transmission, wl)
    rho = np.stack([spectra.sample(sd, wl) for sd in reflectance_list(reflectances)])
    return (rho * power) @ sens


def as_shot_neutral(camera, illuminant_spd, *, transmission=None) -> np.ndarray:
    """Camera response to the illuminant's white (a perfect diffuser), max component 1.

    Parameters
    ----------
    camera, illuminant_spd, transmission
        As in :func:`camera_responses`.

    Returns
    -------
    numpy.ndarray
        (3,) camera neutral, the DNG ``AsShotNeutral`` of a scene lit by this illuminant.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, tag AsShotNeutral (50728).
    """
    white = camera_responses(camera, illuminant_spd, [1.0], transmission=transmission)[0]
    if not np.all(white > 0):
        raise ConfigError("the camera does not respond to this illuminant in every channel")
    return white / white.max()


# ----------------------------------------------------------------------------- training
#: The reflectances the colour matrices are fitted on (:mod:`spectral_cam.reflectance_sets`):
#: AMPAS rawtoaces' 190 training spectra, as rawtoaces fits its IDTs. None of them is a
#: ColorChecker or CIE 2017 sample (5 of the 24 ColorChecker patches have one within 0.02 in
#: reflectance over 400–700 nm; no CIE 2017 sample within 0.019).
TRAINING_SET = "rawtoaces"


@functools.lru_cache(maxsize=1)
def training_reflectances() -> tuple:
    """The :data:`TRAINING_SET` spectra (cached)."""
    from ..reflectance_sets import reflectance_set

    return tuple(reflectance_set(TRAINING_SET).sds)


def training_record() -> dict:
    """What the colour matrices were fitted on, for a RAW's meta and a validation report."""
    return {"training_set": TRAINING_SET, "training_count": len(training_reflectances()),
            "fit": "white-preserving least squares (Finlayson & Drew 1996) under each calibration illuminant",
            "source": "AMPAS rawtoaces training spectra (via colour-science)"}


def _training(reflectances):
    """``reflectances`` as given, or the training set for None."""
    return list(training_reflectances()) if reflectances is None else reflectances


# ----------------------------------------------------------------------------- fitting
def _white_preserving_fit(source: np.ndarray, target: np.ndarray, white_source: np.ndarray,
                          white_target: np.ndarray) -> np.ndarray:
    """M (3 × terms) minimising ‖source·Mᵀ − target‖² subject to M·white_source = white_target.

    Row by row: m = m_ls − G·w·(wᵀm_ls − t)/(wᵀG·w), G = (XᵀX)⁻¹ (Lagrange multiplier).
    """
    gram_inv = np.linalg.inv(source.T @ source)
    m_ls = gram_inv @ source.T @ target  # (3, 3): columns are rows of M
    gw = gram_inv @ white_source
    correction = np.outer(gw, (white_source @ m_ls - white_target) / (white_source @ gw))
    return (m_ls - correction).T


@functools.lru_cache(maxsize=64)
def _xyz_to_camera_cached(camera: str, illuminant: str, transmission_key: tuple) -> np.ndarray:
    return _xyz_to_camera(camera, illuminant, None, list(transmission_key) or None)


def _xyz_to_camera(camera, illuminant_spd, reflectances, transmission) -> np.ndarray:
    reflectances = _training(reflectances)
    cam = camera_responses(camera, illuminant_spd, reflectances, transmission=transmission)
    xyz = reflectance_xyz(illuminant_spd, reflectances)
    white_cam = camera_responses(camera, illuminant_spd, [1.0], transmission=transmission)[0]
    white_xyz = illuminant_white_xyz(illuminant_spd)
    scale = white_cam.max()
    if np.linalg.matrix_rank(cam) < 3:
        raise ConfigError(
            f"camera {camera!r} has linearly dependent channels; an XYZ→camera matrix "
            "needs three distinct spectral sensitivities"
        )
    return _white_preserving_fit(xyz, cam / scale, white_xyz, white_cam / scale)


def xyz_to_camera_matrix(
    camera,
    illuminant_spd="D65",
    *,
    reflectances=None,
    transmission=None,
) -> np.ndarray:
    """Least-squares XYZ → camera matrix, normalised the DNG way (DNG ColorMatrix).

    Fits ``cam ≈ M·XYZ`` over the reflectance set under the illuminant, constrained so
    that the illuminant's white (XYZ with Y = 1) maps exactly onto the camera neutral
    scaled to a maximum component of 1 — the normalisation of a DNG ColorMatrix for its
    calibration illuminant.

    Parameters
    ----------
    camera : str or colour.MultiSpectralDistributions
        Camera name or curves (see :func:`camera_responses`).
    illuminant_spd : str or colour.SpectralDistribution
        Calibration illuminant; ``"D65"`` gives ColorMatrix1 with CalibrationIlluminant1 = 21.
    reflectances : optional
        Training reflectances; default :data:`TRAINING_SET`.
    transmission : optional
        Lens / filter transmission(s) in front of the sensor.

    Returns
    -------
    numpy.ndarray
        (3, 3) matrix, rows = camera channels (r, g, b), columns = X, Y, Z.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 (ColorMatrix1/2).
    .. [2] Finlayson & Drew (1996), white-point preserving least squares.
    """
    cacheable = (isinstance(camera, str) and isinstance(illuminant_spd, str) and reflectances is None
                 and (transmission is None or all(
                     isinstance(t, (str, int, float))
                     for t in (transmission if isinstance(transmission, (list, tuple)) else [transmission]))))
    if cacheable:
        key = () if transmission is None else tuple(
            transmission if isinstance(transmission, (list, tuple)) else [transmission])
        return _xyz_to_camera_cached(camera, illuminant_spd, key).copy()
    return _xyz_to_camera(camera, illuminant_spd, reflectances, transmission)


class RootPolynomialCorrection:
    """Root-polynomial colour correction (Finlayson et al. 2015) as a callable.

    ``corr(rgb)`` maps white-balanced camera RGB (..., 3) to XYZ(D65) (..., 3).

    Attributes
    ----------
    ccm : numpy.ndarray
        (3, n_terms) matrix on the root-polynomial expansion.
    degree : int
        Expansion degree (2 → 6 terms: R, G, B, √RG, √GB, √RB).
    """

    def __init__(self, ccm: np.ndarray, degree: int) -> None:
        self.ccm = np.asarray(ccm, dtype=float)
        self.degree = int(degree)

    def __call__(self, rgb) -> np.ndarray:
        from ..cie import root_polynomial_terms

        return root_polynomial_terms(rgb, self.degree) @ self.ccm.T

    def __repr__(self) -> str:
        return f"RootPolynomialCorrection(degree={self.degree}, terms={self.ccm.shape[1]})"


def camera_to_xyz_d65(
    camera,
    illuminant_spd,
    *,
    method: str = "linear",
    reflectances=None,
    transmission=None,
    degree: int = 2,
) -> np.ndarray | Callable[[np.ndarray], np.ndarray]:
    """Colour correction from white-balanced camera RGB to XYZ adapted to D65.

    Training pairs: camera responses of the reflectances under the scene illuminant,
    divided by the camera's white response (so the illuminant's white is (1, 1, 1)),
    and their CIE XYZ under the same illuminant, Bradford-adapted from the illuminant's
    white to D65's (both Y = 1).

    Parameters
    ----------
    camera : str or colour.MultiSpectralDistributions
        Camera name or curves.
    illuminant_spd : str or colour.SpectralDistribution
        The scene illuminant.
    method : {"linear", "root_polynomial"}
        ``"linear"``: a 3×3 least-squares matrix constrained to map (1, 1, 1) onto the D65
        white exactly; ``"root_polynomial"``: the Finlayson 2015 root-polynomial terms of
        ``degree`` (colour-science's expansion; exposure invariant), fitted under the same
        white-preserving constraint.
    reflectances : optional
        Training reflectances; default :data:`TRAINING_SET`.
    transmission : optional
        Lens / filter transmission(s) in front of the sensor.
    degree : int
        Root-polynomial degree (1–4) for ``method="root_polynomial"``.

    Returns
    -------
    numpy.ndarray or RootPolynomialCorrection
        ``"linear"``: the (3, 3) matrix M with XYZ_D65 = M·rgb; ``"root_polynomial"``: a
        callable mapping (..., 3) RGB to (..., 3) XYZ_D65.

    References
    ----------
    .. [1] Finlayson, Mackiewicz & Hurlbert (2015), root-polynomial colour correction.
    .. [2] Lam (1985), Bradford chromatic adaptation (colour-science
       ``matrix_chromatic_adaptation_VonKries(..., "Bradford")``).
    """
    from ..cie import bradford_adaptation, root_polynomial_terms

    if method not in CORRECTION_METHODS:
        raise ConfigError(f"colour correction method {method!r}; valid: {', '.join(CORRECTION_METHODS)}")
    reflectances = _training(reflectances)
    cam = camera_responses(camera, illuminant_spd, reflectances, transmission=transmission)
    white_cam = camera_responses(camera, illuminant_spd, [1.0], transmission=transmission)[0]
    rgb = cam / white_cam
    xyz = reflectance_xyz(illuminant_spd, reflectances)
    white_xyz = illuminant_white_xyz(illuminant_spd)
    white_d65 = illuminant_white_xyz("D65")
    xyz_d65 = xyz @ bradford_adaptation(white_xyz, white_d65).T
    if method == "linear":
        return _white_preserving_fit(rgb, xyz_d65, np.ones(3), white_d65)
    if not 1 <= int(degree) <= 4:
        raise ConfigError(f"root-polynomial degree {degree!r}; valid: 1, 2, 3, 4")
    # the same white-preserving least squares on the root-polynomial terms, so the white
    # (1, 1, 1) still maps exactly onto D65's white (an unconstrained fit misses it by ~0.8 ΔE)
    def expand(values):
        return root_polynomial_terms(values, int(degree))

    ccm = _white_preserving_fit(expand(rgb), xyz_d65, expand(np.ones(3)), white_d65)
    return RootPolynomialCorrection(ccm, int(degree))


#: (hue, saturation) divisions of the fitted DNG hue/sat maps: 27 hues (13.3° apart) × 6 saturations,
#: one value division (a 2-D map, as most of Adobe's own profiles). 27 × 6 × 3 = 486 numbers per map:
#: exiftool -validate skips arrays over 500 with a "Not decoding some large array(s)" warning; 36 hues
#: scored the same out of sample (CIE 2017 0.925 vs 0.917 mean ΔE2000).
HUE_SAT_MAP_DIVISIONS = (27, 6)
#: Weight of the fitted map's roughness (second differences along hue and saturation, per node) against
#: its training residuals. Chosen by 5-fold cross-validation on the training set alone (docs/design.md).
HUE_SAT_MAP_SMOOTHNESS = 0.1


def forward_matrix_d50(camera, illuminant_spd, *, reflectances=None, transmission=None) -> np.ndarray:
    """White-balanced camera RGB → XYZ(D50) under ``illuminant_spd`` (a DNG ForwardMatrix): the
    white-preserving fit of :func:`camera_to_xyz_d65`, Bradford-adapted from D65 to D50, each row
    scaled so camera white (1, 1, 1) maps exactly onto the D50 white, as the DNG specification asks.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 (ForwardMatrix).
    """
    from ..cie import D50_WHITE_XYZ, bradford_adaptation, illuminant_xy, xy_to_xyz

    to_d65 = np.asarray(camera_to_xyz_d65(camera, illuminant_spd, reflectances=reflectances,
                                          transmission=transmission), float)
    forward = bradford_adaptation(xy_to_xyz(illuminant_xy("D65")), D50_WHITE_XYZ) @ to_d65
    return forward * (D50_WHITE_XYZ / (forward @ np.ones(3)))[:, None]


def _hsm_roughness(hues: int, sats: int) -> np.ndarray:
    """Second differences of a (hues, sats) table: around the hue circle and along saturation."""
    rows = []
    for h in range(hues):
        for s in range(sats):
            row = np.zeros((hues, sats))
            row[h, s] -= 2.0
            row[(h - 1) % hues, s] += 1.0
            row[(h + 1) % hues, s] += 1.0
            rows.append(row.ravel())
            if 0 < s < sats - 1:
                row = np.zeros((hues, sats))
                row[h, s - 1], row[h, s], row[h, s + 1] = 1.0, -2.0, 1.0
                rows.append(row.ravel())
    return np.array(rows)


def fit_hue_sat_map(
    camera,
    illuminant_spd,
    *,
    forward_matrix=None,
    reflectances=None,
    transmission=None,
    divisions: tuple[int, int] = HUE_SAT_MAP_DIVISIONS,
    smoothness: float = HUE_SAT_MAP_SMOOTHNESS,
):
    """A DNG hue/sat map that corrects what a camera's forward matrix leaves, fitted on spectra.

    Training pairs: each reflectance's white-balanced camera RGB through the forward matrix
    (camera → XYZ D50) into linear ProPhoto RGB, and its CIE XYZ under the illuminant
    Bradford-adapted to D50 in ProPhoto; both in the DNG SDK's HSV. The map's output is linear in
    its table, so each of hue shift (weighted by saturation: a hue error is a chroma-sized error),
    saturation scale and value scale (both as relative errors) is a regularised least-squares fit:
    the residuals plus ``smoothness`` × the table's second differences, the neutral axis's value
    scale constrained to exactly 1 (the DNG specification's rule: greys and the white stay where the
    matrix puts them).

    Parameters
    ----------
    camera : str or colour.MultiSpectralDistributions
    illuminant_spd : str or colour.SpectralDistribution
        The calibration illuminant.
    forward_matrix : array_like, optional
        (3, 3) white-balanced camera → XYZ(D50) (DNG ForwardMatrix); default the
        white-preserving fit of :func:`camera_to_xyz_d65` adapted to D50, as the DNG writer does.
    reflectances : optional
        Training reflectances; default :data:`TRAINING_SET`.
    transmission : optional
        Lens / filter transmission(s) in front of the sensor.
    divisions : (int, int)
        Hue and saturation divisions.
    smoothness : float
        Weight of the roughness penalty (>= 0).

    Returns
    -------
    spectral_cam.raw.hue_sat_map.HueSatMap

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 (ProfileHueSatMap).
    .. [2] Hastie, Tibshirani & Friedman (2009). The Elements of Statistical Learning, §5.4
       (penalised least squares), §7.10 (cross-validation).
    """
    from ..cie import D50_WHITE_XYZ, bradford_adaptation
    from ..raw.hue_sat_map import XYZ_D50_TO_PROPHOTO, HueSatMap, interpolation_weights, rgb_to_hsv

    hues, sats = (int(d) for d in divisions)
    if hues < 1 or sats < 2 or not smoothness >= 0:
        raise ConfigError(f"hue/sat map divisions {divisions!r} and smoothness {smoothness!r}: give hues >= 1, "
                          "saturations >= 2 and a smoothness >= 0")
    reflectances = _training(reflectances)
    white_cam = camera_responses(camera, illuminant_spd, [1.0], transmission=transmission)[0]
    rgb = camera_responses(camera, illuminant_spd, reflectances, transmission=transmission) / white_cam
    if forward_matrix is None:
        forward_matrix = forward_matrix_d50(camera, illuminant_spd, transmission=transmission)
    source = rgb @ (XYZ_D50_TO_PROPHOTO @ np.asarray(forward_matrix, dtype=float)).T
    xyz = reflectance_xyz(illuminant_spd, reflectances)
    target = xyz @ (XYZ_D50_TO_PROPHOTO @ bradford_adaptation(illuminant_white_xyz(illuminant_spd),
                                                               D50_WHITE_XYZ)).T
    keep = np.all(source > 0, axis=1) & np.all(target > 0, axis=1)  # inside ProPhoto (nearly all)
    hsv_s, hsv_t = rgb_to_hsv(source[keep]), rgb_to_hsv(target[keep])
    indices, weights = interpolation_weights(hsv_s, (hues, sats, 1))
    nodes = hues * sats
    design = np.zeros((len(hsv_s), nodes))
    np.add.at(design, (np.repeat(np.arange(len(hsv_s)), indices.shape[1]), indices.ravel()), weights.ravel())
    rough = np.sqrt(smoothness) * _hsm_roughness(hues, sats)
    tie = 1e-3 * np.eye(nodes)  # a node no sample reaches stays at the identity

    def solve(rows, values, identity, fixed=None):
        """Penalised least squares for the table; the ``fixed`` nodes are held at ``identity``
        exactly (their columns move to the right-hand side), not pulled there by a penalty."""
        blocks = np.vstack([rows, rough, tie])
        rhs = np.concatenate([values, rough @ np.full(nodes, identity), tie @ np.full(nodes, identity)])
        free = np.ones(nodes, bool)
        if fixed is not None:
            free[fixed] = False
        table = np.full(nodes, float(identity))
        rhs = rhs - blocks[:, ~free] @ table[~free]
        table[free] = np.linalg.lstsq(blocks[:, free], rhs, rcond=None)[0]
        return table

    turn = np.mod(hsv_t[:, 0] - hsv_s[:, 0] + 3.0, 6.0) - 3.0  # hexcone units, the short way round
    shift = solve(design * hsv_s[:, 1:2], hsv_s[:, 1] * turn * 60.0, 0.0)
    relative_s = 1.0 / np.maximum(hsv_t[:, 1], 1e-3)
    sat_scale = solve(design * (hsv_s[:, 1] * relative_s)[:, None], hsv_t[:, 1] * relative_s, 1.0)
    # the DNG specification (and Adobe's SDK, dng_hue_sat_map::SetDelta, which warns and resets it) wants
    # the value scale at saturation 0 exactly 1: greys and the white stay where the matrix puts them
    relative_v = 1.0 / hsv_t[:, 2]
    val_scale = solve(design * (hsv_s[:, 2] * relative_v)[:, None], hsv_t[:, 2] * relative_v, 1.0,
                      fixed=np.arange(hues) * sats)
    table = np.stack([shift, np.clip(sat_scale, 0, None), np.clip(val_scale, 0, None)], axis=-1)
    return HueSatMap(table.reshape(1, hues, sats, 3))
