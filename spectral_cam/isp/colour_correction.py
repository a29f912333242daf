"""Colour correction: white-balanced camera RGB → CIE XYZ (D65) → linear sRGB.

Two sources for the camera → XYZ(D65) transform:

- ``"dng"``, from the RAW's own metadata: the DNG ColorMatrix1 C maps XYZ (calibrated
  under D65, CalibrationIlluminant1 = 21) to camera RGB, so un-balanced camera RGB → XYZ
  is C⁻¹. For data white-balanced by gains g (neutral n = 1/g), camera = diag(n)·rgb_wb,
  and the white those gains assume has XYZ_w = C⁻¹·n. A Bradford chromatic adaptation from
  XYZ_w to D65 and a scale that maps the balanced white (1, 1, 1) to Y = 1 give
  ``M = s · CAT_Bradford(XYZ_w → D65) · C⁻¹ · diag(n)``.
- ``"fitted"`` / ``"root_polynomial"``: a transform supplied with the RAW (or by the
  caller) that maps white-balanced camera RGB to XYZ(D65), e.g. fitted by least squares
  from a camera's measured curves on reflectance sets under the scene illuminant. It is a
  (3, 3) matrix, a (3, N) root-polynomial matrix (N = 6, 13, 22 for degrees 2, 3, 4 of
  Finlayson et al. 2015) or a callable. The ISP never sees spectra: only these numbers.

Which calibration (of two or three) a scene white takes is :mod:`spectral_cam.isp.dng_calibrations`.

References
----------
.. [1] Adobe (2023). Digital Negative (DNG) Specification 1.7.1.0, chapter 6 "Mapping
   Camera Color Space to CIE XYZ Space".
.. [2] Lam, K. M. (1985). Metamerism and colour constancy. PhD thesis, University of
   Bradford (Bradford CAT); CIE 159:2004.
.. [3] Finlayson, G. D., Mackiewicz, M., & Hurlbert, A. (2015). Color correction using
   root-polynomial regression. IEEE Trans. Image Process. 24(5), 1460–1470.
.. [4] IEC 61966-2-1:1999, Multimedia systems and equipment — Colour measurement and
   management — Default RGB colour space — sRGB.
"""

from __future__ import annotations

import numpy as np

from ..cie import SRGB_TO_XYZ, XYZ_TO_SRGB, bradford_adaptation, root_polynomial_terms, xyz_d65_white
from ..errors import ConfigError
from ..registry import Registry
from .dng_calibrations import (  # noqa: F401 (their old home)
    CCT_A_K,
    CCT_D65_K,
    calibration_weight,
    interpolate_color_matrix,
    mccamy_cct,
    triple_calibration_weights,
    triple_profile,
)

__all__ = [
    "ROOT_POLYNOMIAL_TERMS",
    "xyz_d65_white",
    "mccamy_cct",
    "von_kries_bradford",
    "dng_camera_to_xyz_d65",
    "dng_profile_camera_to_xyz_d65",
    "calibration_weight",
    "triple_calibration_weights",
    "triple_profile",
    "camera_to_xyz",
    "camera_to_linear_srgb",
    "xyz_to_linear_srgb",
    "linear_srgb_to_xyz",
]

#: Number of root-polynomial terms per degree (Finlayson et al. 2015, Table 1).
ROOT_POLYNOMIAL_TERMS = {3: 1, 6: 2, 13: 3, 22: 4}


# The few colorimetric constants a develop needs are written out here rather than taken from
# colour-science: ``import colour`` loads matplotlib and scipy (0.8–1.1 s), which a ``develop``
# of a DNG must not pay. tests/test_cie.py checks each against colour-science.

# (the sRGB white and matrices, Bradford and xy → XYZ: spectral_cam.cie, shared with the ground truth)


#: (3, 3) von Kries adaptation in Bradford cone space from one white to another (Lam 1985).
von_kries_bradford = bradford_adaptation


