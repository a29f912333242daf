"""The validation report's CSV files: every number the page shows, at full precision.

- ``cells.csv``: one row per cell (set, illuminant, camera, exposure, pipeline) with the
  status, ΔE2000 mean / 95th percentile / max, white-balance angular error, SNR summary,
  exposure, gain and run time (:data:`CELL_COLUMNS`);
- ``patches.csv``: one row per cell and patch with the ground-truth and pipeline linear
  sRGB, their CIELAB (D65), ΔE2000 and SNR (:data:`PATCH_COLUMNS`);
- ``pivot.csv``, ``comparisons.csv``, ``metamerism.csv``: the tables of
  :mod:`spectral_cam.apps.validate.statistics` (:func:`write_summary_csvs`).

Numbers are unclipped linear values written by :func:`spectral_cam.records.exact_number`,
each file atomically through the package's one CSV writer.

References
----------
.. [1] docs/design.md, "Errors, outputs, provenance" (atomic files, one CSV writer).
.. [2] CIE 15:2004, Colorimetry, §8.2.1 (CIELAB).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Iterator

from ...records import exact_number, write_csv

__all__ = ["CELL_COLUMNS", "PATCH_COLUMNS", "COMPARISON_COLUMNS", "reference_data", "write_cells_csv",
           "write_patches_csv", "write_summary_csvs"]

#: Columns of cells.csv, one row per cell.
CELL_COLUMNS = ("set", "illuminant", "camera", "exposure", "pipeline", "status", "failures", "warnings", "calibration",
                "reference_data", "n_patches", "seeds", "delta_e_mean_ci95",
                "delta_e_mean", "delta_e_p95", "delta_e_max", "wb_angular_error_deg", "snr_median", "snr_min",
                "exposure_scale", "delta_l_mean", "delta_c_mean", "delta_h_mean", "patches_clipped", "tone_slope",
                "exposure_s", "iso", "K_dn_per_e", "runtime_s", "dng")
#: Columns of patches.csv, one row per cell and patch.
PATCH_COLUMNS = ("set", "illuminant", "camera", "exposure", "pipeline", "patch_index", "patch", "role",
                 "reference_r", "reference_g", "reference_b", "test_r", "test_g", "test_b",
                 "reference_L", "reference_a", "reference_b_star", "test_L", "test_a", "test_b_star",
                 "delta_e2000", "delta_l", "delta_c", "delta_h", "clipped", "snr", "snr_db")
#: patches.csv's per-patch numbers, by name (a slice by position once dropped two of them)
_PATCH_NUMBERS = ("reference_r", "reference_g", "reference_b", "test_r", "test_g", "test_b",
                  "reference_L", "reference_a", "reference_b_star", "test_L", "test_a", "test_b_star",
                  "delta_e2000", "delta_l", "delta_c", "delta_h")
#: Columns of comparisons.csv (:func:`spectral_cam.apps.validate.statistics.compare_pipelines`).
COMPARISON_COLUMNS = ("set", "illuminant", "camera", "exposure", "a", "b", "difference", "ci95", "seeds",
                      "significant")
#: Cell statistics written as they are, in CELL_COLUMNS order.
_STAT_COLUMNS = ("delta_e_mean", "delta_e_p95", "delta_e_max", "wb_angular_error_deg", "snr_median", "snr_min",
                 "exposure_scale", "delta_l_mean", "delta_c_mean", "delta_h_mean", "patches_clipped", "tone_slope")


def _role(cell, index: int) -> str:
    if index < cell.n_set:
        return "patch" if index != cell.white_index else "patch, white reference"
    return "white reference"


def _coordinates(cell) -> dict:
    return {"set": cell.set_name, "illuminant": cell.illuminant, "camera": cell.camera, "exposure": cell.exposure,
            "pipeline": cell.pipeline}


def reference_data(refset) -> str:
    """What a set's truth is computed from: its spectra's source (the scores depend on it: the
    ColorChecker's BabelColor average and ISO 17321-1's measurement of the same chart give other
    truths) and, for a set other than the ColorChecker, the white reference appended to it."""
    from ...colour_ground_truth import WHITE_PATCH
    from ...spectra import COLORCHECKER_SET

    colorchecker = f"colour-science SDS_COLOURCHECKERS[{COLORCHECKER_SET!r}]"
    if refset.name == "colorchecker":
        return f"{refset.description}; {colorchecker}"
    return f"{refset.description}; white reference: ColorChecker {WHITE_PATCH} of {colorchecker}"


def _cell_rows(result) -> Iterator[dict]:
    sources = {refset.name: reference_data(refset) for refset in result.plan.reflectance_sets}
    for c in result.cells:
        # whole numbers and the rounded run time as text: exact_number writes every number as a float
        yield {**_coordinates(c), "status": c.status, "failures": "; ".join(c.failures),
               "warnings": "; ".join(c.warnings), "calibration": c.calibration,
               "reference_data": sources.get(c.set_name, ""),
               "n_patches": str(c.n_set), "seeds": str(len(c.seed_means)), "delta_e_mean_ci95": c.delta_e_mean_ci95,
               **{k: c.stats.get(k) for k in _STAT_COLUMNS}, "exposure_s": c.exposure_s, "iso": c.iso,
               "K_dn_per_e": c.gain_dn_per_e, "runtime_s": f"{c.runtime_s:.4f}", "dng": c.dng}


def write_cells_csv(result, path: str | Path) -> Path:
    """One row per cell (see :data:`CELL_COLUMNS`), every number at full precision, written atomically."""
    return write_csv(_cell_rows(result), path, CELL_COLUMNS, number=exact_number)


def _snr_db(snr: float) -> float:
    if snr > 0 and math.isfinite(snr):
        return 20 * math.log10(snr)
    return math.inf if snr > 0 else math.nan


def _patch_rows(result) -> Iterator[dict]:
    from ...metrics.image_quality import linear_srgb_to_lab

    for c in result.cells:
        if c.test is None:
            continue
        ref_lab = linear_srgb_to_lab(c.reference)
        test_lab = linear_srgb_to_lab(c.test)
        for i, name in enumerate(c.patch_names):
            snr = float(c.snr[i])
            values = (*c.reference[i], *c.test[i], *ref_lab[i], *test_lab[i], c.delta_e[i], *c.delta_lch[i])
            yield {**_coordinates(c), "patch_index": str(i), "patch": name, "role": _role(c, i),
                   **dict(zip(_PATCH_NUMBERS, (float(v) for v in values), strict=True)),
                   "clipped": "true" if c.clipped[i] else "false", "snr": snr, "snr_db": _snr_db(snr)}


def write_patches_csv(result, path: str | Path) -> Path:
    """One row per cell and patch (see :data:`PATCH_COLUMNS`), written atomically."""
    return write_csv(_patch_rows(result), path, PATCH_COLUMNS, number=exact_number)


def write_summary_csvs(result, folder: Path) -> dict[str, Path]:
    """``pivot.csv`` (mean ΔE2000, pipeline × illuminant), ``comparisons.csv`` (the plan's paired
    differences, :data:`COMPARISON_COLUMNS`) and ``metamerism.csv`` (each pipeline's index for a
    change in illuminant) in ``folder``; returns ``{"pivot_csv", "comparisons_csv", "metamerism_csv"}``
    → path."""
    from .statistics import METAMERISM_COLUMNS, compare_pipelines, pipeline_metamerism, pivot, significance_text

    paths = {}
    names, illuminants, table = pivot(result)
    paths["pivot_csv"] = write_csv(({"pipeline": name, **{i: v for i, v in zip(illuminants, values)}}
                                    for name, values in zip(names, table)), folder / "pivot.csv",
                                   ("pipeline", *illuminants), number=exact_number)
    paths["comparisons_csv"] = write_csv(({**row, "significant": significance_text(row)}
                                          for row in compare_pipelines(result)), folder / "comparisons.csv",
                                         COMPARISON_COLUMNS, number=exact_number)
    paths["metamerism_csv"] = write_csv(pipeline_metamerism(result), folder / "metamerism.csv", METAMERISM_COLUMNS,
                                        number=exact_number)
    return paths
