"""Statistics across a validation's cells: paired pipeline comparisons over the noise seeds and the
pivot of mean ΔE2000 by pipeline × illuminant (the report's tables, comparisons.csv, pivot.csv).

References
----------
.. [1] Student (1908). The probable error of a mean. Biometrika 6(1), 1–25 (paired t interval).
.. [2] CIE 15:2004, Colorimetry, §8.2 (metamerism indices: change in illuminant).
.. [3] Fairman, H. S. (1987). Metameric correction using parameric decomposition. Color Research
   & Application 12(5), 261–265 (additive and multiplicative corrections of a near-match).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from .results import ValidationResult

__all__ = ["compare_pipelines", "significance_text", "pivot", "sensitivity_metamerism_index", "cct_sweep",
           "illuminant_metamerism_index", "pipeline_metamerism", "METAMERISM_COLUMNS"]


def compare_pipelines(result: "ValidationResult") -> list[dict]:
    """Each ``plan.compare`` pair's difference in mean ΔE2000, cell by cell, paired over the noise
    seeds (both pipelines develop the same RAWs: common random numbers).

    Returns
    -------
    list of dict
        ``set``, ``illuminant``, ``camera``, ``exposure``, ``a``, ``b``, ``difference`` (a − b,
        mean over the seeds), ``ci95`` (half-width, Student's t on the paired differences; None
        with one seed) and ``significant`` (True: the interval excludes 0; False: it holds 0;
        None with one seed, where there is no interval and nothing can be called either,
        :func:`significance_text`).

    References
    ----------
    .. [1] Student (1908). The probable error of a mean. Biometrika 6(1), 1–25 (paired t interval).
    """
    from scipy import stats as scipy_stats

    rows = []
    by_key = {cell.key: cell for cell in result.cells}
    for a, b in result.plan.compare:
        for key, cell_a in by_key.items():
            if key[4] != a or (key[:4] + (b,)) not in by_key:
                continue
            cell_b = by_key[key[:4] + (b,)]
            if cell_a.status == "error" or cell_b.status == "error":
                continue
            differences = np.subtract(cell_a.seed_means, cell_b.seed_means)
            n = len(differences)
            half = float(scipy_stats.t.ppf(0.975, n - 1) * np.std(differences, ddof=1) / math.sqrt(n)) if n > 1 \
                else None
            mean = float(np.mean(differences))
            rows.append({"set": key[0], "illuminant": key[1], "camera": key[2], "exposure": key[3], "a": a, "b": b,
                         "difference": mean, "ci95": half, "seeds": n,
                         "significant": None if half is None else bool(abs(mean) > half)})
    return rows


def significance_text(row: dict) -> str:
    """How a comparison row reads (comparisons.csv, the report): ``"true"`` (the 95 % interval
    excludes 0), ``"false"`` (it holds 0: not significant), or ``"no interval (1 seed)"`` — one
    noise realisation gives no interval, so a difference is neither significant nor not."""
    if row["significant"] is None:
        return f"no interval ({row['seeds']} seed)"
    return str(bool(row["significant"])).lower()


def pivot(result: "ValidationResult") -> tuple[list[str], list[str], np.ndarray]:
    """Mean ΔE2000 by pipeline (rows) × illuminant (columns), averaged over the sets, cameras and
    exposures of cells that ran (NaN where none did)."""
    pipelines = [p.name for p in result.plan.pipelines]
    illuminants = list(result.plan.illuminants)
    table = np.full((len(pipelines), len(illuminants)), np.nan)
    for i, name in enumerate(pipelines):
        for j, illuminant in enumerate(illuminants):
            values = [c.stats["delta_e_mean"] for c in result.cells
                      if c.pipeline == name and c.illuminant == illuminant and c.status != "error"]
            if values:
                table[i, j] = float(np.mean(values))
    return pipelines, illuminants, table


#: The ColorChecker patches ISO 17321-1's index averages over: the 18 chromatic ones (1–18).
SMI_PATCHES = slice(0, 18)


def sensitivity_metamerism_index(camera: str, illuminant: str) -> float:
    """ISO 17321-1's Digital Still Camera Sensitivity Metamerism Index of a camera under an
    illuminant: SMI = 100 − 5.5 × the mean CIE 1976 ΔE*ab of the 18 chromatic ColorChecker patches
    after the camera's best 3 × 3 for them under that illuminant (the one minimising Σ ΔE*ab²,
    started from the least-squares fit in XYZ). 100: the camera sees colour as the CIE observer
    does; a typical DSLR scores 75–90.

    References
    ----------
    .. [1] ISO 17321-1:2012, Graphic technology and photography — Colour characterisation of
       digital still cameras (DSCs) — Part 1: Stimuli, metrology and test procedures, Annex (SMI).
    .. [2] CIE 15:2004, §8.2.1 (CIELAB, ΔE*ab).
    """
    import colour

    from ...colour_ground_truth import illuminant_white_xyz, reflectance_xyz
    from ...sensor.colour_calibration import camera_responses, xyz_to_camera_matrix
    from ...spectra import colorchecker_reflectances

    patches = list(colorchecker_reflectances().values())[SMI_PATCHES]
    fitted = xyz_to_camera_matrix(camera, illuminant, reflectances=patches)  # XYZ → camera, white exact
    camera_rgb = camera_responses(camera, illuminant, patches)
    white = camera_responses(camera, illuminant, [1.0])[0]
    from scipy.optimize import least_squares

    white_xy = colour.XYZ_to_xy(illuminant_white_xyz(illuminant))
    rgb = camera_rgb / white.max()
    truth_lab = colour.XYZ_to_Lab(reflectance_xyz(illuminant, patches), white_xy)

    def residuals(m):
        return (colour.XYZ_to_Lab(rgb @ m.reshape(3, 3).T, white_xy) - truth_lab).ravel()

    # from the least-squares fit in XYZ to the one minimising Σ ΔE*ab² (ISO 17321-1's optimisation)
    best = least_squares(residuals, np.linalg.inv(fitted).ravel()).x
    delta = np.linalg.norm(residuals(best).reshape(-1, 3), axis=1)
    return float(100.0 - 5.5 * delta.mean())


def cct_sweep(result: "ValidationResult") -> tuple[list[float], dict[str, list[float]]] | None:
    """Mean ΔE2000 per pipeline against the illuminants' correlated colour temperature (Robertson
    1968 on CIE 1960 uv of each illuminant's white), averaged over the other axes; None with fewer
    than three illuminants. Returns (CCTs in K, ascending; pipeline → means)."""
    from ...cie import cct_robertson1968, xy_to_uv_1960, xyz_to_xy
    from ...colour_ground_truth import illuminant_white_xyz

    illuminants = list(result.plan.illuminants)
    if len(illuminants) < 3:
        return None
    ccts = {name: float(cct_robertson1968(xy_to_uv_1960(xyz_to_xy(illuminant_white_xyz(name))))[0])
            for name in illuminants}
    order = sorted(illuminants, key=ccts.get)
    means = {}
    for pipeline in (p.name for p in result.plan.pipelines):
        means[pipeline] = [float(np.mean([c.stats["delta_e_mean"] for c in result.cells
                                          if c.pipeline == pipeline and c.illuminant == name and c.stats] or [np.nan]))
                           for name in order]
    return [ccts[name] for name in order], means


def illuminant_metamerism_index(reference_pair, test_pair) -> np.ndarray:
    """CIE special metamerism index for a change in illuminant, with the additive correction.

    Two samples that match under a reference illuminant may not under a test one; the index is
    their CIE 1976 colour difference under the test illuminant. When they do not match exactly under
    the reference, the reference mismatch is taken off component by component in CIELAB (the
    additive correction): M_t = ‖(Lab_b − Lab_a)_test − (Lab_b − Lab_a)_reference‖.

    Parameters
    ----------
    reference_pair : tuple of array_like
        (Lab_a, Lab_b), each (..., 3) CIELAB under the reference illuminant.
    test_pair : tuple of array_like
        (Lab_a, Lab_b) under the test illuminant.

    Returns
    -------
    numpy.ndarray
        (...) the index in ΔE*ab units; 0 where the pair's difference does not change.

    References
    ----------
    .. [1] CIE 15:2004, Colorimetry, §8.2 (special metamerism index: change in illuminant).
    .. [2] Fairman (1987), Color Res. Appl. 12(5), 261–265 (the additive correction).
    """
    ref_a, ref_b = (np.asarray(lab, dtype=float) for lab in reference_pair)
    test_a, test_b = (np.asarray(lab, dtype=float) for lab in test_pair)
    return np.linalg.norm((test_b - test_a) - (ref_b - ref_a), axis=-1)


#: Columns of metamerism.csv (:func:`pipeline_metamerism`).
METAMERISM_COLUMNS = ("set", "camera", "exposure", "pipeline", "reference", "test", "index_mean", "index_max",
                      "delta_e_ab_reference", "delta_e_ab_test")


def pipeline_metamerism(result: "ValidationResult", reference: str | None = None) -> list[dict]:
    """Each pipeline's metamerism index for a change in illuminant, per set × camera × exposure.

    The pair is the pipeline's reproduction of each patch and its truth (both in CIELAB, D65, the
    white Bradford-adapted as the report scores them). Under the reference illuminant they nearly
    match; :func:`illuminant_metamerism_index` says how much of the mismatch under each other
    illuminant is new: a camera whose curves are not colour-matching functions, and a pipeline whose
    matrix was made for another light, reproduce the change of light wrongly. The first noise
    seed's patches, the set's own (not the white reference's padding).

    Parameters
    ----------
    result : ValidationResult
    reference : str, optional
        The reference illuminant; default D65 where the plan has it, else its first.

    Returns
    -------
    list of dict
        :data:`METAMERISM_COLUMNS`: the index's mean and max over the patches, and the mean ΔE*ab
        of the pair under the reference and the test illuminant.

    References
    ----------
    .. [1] CIE 15:2004, Colorimetry, §8.2 (special metamerism index: change in illuminant).
    """
    from ...metrics.image_quality import linear_srgb_to_lab

    illuminants = list(result.plan.illuminants)
    if reference is None:
        reference = "D65" if "D65" in illuminants else illuminants[0]
    by_key = {cell.key: cell for cell in result.cells if cell.test is not None}
    rows = []
    for (set_name, illuminant, camera, exposure, pipeline), cell in by_key.items():
        if illuminant != reference:
            continue
        for test in illuminants:
            other = by_key.get((set_name, test, camera, exposure, pipeline))
            if test == reference or other is None:
                continue
            n = min(cell.n_set, other.n_set)
            ref_pair = (linear_srgb_to_lab(cell.reference[:n]), linear_srgb_to_lab(cell.test[:n]))
            test_pair = (linear_srgb_to_lab(other.reference[:n]), linear_srgb_to_lab(other.test[:n]))
            index = illuminant_metamerism_index(ref_pair, test_pair)
            rows.append({"set": set_name, "camera": camera, "exposure": exposure, "pipeline": pipeline,
                         "reference": reference, "test": test, "index_mean": float(index.mean()),
                         "index_max": float(index.max()),
                         "delta_e_ab_reference": float(np.linalg.norm(ref_pair[1] - ref_pair[0], axis=1).mean()),
                         "delta_e_ab_test": float(np.linalg.norm(test_pair[1] - test_pair[0], axis=1).mean())})
    return rows
