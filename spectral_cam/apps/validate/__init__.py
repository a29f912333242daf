"""Colour-pipeline validation against spectral ground truth: ``spectral-cam validate``.

A *plan* (TOML, :mod:`.plan`) names a matrix of illuminants × cameras × exposures ×
reflectance sets and the pipelines to evaluate on it. For every cell (:mod:`.run`) the
simulator builds a chart of the reflectances under the illuminant, exposes it on the camera's
measured curves, writes the RAW as a DNG and hands it to each pipeline (:mod:`.pipelines`);
each pipeline's linear output is compared, patch by patch, with the colorimetric ground truth
computed from the spectra. :mod:`.report` writes the HTML page and CSVs; :mod:`.selfcheck`
holds the simulator's own physics checks (``--self``).

    spectral-cam validate PLAN.toml -o REPORT_DIR [--set section.key=value]... [--force]
    spectral-cam validate --self [--csv PATH]

Ground truth (one definition everywhere, :mod:`spectral_cam.colour_ground_truth`): CIE 1931 2° XYZ
of each reflectance under the scene illuminant (colour-science integration on the CMFs'
1-nm grid, the perfect diffuser at Y = 1) → Bradford chromatic adaptation (von Kries) from
the illuminant's white to D65 → linear sRGB, unclipped.

The chart: ``chart = "synthetic"`` (the default) is :func:`spectral_cam.radiance_targets.synthetic_chart`
— each reflectance a square block of ``patch_px`` pixels of band radiance
``L_b = ∫_b ρ(λ)·E(λ)/π dλ``, exactly what a render of flat Lambertian patches facing the
camera converges to, without Monte-Carlo noise; ``chart = "render"`` renders the
``colorchecker`` scene preset with Mitsuba instead (the plan's ``[scene]``, ``[lens]``,
``[render]`` tables apply). Sets other than the ColorChecker get its white patch
(:data:`spectral_cam.colour_ground_truth.WHITE_PATCH`) appended as the white reference, excluded from
their statistics.

References
----------
.. [1] docs/design.md, "Ground truth and metrics" and "Registries".
.. [2] CIE 15:2004, Colorimetry, 3rd ed., §7 (tristimulus values), §8.2.1 (CIELAB).
.. [3] Lam, K. M. (1985). Metamerism and colour constancy. PhD thesis, University of
   Bradford; CIE 160:2004 (the Bradford chromatic adaptation transform).
.. [4] CIE 224:2017 (99 samples); CIE 13.3-1995 (test colour samples); Davis, W., & Ohno, Y.
   (2010). Color quality scale. Optical Engineering 49(3); AMPAS rawtoaces (190 training
   reflectances); Pascale, D. (2006), BabelColor ColorChecker data.
"""

from __future__ import annotations

from ...radiance_targets import REFLECTANCE_SETS, reflectance_set
from .pipelines import PIPELINES, CellContext, Pipeline, pipeline_type
from .plan import ExposureSpec, Plan, Thresholds, load_plan, plan_from_dict
from .run import (CellResult, ValidationResult, angular_error_deg, calibration_sample, evaluate_patches,
                  gamut_clipped, lab_difference_split, rendered_chart, run_plan, tone_slope)
from .statistics import compare_pipelines, pivot
from .selfcheck import SELF_CHECKS, CheckResult, format_checks, self_checks, write_checks_csv

__all__ = [
    "load_plan", "plan_from_dict", "run_plan", "self_checks", "format_checks", "write_checks_csv",
    "Plan", "Thresholds", "ExposureSpec", "CellResult", "ValidationResult", "CheckResult",
    "PIPELINES", "Pipeline", "CellContext", "pipeline_type", "SELF_CHECKS",
    "evaluate_patches", "angular_error_deg", "rendered_chart", "reflectance_set", "REFLECTANCE_SETS",
    "calibration_sample", "compare_pipelines", "pivot", "lab_difference_split", "gamut_clipped", "tone_slope",
]
