"""Running a plan: every pipeline on every exposed chart, the cells' statistics over the seeds.

For every reflectance set × illuminant × camera × exposure the chart is exposed once per seed
(:mod:`.exposures`) and written as DNGs; every pipeline develops them, and each image is scored
against the ground truth (:func:`~.scoring.evaluate_patches`). A cell's statistics are their
means over the seeds, with a 95 % Student's t interval of the mean ΔE2000 (:func:`_combine`);
what makes a number untrustworthy without failing it is a warning of the cell (a tone curve,
clipped patches, a white reference balanced on itself). A pipeline that fails the same way on
:data:`FAIL_FAST_AFTER` cells in a row is not run on the rest.

References
----------
.. [1] docs/design.md, "Ground truth and metrics".
.. [2] Student (1908). The probable error of a mean. Biometrika 6(1), 1–25 (the interval).
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import shutil
import tempfile
import time
import traceback
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

from ...errors import SpectralCamError
from .exposures import Exposed, exposed_charts, rendered_chart
from .pipelines import CellContext
from .plan import Plan
from .results import CellResult, ValidationResult
# scoring, results and the charts live in their own modules; their names stay importable from here
from .scoring import (PATCH_MARGIN, TONE_SLOPE_TOLERANCE, angular_error_deg, evaluate_patches, gamut_clipped,
                      lab_difference_split, tone_slope)

__all__ = ["PATCH_MARGIN", "CellResult", "ValidationResult", "run_plan", "evaluate_patches",
           "angular_error_deg", "rendered_chart", "calibration_sample", "lab_difference_split", "gamut_clipped",
           "tone_slope"]


def calibration_sample(set_name: str, raw_meta: dict | None) -> str:
    """Is a score in sample? The RAW's colour matrices (DNG ColorMatrix/ForwardMatrix, and the
    fitted corrections ``ours`` reads) were fitted on ``raw_meta["colour_calibration"]``'s
    training set: a cell scoring that set is in sample, any other set out of sample."""
    record = (raw_meta or {}).get("colour_calibration")
    if not record:
        return "unknown (no colour matrices)"
    training = record["training_set"]
    if set_name.lower() == training.lower():
        return f"in sample ({training})"
    return f"out of sample (fitted on {training}, {record['training_count']} reflectances)"


#: A white reference this much closer to grey (R = G = B) than its truth is taken as balanced
#: on itself: the ColorChecker's white 9.5 is 1.5° from grey in linear sRGB; as-shot balance
#: leaves it 0.1–1.5° off its truth, in any direction.
SELF_BALANCED_FRACTION = 0.1


def _context(exposed: Exposed) -> CellContext:
    """What a pipeline is told about the cell (:class:`~.pipelines.CellContext`)."""

    chart, meta = exposed.chart, exposed.raw.meta or {}
    height, width = chart.radiance.data.shape[:2]
    patches = [{"name": p.name, "column": p.column, "row": p.row, "half_width_px": p.half_width_px,
                "half_height_px": p.half_height_px, "role": "white reference" if i == chart.white_index else "patch"}
               for i, p in enumerate(chart.patches)]
    return CellContext(exposed.refset.name, exposed.illuminant, exposed.camera, exposed.exposure.name,
                       (int(width), int(height)), patches, int(chart.white_index),
                       float(meta.get("exposure_s", float("nan"))), float(meta.get("iso", exposed.exposure.iso)))


def _user_frames(trace: str, limit: int = 12) -> str:
    """A traceback's last ``limit`` frames' lines (where a user's function failed)."""
    lines = trace.rstrip().splitlines()
    return "\n".join(lines[-3 * limit:])


def _cell_fields(pipeline, exposed: Exposed) -> dict:
    """What a cell records whatever its pipeline did: its coordinates, chart, truth and RAW."""
    chart, meta = exposed.chart, exposed.raw.meta or {}
    return dict(set_name=exposed.refset.name, illuminant=exposed.illuminant, camera=exposed.camera,
                exposure=exposed.exposure.name, pipeline=pipeline.name, patch_names=[p.name for p in chart.patches],
                n_set=chart.n_set, white_index=chart.white_index, reference=exposed.reference,
                exposure_s=float(meta.get("exposure_s", float("nan"))), iso=float(meta.get("iso", exposed.exposure.iso)),
                gain_dn_per_e=float(meta.get("K_dn_per_e", float("nan"))), dng=f"raw/{exposed.dng_name}",
                calibration=calibration_sample(exposed.refset.name, meta))


def _cell_warnings(stats: dict, test_white: np.ndarray, reference_white: np.ndarray) -> list[str]:
    """What makes a scored cell's numbers untrustworthy without failing it: a tone curve (the
    neutral patches' log-log slope off 1 by more than :data:`TONE_SLOPE_TOLERANCE`), patches
    clipped to sRGB's gamut, and a white reference balanced on itself (it comes out
    :data:`SELF_BALANCED_FRACTION` closer to grey than its truth is)."""
    warnings = []
    if abs(stats["tone_slope"] - 1.0) > TONE_SLOPE_TOLERANCE:  # NaN compares False: no neutrals, no warning
        warnings.append(f"a tone curve: the neutral patches' luminance follows the truth's to the power "
                        f"{stats['tone_slope']:.2f}, not 1 (an encoded image read as linear is ≈ 0.45; a filmic or "
                        "S-curve also bends it): ΔE then measures the curve; declare the output's encoding or "
                        "turn the curve off")
    if stats["patches_clipped"]:
        warnings.append(f"{int(stats['patches_clipped'])} patch(es) lie outside the sRGB gamut and came out on its "
                        "edge: their ΔE measures the gamut, not the pipeline")
    grey = angular_error_deg(test_white, np.ones(3))
    tint = angular_error_deg(reference_white, np.ones(3))  # the truth's own, from grey
    if grey < SELF_BALANCED_FRACTION * tint:
        warnings.append(f"the white reference comes out grey ({grey:.3f}° from R = G = B, its truth "
                        f"{tint:.2f}°): a pipeline that "
                        "white-balances on the patch the metric scores makes its WB error the patch's own tint, not "
                        "a measurement of the balance (balance on the light or on another patch)")
    return warnings


def _run_cell(pipeline, exposed: Exposed, dng_path: Path, work_dir: Path, plan: Plan) -> CellResult:
    """One pipeline on one exposed chart; a pipeline that fails gives an ``"error"`` cell with
    its message and traceback."""
    chart, raw = exposed.chart, exposed.raw
    common = _cell_fields(pipeline, exposed)
    t0 = time.perf_counter()
    try:
        linear = pipeline.develop(raw, dng_path, work_dir, context=_context(exposed))
        runtime = time.perf_counter() - t0
        measured = evaluate_patches(np.asarray(linear, dtype=np.float64), chart, exposed.reference)
    except Exception as exc:  # a user's pipeline may fail in any way; record it, go on
        message = str(exc) if isinstance(exc, SpectralCamError) else f"{type(exc).__name__}: {exc}"
        return CellResult(status="error", failures=[message], test=None, delta_e=None, snr=None, stats={},
                          runtime_s=time.perf_counter() - t0, traceback=_user_frames(traceback.format_exc()), **common)
    stats = {k: measured[k] for k in ("delta_e_mean", "delta_e_p95", "delta_e_max", "wb_angular_error_deg",
                                      "snr_median", "snr_min", "exposure_scale", "delta_l_mean", "delta_c_mean",
                                      "delta_h_mean", "patches_clipped", "tone_slope")}
    warnings = _cell_warnings(stats, measured["test"][chart.white_index], exposed.reference[chart.white_index])
    failures = plan.thresholds.failures(stats)
    return CellResult(status="fail" if failures else "pass", failures=failures, test=measured["test"],
                      delta_e=measured["delta_e"], snr=measured["snr"], stats=stats, runtime_s=runtime,
                      warnings=warnings, delta_lch=measured["delta_lch"], clipped=measured["clipped"], **common)


def _skipped_cell(pipeline, exposed: Exposed, message: str) -> CellResult:
    """The error cell of a pipeline not run again after failing alike :data:`FAIL_FAST_AFTER` times."""
    return CellResult(status="error",
                      failures=[f"not run: it failed the same way on its last {FAIL_FAST_AFTER} cells ({message})"],
                      test=None, delta_e=None, snr=None, stats={}, runtime_s=0.0, **_cell_fields(pipeline, exposed))


def _combine(runs: list[CellResult], plan: Plan) -> CellResult:
    """One cell from its seeds' runs: the statistics' means over the seeds, the 95 % confidence
    interval of the mean ΔE (Student's t, n − 1 degrees of freedom), the first seed's patches;
    an error in any seed makes the cell that error."""
    import dataclasses

    from scipy import stats as scipy_stats

    first = runs[0]
    errors = [run for run in runs if run.status == "error"]
    if errors:
        return errors[0]
    means = [run.stats["delta_e_mean"] for run in runs]
    if len(runs) == 1:
        return dataclasses.replace(first, seed_means=means)
    combined = {key: float(np.mean([run.stats[key] for run in runs])) for key in first.stats}
    half = float(scipy_stats.t.ppf(0.975, len(means) - 1) * np.std(means, ddof=1) / math.sqrt(len(means)))
    failures = plan.thresholds.failures(combined)
    warnings = list(dict.fromkeys(w for run in runs for w in run.warnings))
    return dataclasses.replace(first, stats=combined, status="fail" if failures else "pass", failures=failures,
                               warnings=warnings, seed_means=means, delta_e_mean_ci95=half,
                               runtime_s=float(sum(run.runtime_s for run in runs)))


def _run_seeds(pipeline, seeded: list[Exposed], paths: list[Path], work_dir: Path, plan: Plan) -> CellResult:
    """One pipeline on every seed's RAW of a cell, combined (:func:`_combine`); the first seed
    that fails ends it, as the others would fail alike."""
    runs = []
    for exposed, path in zip(seeded, paths):
        runs.append(_run_cell(pipeline, exposed, path, work_dir, plan))
        if runs[-1].status == "error":
            break  # the other seeds would fail alike
    return _combine(runs, plan)


#: A pipeline that fails with the same message on this many cells in a row is not run on the rest.
FAIL_FAST_AFTER = 3


def failure_signature(message: str, *, stage: Path, pipeline: str, dng_name: str) -> str:
    """A failure message with what differs from cell to cell replaced, so that a pipeline failing
    the same way on every cell is seen to (:data:`FAIL_FAST_AFTER`): paths inside the report's
    staging folder (the DNG, a command's scratch folder) → ``<file>``, the cell's DNG name →
    ``<dng>``, a command's scratch-folder name (``<pipeline>-`` and 8 random characters,
    :mod:`tempfile`'s) → ``<scratch>``."""
    text = re.sub(re.escape(str(stage)) + r"""[^\s'"]*""", "<file>", message)
    text = text.replace(Path(dng_name).stem, "<dng>")
    return re.sub(re.escape(pipeline) + r"-[a-z0-9_]{8}", "<scratch>", text)


@contextlib.contextmanager
def _workspace(output_dir: str | Path | None, force: bool) -> Iterator[Path]:
    """The report's staging folder (published whole at the end), or a temporary one."""
    from ...io import staged_directory

    if output_dir is not None:
        with staged_directory(output_dir, force=force) as stage:
            yield stage
        return
    with tempfile.TemporaryDirectory(prefix="spectral-cam-validate-") as folder:
        yield Path(folder)


def run_plan(plan: Plan, output_dir: str | Path | None = None, *, force: bool = False,
             progress: Callable[[str], None] | None = None) -> ValidationResult:
    """Run every cell of a plan; write the report, CSVs and DNGs into ``output_dir``.

    Parameters
    ----------
    plan : Plan
    output_dir : str or path-like, optional
        Report folder (written atomically: it appears complete or not at all); None runs
        in a temporary folder and writes nothing.
    force : bool
        Replace an existing ``output_dir``.
    progress : callable, optional
        Called with one line of text per finished cell (e.g.
        :meth:`spectral_cam.progress.ProgressLine.log`).

    Returns
    -------
    ValidationResult

    Raises
    ------
    ConfigError
        If ``output_dir`` exists without ``force``. A pipeline that fails does not stop
        the run: its cells get status ``"error"`` with the message.

    References
    ----------
    .. [1] See the module docstring (ground truth, ΔE2000, angular error, SNR).

    Examples
    --------
    >>> from spectral_cam.apps.validate import plan_from_dict
    >>> plan = plan_from_dict({"validate": {"patch_px": 8},
    ...                        "pipeline": [{"type": "ours", "isp": {"tone": "linear"}}]})
    >>> result = run_plan(plan)  # nothing written
    >>> cell = result.cells[0]
    >>> len(result.cells), cell.status, cell.stats["delta_e_mean"] < 3.0
    (1, 'pass', True)
    """
    from ...raw import write_dng
    from ...records import package_versions, write_json

    if output_dir is not None:  # commands run in the plan's folder: every path they get must be absolute
        output_dir = Path(os.path.abspath(output_dir))
    started = time.perf_counter()
    versions = package_versions()
    cells: list[CellResult] = []
    total = (len(plan.reflectance_sets) * len(plan.illuminants) * len(plan.cameras) * len(plan.exposures)
             * len(plan.pipelines))
    with _workspace(output_dir, force) as stage:
        raw_dir = stage / "raw"
        raw_dir.mkdir(parents=True, exist_ok=True)
        work_dir = Path(tempfile.mkdtemp(prefix=".work-", dir=stage))
        # each pipeline's errors in a row: (message, its signature without the cell's file names)
        repeated: dict[str, list[tuple[str, str]]] = {p.name: [] for p in plan.pipelines}
        for seeded in exposed_charts(plan):
            paths = [write_dng(exposed.raw, raw_dir / exposed.dng_name) for exposed in seeded]
            for pipeline in plan.pipelines:
                errors = repeated[pipeline.name]
                if len(errors) >= FAIL_FAST_AFTER and len({signature for _, signature in errors}) == 1:
                    cell = _skipped_cell(pipeline, seeded[0], errors[-1][0])
                else:
                    cell = _run_seeds(pipeline, seeded, paths, work_dir, plan)
                    signature = failure_signature(cell.failures[0], stage=stage, pipeline=pipeline.name,
                                                  dng_name=seeded[0].dng_name) if cell.status == "error" else ""
                    repeated[pipeline.name] = errors + [(cell.failures[0], signature)] if cell.status == "error" else []
                cells.append(cell)
                if progress is not None:
                    progress(cell.summary(len(cells), total))
        shutil.rmtree(work_dir, ignore_errors=True)
        result = ValidationResult(plan, cells, time.perf_counter() - started,
                                  Path(output_dir) if output_dir is not None else None, versions)
        if output_dir is not None:
            from .report import write_report

            write_json({"plan": plan.to_dict(), "versions": versions}, stage / "plan.json")
            write_report(result, stage)
    result.elapsed_s = time.perf_counter() - started
    return result