def dng_camera_to_xyz_d65(color_matrix, neutral, *, color_matrix_2=None, adaptation: str = "Bradford") -> np.ndarray:
    """White-balanced camera RGB → XYZ(D65) from the DNG colour matrices and a neutral.

    Parameters
    ----------
    color_matrix
        (3, 3) DNG ColorMatrix1: XYZ → camera RGB, calibrated under D65.
    neutral
        (3,) camera RGB of the white the white balance assumes (AsShotNeutral, or 1/gains).
    color_matrix_2
        Optional (3, 3) XYZ → camera calibrated under Standard Illuminant A; with it the
        matrix is interpolated for the white's colour temperature
        (:func:`interpolate_color_matrix`).
    adaptation
        Chromatic adaptation transform from that white to D65: ``"Bradford"`` (built in),
        or any other colour-science name (``"CAT02"``, ``"CAT16"``, ...).

    Returns
    -------
    numpy.ndarray
        (3, 3) matrix M, with M·(1, 1, 1) = XYZ(D65) at Y = 1.

    Raises
    ------
    ConfigError
        If the matrix is singular or the neutral is not positive.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6.
    .. [2] CIE 159:2004, A colour appearance model for colour management systems: CIECAM02
       (Bradford / von Kries adaptation).
    """
    cm = np.asarray(color_matrix, dtype=np.float64).reshape(3, 3)
    n = np.asarray(neutral, dtype=np.float64).reshape(3)
    if not np.all(np.isfinite(n)) or np.any(n <= 0):
        raise ConfigError(f"the white-balance neutral must be three numbers > 0; got {n.tolist()}")
    if color_matrix_2 is not None:
        try:
            cm = interpolate_color_matrix(cm, color_matrix_2, n)
        except np.linalg.LinAlgError:
            raise ConfigError("the DNG colour matrices are singular") from None
    try:
        cam_to_xyz = np.linalg.inv(cm)
    except np.linalg.LinAlgError:
        raise ConfigError(f"the DNG ColorMatrix1 {cm.tolist()} is singular") from None
    xyz_white = cam_to_xyz @ n
    if not np.all(np.isfinite(xyz_white)) or xyz_white[1] <= 0:
        raise ConfigError("ColorMatrix1 maps the as-shot neutral to a non-physical white")
    target = xyz_d65_white()
    if adaptation == "Bradford":
        cat = von_kries_bradford(xyz_white / xyz_white[1], target)
    else:
        import colour

        cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(
            xyz_white / xyz_white[1], target, transform=adaptation)
    matrix = cat @ cam_to_xyz @ np.diag(n)
    return matrix / (matrix @ np.ones(3))[1]


def camera_to_xyz(rgb: np.ndarray, transform) -> np.ndarray:
    """Apply a white-balanced camera RGB → XYZ(D65) transform.

    Parameters
    ----------
    rgb
        (..., 3) white-balanced camera RGB (linear).
    transform
        (3, 3) matrix; (3, N) root-polynomial matrix with N in 6, 13, 22 (degrees 2–4,
        Finlayson 2015, :func:`spectral_cam.cie.root_polynomial_terms`); or a callable ``f(rgb) -> xyz``.

    Returns
    -------
    numpy.ndarray
        (..., 3) float32 CIE XYZ relative to D65.

    Raises
    ------
    ConfigError
        If the transform has an unusable shape.

    References
    ----------
    .. [1] Finlayson, G. D., Mackiewicz, M., & Hurlbert, A. (2015). IEEE TIP 24(5), 1460–1470.
    """
    rgb = np.asarray(rgb, dtype=np.float32)
    if callable(transform):
        xyz = np.asarray(transform(rgb), dtype=np.float32)
        if xyz.shape != rgb.shape:
            raise ConfigError(f"the camera → XYZ callable returned shape {xyz.shape}, expected {rgb.shape}")
        return xyz
    matrix = np.asarray(transform, dtype=np.float64)
    if matrix.ndim != 2 or matrix.shape[0] != 3 or matrix.shape[1] not in ROOT_POLYNOMIAL_TERMS:
        raise ConfigError(f"a camera → XYZ matrix must be (3, 3) or root-polynomial (3, N), N in 6, 13, 22; "
                          f"got shape {matrix.shape}")
    if matrix.shape[1] == 3:
        return _apply_3x3(rgb, matrix)
    degree = ROOT_POLYNOMIAL_TERMS[matrix.shape[1]]
    xyz = root_polynomial_terms(rgb.reshape(-1, 3), degree) @ matrix.T
    return np.asarray(xyz, dtype=np.float32).reshape(rgb.shape)


