"""Scoring a pipeline's image against the ground truth, patch by patch.

:func:`evaluate_patches` compares a pipeline's linear sRGB with the ground truth of
:mod:`spectral_cam.colour_ground_truth`:

- the pipeline's patch means (interiors, :data:`PATCH_MARGIN` left out on every side) are
  scaled so the white reference has the ground truth's luminance (exposure matching);
- ΔE2000 per patch (CIELAB under D65; mean, 95th percentile — NumPy's linear interpolation —
  and maximum over the set's patches);
- white-balance error: the angle (degrees) between the pipeline's and the ground truth's
  linear sRGB of the white reference (the recovery angular error, :func:`angular_error_deg`);
- noise: SNR = mean / standard deviation of the luminance Y over each patch's interior;
- where the error lies: ΔL*, ΔC*ab, ΔH*ab (:func:`lab_difference_split`), the tone response on
  the neutral patches (:func:`tone_slope`) and the patches the pipeline clipped to sRGB's gamut
  (:func:`gamut_clipped`).

References
----------
.. [1] docs/design.md, "Ground truth and metrics".
.. [2] Sharma, G., Wu, W., & Dalal, E. N. (2005). The CIEDE2000 color-difference formula.
   Color Research & Application 30(1), 21–30.
.. [3] Hordley, S. D., & Finlayson, G. D. (2006). Reevaluation of color constancy algorithm
   performance. JOSA A 23(5), 1008–1020 (angular error).
.. [4] ISO 15739:2017, Photography — Electronic still-picture imaging — Noise measurements
   (SNR of uniform patches).
.. [5] CIE 15:2004, Colorimetry, §8.2.1 (CIELAB, ΔH*ab).
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import ConfigError
from ...radiance_targets import Chart

__all__ = ["PATCH_MARGIN", "GAMUT_EDGE", "NEUTRAL_CHROMA", "TONE_SLOPE_TOLERANCE", "evaluate_patches",
           "angular_error_deg", "lab_difference_split", "gamut_clipped", "tone_slope"]

#: Fraction of each patch's size left out on every side when averaging (edges, demosaicing).
PATCH_MARGIN = 0.2


def angular_error_deg(test_rgb, reference_rgb) -> float:
    """Angle between two RGB vectors, degrees (the recovery angular error).

    Parameters
    ----------
    test_rgb, reference_rgb : array_like
        (3,) linear RGB.

    Returns
    -------
    float
        arccos(a·b / (|a||b|)) in degrees (NaN when a vector is zero).

    References
    ----------
    .. [1] Hordley & Finlayson (2006), JOSA A 23(5), 1008–1020.

    Examples
    --------
    >>> round(angular_error_deg([1, 0, 0], [0, 1, 0]), 6), angular_error_deg([1, 1, 1], [2, 2, 2]) < 1e-6
    (90.0, True)
    """
    a = np.asarray(test_rgb, dtype=float)
    b = np.asarray(reference_rgb, dtype=float)
    norm = np.linalg.norm(a) * np.linalg.norm(b)
    if not norm > 0:
        return float("nan")
    return float(np.degrees(np.arccos(np.clip(a @ b / norm, -1.0, 1.0))))


def evaluate_patches(linear: np.ndarray, chart: Chart, reference: np.ndarray) -> dict:
    """Patch statistics of a pipeline's linear sRGB image against the ground truth.

    Parameters
    ----------
    linear : numpy.ndarray
        (H, W, 3) linear sRGB, unclipped, the chart's size.
    chart : Chart
    reference : numpy.ndarray
        (N, 3) ground-truth linear sRGB of every chart patch (perfect diffuser Y = 1).

    Returns
    -------
    dict
        ``test`` (N, 3) exposure-matched patch means, ``delta_e`` (N,) ΔE2000,
        ``snr`` (N,) mean/σ of Y, ``wb_angular_error_deg``, ``exposure_scale``, and the
        set statistics ``delta_e_mean``, ``delta_e_p95``, ``delta_e_max``, ``snr_median``,
        ``snr_min``.

    Raises
    ------
    ConfigError
        If the image is the wrong size, or gives no positive luminance at the white reference
        (saying what it measured there: no pixels or Y ≤ 0 in a lit frame, misregistered).

    References
    ----------
    .. [1] Sharma, Wu & Dalal (2005) (CIEDE2000); ISO 15739:2017 (SNR); Hordley & Finlayson
       (2006) (angular error); docs/design.md, "Ground truth and metrics".
    """
    import colour

    from ...metrics.image_quality import delta_e2000, patch_means

    height, width = chart.radiance.data.shape[:2]
    if linear.shape != (height, width, 3):
        raise ConfigError(f"the pipeline's image is {linear.shape}; the chart needs ({height}, {width}, 3) — "
                          "a pipeline must return the whole frame, uncropped and unrotated")
    weights = np.asarray(colour.models.RGB_COLOURSPACE_sRGB.matrix_RGB_to_XYZ)[1]
    means = patch_means(linear, chart.patches, margin=PATCH_MARGIN)
    w = chart.white_index
    y_test = float(means[w] @ weights)
    if not y_test > 0:
        raise ConfigError(_unscorable_white(linear, chart, y_test, weights))
    scale = float(reference[w] @ weights) / y_test
    test = means * scale
    delta = delta_e2000(test, reference)
    snr = np.empty(len(chart.patches))
    for i, patch in enumerate(chart.patches):
        luminance = linear[patch.interior(PATCH_MARGIN)].reshape(-1, 3) @ weights
        sigma = float(np.std(luminance, ddof=1)) if luminance.size > 1 else 0.0
        snr[i] = float(np.mean(luminance)) / sigma if sigma > 0 else math.inf
    n = chart.n_set
    split = lab_difference_split(test, reference)
    clipped = gamut_clipped(test, reference, scale=scale)
    return {
        "test": test,
        "delta_e": delta,
        "snr": snr,
        "delta_lch": split,
        "clipped": clipped,
        "exposure_scale": scale,
        "wb_angular_error_deg": angular_error_deg(test[w], reference[w]),
        "delta_e_mean": float(np.mean(delta[:n])),
        "delta_e_p95": float(np.percentile(delta[:n], 95)),
        "delta_e_max": float(np.max(delta[:n])),
        "snr_median": float(np.median(snr[:n])),
        "snr_min": float(np.min(snr[:n])),
        "delta_l_mean": float(np.mean(np.abs(split[:n, 0]))),
        "delta_c_mean": float(np.mean(np.abs(split[:n, 1]))),
        "delta_h_mean": float(np.mean(np.abs(split[:n, 2]))),
        "patches_clipped": float(np.sum(clipped[:n])),
        "tone_slope": tone_slope(test[:n], reference[:n]),
    }


def _unscorable_white(linear: np.ndarray, chart: Chart, y_test: float, weights: np.ndarray) -> str:
    """Why the white reference gives no exposure scale, with what was measured there: no pixels
    (the image does not cover it: misregistered or cropped), or Y ≤ 0 while the rest of the frame
    is lit (the chart lies elsewhere in the image: misregistered, flipped or rotated), or a black
    frame."""
    patch = chart.patches[chart.white_index]
    where = f"the white reference ({patch.name}, centre column {patch.column}, row {patch.row})"
    interior = linear[patch.interior(PATCH_MARGIN)].reshape(-1, 3)
    covered = np.isfinite(interior).all(axis=1).mean() if interior.size else 0.0
    if covered < 1.0:
        return (f"the pipeline's image does not cover {where}: {100 * (1 - covered):.0f} % of its interior lies outside "
                "the image — misregistered (declare crop = [top, bottom, left, right], the pixels the tool removed)")
    lit = np.nanmean(linear.reshape(-1, 3) @ weights)
    if lit > 0:
        return (f"the pipeline's image measures Y = {y_test:.3g} at {where} while the frame's mean is {lit:.3g}: the "
                "chart is not where the frame has it — misregistered (shifted, flipped or rotated; check crop)")
    return f"the pipeline's image is black or negative everywhere (mean Y {lit:.3g}; {y_test:.3g} at {where})"


def lab_difference_split(test: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(N, 3) ΔL*, ΔC*ab and ΔH*ab (test − reference; ΔH signed by the hue angle's turn) of
    linear sRGB colours in CIELAB (D65): where a colour error lies — lightness (tone, exposure),
    chroma (saturation) or hue (the matrix).

    References
    ----------
    .. [1] CIE 15:2004, Colorimetry, §8.2.1 (ΔH*ab = √(ΔE*ab² − ΔL*² − ΔC*ab²)).
    """
    from ...metrics.image_quality import linear_srgb_to_lab

    t, r = linear_srgb_to_lab(test), linear_srgb_to_lab(reference)
    dl = t[:, 0] - r[:, 0]
    ct, cr = np.hypot(t[:, 1], t[:, 2]), np.hypot(r[:, 1], r[:, 2])
    dc = ct - cr
    de2 = np.sum((t - r) ** 2, axis=1)
    dh = np.sqrt(np.clip(de2 - dl ** 2 - dc ** 2, 0.0, None))
    turn = np.sign(np.sin(np.arctan2(t[:, 2], t[:, 1]) - np.arctan2(r[:, 2], r[:, 1])))
    return np.stack([dl, dc, dh * np.where(turn == 0, 1.0, turn)], axis=1)


