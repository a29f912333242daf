"""Statistics across a validation's cells: paired pipeline comparisons over the noise seeds and the
pivot of mean ΔE2000 by pipeline × illuminant (the report's tables, comparisons.csv, pivot.csv).

References
----------
.. [1] Student (1908). The probable error of a mean. Biometrika 6(1), 1–25 (paired t interval).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from .run import ValidationResult

__all__ = ["compare_pipelines", "pivot"]


def compare_pipelines(result: "ValidationResult") -> list[dict]:
    """Each ``plan.compare`` pair's difference in mean ΔE2000, cell by cell, paired over the noise
    seeds (both pipelines develop the same RAWs: common random numbers).

    Returns
    -------
    list of dict
        ``set``, ``illuminant``, ``camera``, ``exposure``, ``a``, ``b``, ``difference`` (a − b,
        mean over the seeds), ``ci95`` (half-width, Student's t on the paired differences; None
        with one seed) and ``significant`` (the interval excludes 0; False with one seed).

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
                         "significant": bool(half is not None and abs(mean) > half)})
    return rows


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