def _apply_3x3(values: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """values @ matrix.T for (..., 3) float32 data (cv2.transform: vectorised, threaded)."""
    import cv2

    values = np.ascontiguousarray(values, dtype=np.float32)
    flat = values.reshape(-1, 1, 3)
    return cv2.transform(flat, np.asarray(matrix, dtype=np.float32)).reshape(values.shape)


def camera_to_linear_srgb(rgb: np.ndarray, transform) -> np.ndarray:
    """White-balanced camera RGB → XYZ(D65) → linear sRGB in one pass.

    A (3, 3) transform is folded into one matrix, M_sRGB · M; other transforms go through
    :func:`camera_to_xyz` and :func:`xyz_to_linear_srgb`.

    Parameters
    ----------
    rgb
        (..., 3) white-balanced camera RGB (linear).
    transform
        As in :func:`camera_to_xyz`.

    Returns
    -------
    numpy.ndarray
        (..., 3) float32 linear sRGB, unclipped.

    References
    ----------
    .. [1] IEC 61966-2-1:1999; Adobe (2023). DNG Specification 1.7.1.0, ch. 6.
    """
    if not callable(transform):
        matrix = np.asarray(transform, dtype=np.float64)
        if matrix.shape == (3, 3):
            to_rgb, _ = _srgb_matrices()
            return _apply_3x3(rgb, to_rgb @ matrix)
    return xyz_to_linear_srgb(camera_to_xyz(rgb, transform))



def _srgb_matrices() -> tuple[np.ndarray, np.ndarray]:
    """(XYZ → linear sRGB, linear sRGB → XYZ), as IEC 61966-2-1 tabulates them."""
    return XYZ_TO_SRGB, SRGB_TO_XYZ


def xyz_to_linear_srgb(xyz: np.ndarray) -> np.ndarray:
    """CIE XYZ (D65) → linear sRGB, unclipped.

    Parameters
    ----------
    xyz
        (..., 3) CIE XYZ relative to D65 (Y = 1 for the reference white).

    Returns
    -------
    numpy.ndarray
        (..., 3) float32 linear sRGB (IEC 61966-2-1 primaries, D65).

    References
    ----------
    .. [1] IEC 61966-2-1:1999, eq. (7) (the XYZ → RGB matrix, as tabulated in colour-science).
    """
    to_rgb, _ = _srgb_matrices()
    return _apply_3x3(xyz, to_rgb)


def linear_srgb_to_xyz(rgb: np.ndarray) -> np.ndarray:
    """Linear sRGB → CIE XYZ (D65).

    Parameters
    ----------
    rgb
        (..., 3) linear sRGB.

    Returns
    -------
    numpy.ndarray
        (..., 3) float32 CIE XYZ (Y = 1 for sRGB white).

    References
    ----------
    .. [1] IEC 61966-2-1:1999.
    """
    _, to_xyz = _srgb_matrices()
    return _apply_3x3(rgb, to_xyz)



# ----------------------------------------------------------------------------- which transform
#: RawImage.meta key of a fitted (3, 3) white-balanced camera RGB → XYZ(D65) matrix
#: (or a callable).
META_CAMERA_TO_XYZ = "camera_to_xyz_d65"
#: RawImage.meta key of a root-polynomial correction: a (3, N) matrix (N = 6, 13, 22) or
#: a callable.
META_CAMERA_TO_XYZ_ROOT_POLY = "camera_to_xyz_d65_root_polynomial"


def _tag_problems(raw, kinds: tuple[str, ...] = ("ColorMatrix", "ForwardMatrix")) -> str:
    """What the RAW's reader found wrong with its colour tags of ``kinds`` (``meta["colour_tag_problems"]``),
    as one clause: the develop names the tag that is wrong, not only what is missing."""
    problems = (raw.meta or {}).get("colour_tag_problems") or []
    return "; ".join(str(p) for p in problems if str(p).startswith(kinds))


def _dng(raw, gains, supplied):
    if raw.color_matrix is None:
        wrong = _tag_problems(raw)
        raise ConfigError("isp.colour_matrix = 'dng' needs the RAW's ColorMatrix; "
                          + (f"this RAW's is unusable: {wrong}" if wrong else "this RAW has none")
                          + " (use 'fitted' with a supplied matrix, or 'none')")
    second = getattr(raw, "color_matrix_2", None)
    if second is not None and getattr(raw, "calibration_3", None) is not None:  # DNG 1.6: three calibrations
        weights, _ = triple_profile(raw, 1.0 / np.asarray(gains)[:3])
        blended = sum(w * np.asarray(m, dtype=np.float64)[:3]
                      for w, m in zip(weights, (raw.color_matrix, second, raw.calibration_3.color_matrix)))
        return dng_camera_to_xyz_d65(blended, 1.0 / np.asarray(gains)[:3])
    # an RGBW RAW's fourth plane (white) is developed as luminance: the colour rows are R, G, B
    return dng_camera_to_xyz_d65(np.asarray(raw.color_matrix)[:3], 1.0 / np.asarray(gains)[:3],
                                 color_matrix_2=None if second is None else np.asarray(second)[:3])


def dng_profile_camera_to_xyz_d65(raw, neutral):
    """White-balanced camera RGB → XYZ(D65) the way an Adobe-path develop uses a DNG camera
    profile: the ForwardMatrix (camera → XYZ D50) into linear ProPhoto RGB, the ProfileHueSatMap
    there when the RAW has one, back to XYZ D50 and Bradford to D65. With two calibrations the
    forward matrices and maps are blended with the colour matrices' weight for the scene white.

    Parameters
    ----------
    raw : RawImage
        Its ``forward_matrix`` (D65) and optional ``forward_matrix_2`` (A), ``hue_sat_map`` /
        ``hue_sat_map_2``, and ``color_matrix`` / ``color_matrix_2`` for the weight.
    neutral : array_like
        (3,) camera RGB of the white the white balance assumes.

    Returns
    -------
    numpy.ndarray or callable
        A (3, 3) matrix without a map, else a callable (..., 3) → (..., 3).

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 (ForwardMatrix, ProfileHueSatMap).
    """
    from .hue_sat_map import PROPHOTO_TO_XYZ_D50, XYZ_D50_TO_PROPHOTO, apply_hue_sat_map

    forward, hue_sat = raw.forward_matrix, getattr(raw, "hue_sat_map", None)
    if forward is None:
        wrong = _tag_problems(raw)
        raise ConfigError("isp.colour_matrix = 'dng_profile' needs the RAW's ForwardMatrix (and the ColorMatrix "
                          "it belongs to); " + (f"this RAW's are unusable: {wrong}" if wrong else "this RAW has none")
                          + " (valid: 'dng', 'fitted', 'none')")
    forward = _usable_forward(forward, "forward_matrix (the D65 calibration's ForwardMatrix)")
    neutral = np.asarray(neutral, dtype=np.float64)[:3]
    third = getattr(raw, "calibration_3", None)
    if third is not None and third.forward_matrix is not None and raw.forward_matrix_2 is not None \
            and raw.color_matrix is not None and raw.color_matrix_2 is not None:
        # DNG 1.6: the three calibrations weighted by the white's distance from each light
        weights, _ = triple_profile(raw, neutral)
        seconds = (_usable_forward(raw.forward_matrix_2, "forward_matrix_2 (the Standard A calibration's "
                                   "ForwardMatrix)"), _usable_forward(third.forward_matrix, "calibration_3's ForwardMatrix"))
        forward = weights[0] * forward + weights[1] * seconds[0] + weights[2] * seconds[1]
        maps = (hue_sat, getattr(raw, "hue_sat_map_2", None), third.hue_sat_map)
        hue_sat = None if any(m is None for m in maps) else maps[0].weighted(maps, weights)
    elif raw.forward_matrix_2 is not None and raw.color_matrix is not None and raw.color_matrix_2 is not None:
        weight = calibration_weight(np.asarray(raw.color_matrix)[:3], np.asarray(raw.color_matrix_2)[:3], neutral)
        second = _usable_forward(raw.forward_matrix_2, "forward_matrix_2 (the Standard A calibration's ForwardMatrix)")
        forward = weight * forward + (1 - weight) * second
        if hue_sat is not None and getattr(raw, "hue_sat_map_2", None) is not None:
            hue_sat = hue_sat.blend(raw.hue_sat_map_2, weight)
    d50 = PROPHOTO_TO_XYZ_D50 @ np.ones(3)
    forward = forward * (d50 / (forward @ np.ones(3)))[:, None]  # the white onto D50 (DNG ch. 6)
    to_d65 = von_kries_bradford(d50, xyz_d65_white())
    if hue_sat is None:
        return to_d65 @ forward
    into, back = XYZ_D50_TO_PROPHOTO @ forward, to_d65 @ PROPHOTO_TO_XYZ_D50

    def transform(rgb):
        rgb = np.asarray(rgb)
        return (apply_hue_sat_map(rgb.reshape(-1, 3) @ into.T, hue_sat) @ back.T).reshape(rgb.shape)

    return transform


def _usable_forward(matrix, name: str) -> np.ndarray:
    """A forward matrix's R, G, B columns (an RGBW RAW's white is luminance), refused unless it is
    finite, of rank 3 and maps camera white (1, 1, 1) to a positive XYZ — what scaling it onto D50
    needs (an all-zero one divided 0 by 0 and reached the tone curve as NaN, issue 39 #23)."""
    forward = np.asarray(matrix, dtype=np.float64)[:, :3]
    if forward.shape != (3, 3) or not np.all(np.isfinite(forward)):
        raise ConfigError(f"the RAW's {name} must be 3 finite rows; got {forward.tolist()}")
    rank = int(np.linalg.matrix_rank(forward))
    if rank < 3 or not np.all(forward @ np.ones(3) > 0):
        raise ConfigError(f"the RAW's {name} is {'singular (rank %d)' % rank if rank < 3 else 'not white-preserving'}"
                          f": {np.round(forward, 6).tolist()}; valid: a rank-3 matrix mapping camera white (1, 1, 1) "
                          "to a positive XYZ (DNG ch. 6). Use isp.colour_matrix = 'dng' or 'fitted'")
    return forward


def _dng_profile(raw, gains, supplied):
    return dng_profile_camera_to_xyz_d65(raw, 1.0 / gains)


def _supplied(method: str, key: str):
    def transform_of(raw, gains, supplied):
        transform = supplied if supplied is not None else (raw.meta or {}).get(key)
        if transform is None:
            raise ConfigError(f"isp.colour_matrix = {method!r} needs a camera → XYZ(D65) transform: pass "
                              f"camera_to_xyz= to develop() or put it in RawImage.meta[{key!r}]; "
                              "valid without one: 'dng', 'none'")
        if not callable(transform):
            transform = np.asarray(transform, dtype=np.float64)
            if method == "fitted" and transform.shape != (3, 3):
                raise ConfigError(f"isp.colour_matrix = 'fitted' needs a (3, 3) matrix; got shape {transform.shape} "
                                  "(a (3, N) matrix is a root-polynomial correction: use 'root_polynomial')")
        return transform

    return transform_of


def _auto(raw, gains, supplied):
    return None  # resolved by colour_transform (to "fitted", "dng" or "none")


#: Sources of the white-balanced camera RGB → XYZ(D65) transform (``isp.colour_matrix``):
#: each entry ``(raw, gains, supplied) -> transform`` (None: no colour correction).
COLOUR_MATRIX = Registry("colour matrix source")
COLOUR_MATRIX.add("auto", _auto, description="'fitted' when the RAW carries a fitted matrix, else 'dng', else 'none'")
COLOUR_MATRIX.add("dng", _dng, description="the DNG's ColorMatrix1/2 (interpolated by CCT) and AsShotNeutral")
COLOUR_MATRIX.add("dng_profile", _dng_profile,
                  description="the DNG's ForwardMatrix1/2 and ProfileHueSatMap (Adobe's camera-profile path)")
COLOUR_MATRIX.add("fitted", _supplied("fitted", META_CAMERA_TO_XYZ),
                  description="a 3×3 matrix fitted from the measured curves (RawImage.meta)")
COLOUR_MATRIX.add("root_polynomial", _supplied("root_polynomial", META_CAMERA_TO_XYZ_ROOT_POLY),
                  description="a root-polynomial correction fitted from the measured curves")
COLOUR_MATRIX.add("none", lambda raw, gains, supplied: None, description="no colour correction (camera RGB)")


def colour_transform(raw, method: str, gains: np.ndarray, supplied=None):
    """(transform, source name) of white-balanced camera RGB → XYZ(D65) for a RAW.

    Parameters
    ----------
    raw : RawImage
        The RAW (its ColorMatrix1/2 and ``meta`` fitted corrections).
    method : str
        One of :data:`COLOUR_MATRIX`; ``"auto"`` picks ``"fitted"`` when a transform is
        supplied or the RAW carries one, else ``"dng"`` when it has a ColorMatrix1, else
        ``"none"``.
    gains : numpy.ndarray
        The white-balance gains applied (their inverse is the neutral the DNG matrix is
        adapted from).
    supplied : array or callable, optional
        A transform given to :func:`spectral_cam.isp.develop` (``camera_to_xyz``).

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 (mapping camera colour space to
       CIE XYZ).
    """
    if method == "auto":
        if supplied is not None or (raw.meta or {}).get(META_CAMERA_TO_XYZ) is not None:
            method = "fitted"
        elif raw.color_matrix is not None:
            method = "dng"
        else:
            method = "none"
            if _tag_problems(raw, ("ColorMatrix",)):  # a corrupt matrix is not the same as none: say so
                import warnings

                from ..errors import SceneWarning

                warnings.warn("isp.colour_matrix = 'auto' developed without colour correction (camera RGB): "
                              f"{_tag_problems(raw, ('ColorMatrix',))}", SceneWarning, stacklevel=3)
    transform = COLOUR_MATRIX[method](raw, gains, supplied)
    used = {"dng": ("ColorMatrix",), "dng_profile": ("ColorMatrix", "ForwardMatrix")}.get(method)
    if transform is not None and used and _tag_problems(raw, used):
        import warnings

        from ..errors import SceneWarning

        # e.g. a singular Standard A matrix: the develop goes on with the D65 calibration alone
        warnings.warn(f"isp.colour_matrix = {method!r} developed with the RAW's usable colour tags only: "
                      f"{_tag_problems(raw, used)}", SceneWarning, stacklevel=3)
    return transform, ("none" if transform is None else method)
