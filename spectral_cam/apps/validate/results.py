"""What a plan run measured: :class:`CellResult` (one pipeline on one reflectance set ×
illuminant × camera × exposure) and :class:`ValidationResult` (every cell of a plan).

The report (:mod:`.report`), the statistics (:mod:`.statistics`) and the CSVs read these; the
run (:mod:`.run`) makes them.

References
----------
.. [1] docs/design.md, "Ground truth and metrics" (validation statistics).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .plan import Plan

__all__ = ["CellResult", "ValidationResult"]


@dataclass
class CellResult:
    """One pipeline on one illuminant × camera × exposure × reflectance set.

    Attributes
    ----------
    set_name, illuminant, camera, exposure, pipeline : str
        The cell's coordinates.
    status : str
        ``"pass"``, ``"fail"`` (a threshold broken) or ``"error"`` (the pipeline failed).
    failures : list of str
        Broken criteria, or the error message.
    patch_names : list of str
        Every chart patch (the set's first ``n_set``).
    n_set, white_index : int
    reference, test : numpy.ndarray or None
        (N, 3) ground truth and exposure-matched pipeline linear sRGB.
    delta_e, snr : numpy.ndarray or None
        (N,) ΔE2000 and SNR per patch.
    stats : dict
        ``delta_e_mean``, ``delta_e_p95``, ``delta_e_max``, ``wb_angular_error_deg``,
        ``snr_median``, ``snr_min``, ``exposure_scale``, ``delta_l_mean``, ``delta_c_mean``,
        ``delta_h_mean`` (mean |ΔL*|, |ΔC*ab|, |ΔH*ab|), ``patches_clipped``, ``tone_slope``.
    exposure_s, iso, gain_dn_per_e : float
        What the sensor did.
    runtime_s : float
        Seconds the pipeline took.
    dng : str
        The RAW the pipeline developed (relative to the report folder).
    calibration : str
        Whether the scored set was among the reflectances the RAW's colour matrices were
        fitted on: ``"in sample (<set>)"`` or ``"out of sample (fitted on <set>)"``
        (:func:`~.run.calibration_sample`).
    warnings : list of str
        What makes a number untrustworthy without failing it (a pipeline balancing on the
        white reference the metric scores).
    traceback : str
        Where a pipeline that failed failed (the last frames of its traceback).
    seed_means : list of float
        The mean ΔE2000 of each noise realisation (``plan.seeds`` of them; the statistics in
        ``stats`` are their means, the patches and swatches the first's).
    delta_e_mean_ci95 : float or None
        Half-width of the 95 % confidence interval of the mean ΔE2000 over the seeds (Student's
        t); None with one seed.
    delta_lch : numpy.ndarray or None
        (N, 3) ΔL*, ΔC*ab, ΔH*ab per patch (:func:`~.scoring.lab_difference_split`).
    clipped : numpy.ndarray or None
        (N,) patches outside sRGB that the pipeline clipped to its edge (:func:`~.scoring.gamut_clipped`).
    """

    set_name: str
    illuminant: str
    camera: str
    exposure: str
    pipeline: str
    status: str
    failures: list
    patch_names: list
    n_set: int
    white_index: int
    reference: np.ndarray | None
    test: np.ndarray | None
    delta_e: np.ndarray | None
    snr: np.ndarray | None
    stats: dict
    exposure_s: float
    iso: float
    gain_dn_per_e: float
    runtime_s: float
    dng: str
    calibration: str = "unknown"
    warnings: list = field(default_factory=list)
    traceback: str = ""
    seed_means: list = field(default_factory=list)
    delta_e_mean_ci95: float | None = None
    delta_lch: np.ndarray | None = None
    clipped: np.ndarray | None = None

    @property
    def key(self) -> tuple[str, str, str, str, str]:
        return (self.set_name, self.illuminant, self.camera, self.exposure, self.pipeline)

    def summary(self, done: int, total: int) -> str:
        """One progress line: ``[3/32] set · illuminant · camera · exposure · pipeline: ΔE00 ...``."""
        where = f"[{done}/{total}] {self.set_name} · {self.illuminant} · {self.camera} · {self.exposure} · {self.pipeline}"
        if self.status == "error":
            return f"{where}: ERROR {self.failures[0]}"
        warned = f" WARNING: {self.warnings[0].split(':')[0]}" if self.warnings else ""
        interval = f" ± {self.delta_e_mean_ci95:.2f}" if self.delta_e_mean_ci95 is not None else ""
        s = self.stats
        return (f"{where}: ΔE00 mean {s['delta_e_mean']:.2f}{interval}, p95 {s['delta_e_p95']:.2f}, "
                f"max {s['delta_e_max']:.2f}; WB {s['wb_angular_error_deg']:.2f}°  {self.status.upper()} "
                f"[{self.calibration.split(' (')[0]}]{warned}")


@dataclass
class ValidationResult:
    """Everything a plan run measured.

    Attributes
    ----------
    plan : Plan
    cells : list of CellResult
    elapsed_s : float
        Wall-clock seconds of the whole run.
    output_dir : pathlib.Path or None
        Where the report, CSVs and DNGs were written.
    versions : dict
        Python, LibRaw and package versions (:func:`spectral_cam.records.package_versions`).
    """

    plan: Plan
    cells: list
    elapsed_s: float
    output_dir: Path | None
    versions: dict

    @property
    def passed(self) -> bool:
        return all(cell.status == "pass" for cell in self.cells)

    def cell(self, **where: str) -> CellResult:
        """The one cell matching ``set_name=..., illuminant=..., camera=..., exposure=..., pipeline=...``."""
        found = [c for c in self.cells if all(getattr(c, k) == v for k, v in where.items())]
        if len(found) != 1:
            raise KeyError(f"{len(found)} cells match {where}")
        return found[0]