#: A channel within this of 0 or 1 (after exposure matching) is taken as at the sRGB gamut's edge.
GAMUT_EDGE = 2e-3


def gamut_clipped(test: np.ndarray, reference: np.ndarray, *, scale: float = 1.0) -> np.ndarray:
    """(N,) True where a channel of the truth lies outside the sRGB gamut of the pipeline's output
    (< 0, or > 1 of its full scale) and the pipeline's same channel sits on that edge: the pipeline
    clipped it, so its ΔE measures sRGB's gamut, not the pipeline.

    ``test`` and ``reference`` are exposure-matched (``test = means × scale``); the edges are the
    pipeline's own 0 and 1, so both are compared in its units (÷ ``scale``): with the white
    reference developed at 0.68 (scale 1.46), a truth of 1.01 was within its range, and its 0.998
    after matching was no clip."""
    test, reference = np.asarray(test) / scale, np.asarray(reference) / scale
    below, above = reference < -GAMUT_EDGE, reference > 1.0 + GAMUT_EDGE
    clipped = (below & (np.abs(test) <= GAMUT_EDGE)) | (above & (np.abs(test - 1.0) <= GAMUT_EDGE))
    return np.any(clipped, axis=1)


#: Neutral patches (CIELAB chroma below this) carry the tone response.
NEUTRAL_CHROMA = 4.0
#: A tone response whose log-log slope leaves 1 by more than this is a tone curve, not linear.
TONE_SLOPE_TOLERANCE = 0.05


def tone_slope(test: np.ndarray, reference: np.ndarray) -> float:
    """The slope of log Y(pipeline) against log Y(truth) over the neutral patches (NaN with fewer
    than three): 1 for a linear develop, the exponent of a power law otherwise (≈ 1/2.2 for a
    gamma-encoded image read as linear; a filmic curve lowers it)."""
    from ...metrics.image_quality import linear_srgb_to_lab

    lab = linear_srgb_to_lab(reference)
    weights = np.array([0.2126, 0.7152, 0.0722])  # sRGB's Y
    y_test, y_ref = test @ weights, reference @ weights
    neutral = (np.hypot(lab[:, 1], lab[:, 2]) < NEUTRAL_CHROMA) & (y_test > 0) & (y_ref > 0)
    if neutral.sum() < 3 or np.ptp(np.log(y_ref[neutral])) < 0.5:
        return float("nan")
    return float(np.polyfit(np.log(y_ref[neutral]), np.log(y_test[neutral]), 1)[0])
