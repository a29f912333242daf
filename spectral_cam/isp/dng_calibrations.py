"""Which of a DNG's calibrations a scene white takes: two calibrations (D65 and Standard A)
interpolated linearly in inverse correlated colour temperature (:func:`calibration_weight`,
McCamy's CCT), three (DNG 1.6) weighted by the white's distance from each calibration light in
the DNG SDK's temperature–tint space (:func:`triple_calibration_weights`, :func:`triple_profile`).
The colour matrices, forward matrices and hue/sat maps of a profile all take these weights.

References
----------
.. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 "Mapping Camera Color Space to CIE XYZ Space".
.. [2] McCamy, C. S. (1992). Correlated color temperature as an explicit function of chromaticity
   coordinates. Color Res. Appl. 17(2), 142–144.
.. [3] Adobe DNG SDK 1.7 (``CalculateTripleIlluminantWeights``, ``dng_color_spec::NeutralToXY``).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["CCT_D65_K", "CCT_A_K", "mccamy_cct", "calibration_weight", "interpolate_color_matrix",
           "triple_calibration_weights", "triple_profile"]


def mccamy_cct(xyz) -> float:
    """Correlated colour temperature (K) of a CIE XYZ by McCamy's cubic in chromaticity.

    References
    ----------
    .. [1] McCamy, C. S. (1992). Correlated color temperature as an explicit function of
       chromaticity coordinates. Color Res. Appl. 17(2), 142–144, eq. (3).
    """
    X, Y, Z = (float(v) for v in np.asarray(xyz, dtype=np.float64).reshape(3))
    total = X + Y + Z
    x, y = X / total, Y / total
    n = (x - 0.3320) / (0.1858 - y)
    return 449.0 * n ** 3 + 3525.0 * n ** 2 + 6823.3 * n + 5520.33


#: Correlated colour temperatures (K) of the DNG calibration illuminants D65 and A.
CCT_D65_K, CCT_A_K = 6504.0, 2856.0


def calibration_weight(color_matrix_d65, color_matrix_a, neutral, *, iterations: int = 20) -> float:
    """The weight of the D65 calibration for a scene white, between the D65 and Standard A
    calibrations, linear in inverse correlated colour temperature (DNG ch. 6); the colour
    matrices, forward matrices and hue/sat maps of a dual-illuminant DNG all take it.

    The white's CCT depends on the matrix and the matrix on the CCT, so both are iterated:
    XYZ_white = M(T)⁻¹·neutral → xy → CCT (McCamy 1992), clamped to [2856, 6504] K.

    Parameters
    ----------
    color_matrix_d65, color_matrix_a
        (3, 3) XYZ → camera under D65 and Standard Illuminant A.
    neutral
        (3,) camera RGB of the scene white.

    Returns
    -------
    float
        In [0, 1]: 1 at or above 6504 K, 0 at or below 2856 K.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 "Mapping Camera Color Space to CIE
       XYZ Space" (interpolation by inverse CCT).
    .. [2] McCamy, C. S. (1992). Correlated color temperature as an explicit function of
       chromaticity coordinates. Color Res. Appl. 17(2), 142–144.
    """
    d65 = np.asarray(color_matrix_d65, dtype=np.float64).reshape(3, 3)
    tungsten = np.asarray(color_matrix_a, dtype=np.float64).reshape(3, 3)
    n = np.asarray(neutral, dtype=np.float64).reshape(3)
    weight = 0.5  # of the D65 matrix
    for _ in range(iterations):
        matrix = weight * d65 + (1 - weight) * tungsten
        xyz = np.linalg.solve(matrix, n)
        if not np.all(np.isfinite(xyz)) or xyz.sum() <= 0:
            break
        cct = mccamy_cct(xyz)
        cct = min(max(cct, CCT_A_K), CCT_D65_K) if np.isfinite(cct) else CCT_D65_K
        new = (1 / cct - 1 / CCT_A_K) / (1 / CCT_D65_K - 1 / CCT_A_K)
        if abs(new - weight) < 1e-6:
            return float(new)
        weight = new
    return float(weight)


def interpolate_color_matrix(color_matrix_d65, color_matrix_a, neutral, *, iterations: int = 20) -> np.ndarray:
    """The XYZ → camera matrix for the scene white: :func:`calibration_weight` of the D65
    matrix, the rest of the Standard A one (DNG ch. 6).

    Parameters
    ----------
    color_matrix_d65, color_matrix_a
        (3, 3) XYZ → camera under D65 (ColorMatrix1) and Standard Illuminant A.
    neutral
        (3,) camera RGB of the scene white.

    Returns
    -------
    numpy.ndarray
        (3, 3) interpolated XYZ → camera matrix.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 (interpolation by inverse CCT).
    """
    weight = calibration_weight(color_matrix_d65, color_matrix_a, neutral, iterations=iterations)
    return weight * np.asarray(color_matrix_d65, float).reshape(3, 3) \
        + (1 - weight) * np.asarray(color_matrix_a, float).reshape(3, 3)


def _temperature_tint_point(xy) -> np.ndarray:
    """A white's place in the DNG SDK's triple-illuminant space: (correlated colour temperature as
    min(1500/T, 1), Duv × 15) — Adobe's tint is −3000·Duv, scaled by 1/200 (colour-science's
    Robertson 1968 CCT and Duv)."""
    import colour

    cct, duv = colour.temperature.uv_to_CCT(colour.xy_to_UCS_uv(np.asarray(xy, dtype=np.float64)),
                                            method="Robertson 1968")
    return np.array([min(1500.0 / cct, 1.0) if cct > 0 else 1.0, 15.0 * duv])


def triple_calibration_weights(white_xy, light_xys) -> np.ndarray:
    """Weights of three calibrations for a scene white (DNG 1.6 "three calibrations"): inverse squared
    distance to each calibration light in (min(1500/T, 1), tint/200), normalised, smoothed by the
    smoothstep 3w² − 2w³, weights under 0.02 dropped (the rest rescaled from 0.02…1 to 0…1) and
    normalised again. A white at a calibration light's own chromaticity takes that calibration alone.

    Parameters
    ----------
    white_xy : array_like
        (2,) CIE 1931 xy of the scene white.
    light_xys : array_like
        (3, 2) xy of the three calibration lights, in slot order.

    Returns
    -------
    numpy.ndarray
        (3,) weights summing to 1.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 (interpolation with three calibrations);
       DNG SDK 1.7 ``CalculateTripleIlluminantWeights`` (dng_xy_coord.cpp).
    .. [2] Robertson, A. R. (1968). Computation of correlated color temperature and distribution
       temperature. JOSA 58(11), 1528–1535.
    """
    point = _temperature_tint_point(white_xy)
    distances = np.array([np.sum((point - _temperature_tint_point(xy)) ** 2) for xy in np.asarray(light_xys)])
    weights = 1.0 / (distances + 1e-8)
    weights /= weights.sum()
    weights = weights * weights * (3.0 - 2.0 * weights)  # smoothstep
    weights = np.clip((weights - 0.02) / 0.98, 0.0, 1.0)
    return weights / weights.sum()


def _xy_of(xyz) -> np.ndarray:
    xyz = np.asarray(xyz, dtype=np.float64)
    return xyz[:2] / xyz.sum()


#: CIE 1931 xy of the DNG's D65 and Standard A calibration lights (CIE 15:2004 Table T.3).
_XY_D65, _XY_A = np.array([0.31272, 0.32903]), np.array([0.44757, 0.40745])


def triple_profile(raw, neutral, *, iterations: int = 30) -> tuple[np.ndarray, np.ndarray]:
    """(weights, scene white xy) of a RAW's three calibrations (D65, Standard A, ``raw.calibration_3``)
    for a camera neutral: the white's xy and the weighted colour matrix depend on each other, so both
    are iterated from D50 as the DNG SDK does (``NeutralToXY``).

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6; DNG SDK 1.7 ``dng_color_spec::NeutralToXY``.
    """
    third = raw.calibration_3
    matrices = [np.asarray(m, dtype=np.float64)[:3] for m in (raw.color_matrix, raw.color_matrix_2, third.color_matrix)]
    lights = np.array([_XY_D65, _XY_A, np.asarray(third.white_xy, dtype=np.float64)])
    n = np.asarray(neutral, dtype=np.float64)[:3]
    xy = np.array([0.34567, 0.35850])  # D50, the SDK's start
    weights = triple_calibration_weights(xy, lights)
    for _ in range(iterations):
        weights = triple_calibration_weights(xy, lights)
        xyz = np.linalg.solve(sum(w * m for w, m in zip(weights, matrices)), n)
        if not np.all(np.isfinite(xyz)) or xyz.sum() <= 0:
            raise ConfigError("the DNG's three colour matrices map the neutral to no physical white")
        new = _xy_of(xyz)
        if np.abs(new - xy).sum() < 1e-7:
            xy = new
            break
        xy = new
    return triple_calibration_weights(xy, lights), xy
