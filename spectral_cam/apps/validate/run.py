"""Running a plan: charts, exposures, pipelines and the patch statistics of every cell.

For every reflectance set × illuminant × camera × exposure the chart (a synthetic one from
:func:`spectral_cam.radiance_targets.synthetic_chart`, or the ColorChecker preset rendered with
Mitsuba, :func:`rendered_chart`) is exposed on the camera's curves and written as a DNG;
every pipeline develops it, and :func:`evaluate_patches` compares its linear sRGB, patch by
patch, with the ground truth of :mod:`spectral_cam.colour_ground_truth`:

- the pipeline's patch means (interiors, :data:`PATCH_MARGIN` left out on every side) are
  scaled so the white reference has the ground truth's luminance (exposure matching);
- ΔE2000 per patch (CIELAB under D65; mean, 95th percentile — NumPy's linear interpolation —
  and maximum over the set's patches);
- white-balance error: the angle (degrees) between the pipeline's and the ground truth's
  linear sRGB of the white reference (the recovery angular error, :func:`angular_error_deg`);
- noise: SNR = mean / standard deviation of the luminance Y over each patch's interior.

Auto exposure (``time_s = "auto"``) puts the brightest patch — the white reference, or a
fluorescent sample brighter than white — at ``auto_fraction`` of saturation. Temporal noise
is seeded by ``[render] seed`` and the fixed patterns by ``[sensor] seed``, as in a render,
so every cell of a plan sees the same noise realisation (common random numbers make
pipelines directly comparable).

References
----------
.. [1] docs/design.md, "Ground truth and metrics".
.. [2] Sharma, G., Wu, W., & Dalal, E. N. (2005). The CIEDE2000 color-difference formula.
   Color Research & Application 30(1), 21–30.
.. [3] Hordley, S. D., & Finlayson, G. D. (2006). Reevaluation of color constancy algorithm
   performance. JOSA A 23(5), 1008–1020 (angular error).
.. [4] ISO 15739:2017, Photography — Electronic still-picture imaging — Noise measurements
   (SNR of uniform patches).
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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

from ...radiance_targets import Chart, ReflectanceSet, synthetic_chart
from ...colour_ground_truth import white_patch_index
from ...errors import ConfigError, SpectralCamError
from .pipelines import CellContext
from .plan import ExposureSpec, Plan

__all__ = ["PATCH_MARGIN", "CellResult", "ValidationResult", "run_plan", "evaluate_patches",
           "angular_error_deg", "rendered_chart", "calibration_sample", "lab_difference_split", "gamut_clipped",
           "tone_slope"]

#: Fraction of each patch's size left out on every side when averaging (edges, demosaicing).
PATCH_MARGIN = 0.2


def rendered_chart(config) -> Chart:
    """The ``colorchecker`` scene preset rendered with Mitsuba under ``config``.

    Parameters
    ----------
    config : SceneConfig
        A scene with ``scene.preset = "colorchecker"`` (its illuminant, lens, sensor size
        and render settings are used as they are).

    Returns
    -------
    Chart
        The render (tiny negative round-off set to 0) with the preset's patches.

    References
    ----------
    .. [1] Jakob, W., et al. (2022). Mitsuba 3 renderer (spectral variants, ``specfilm``).
    """
    from ... import spectra
    from ...presets import colorchecker_patches
    from ...render import render

    if config.scene.preset != "colorchecker" or config.scene.mitsuba_xml:
        raise ConfigError("validate.chart = 'render' renders the 'colorchecker' scene preset; "
                          "set [scene] preset = 'colorchecker' (and no mitsuba_xml)")
    image = render(config, with_depth=False)
    image.data = np.maximum(image.data, 0.0)
    patches = colorchecker_patches(config)
    names = [p.name for p in patches]
    sds = list(spectra.colorchecker_reflectances().values())
    return Chart(image, patches, len(patches), white_patch_index(names), sds, "render")


# ============================================================================ metrics
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


# ============================================================================ results
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
        (:func:`calibration_sample`).
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
        (N, 3) ΔL*, ΔC*ab, ΔH*ab per patch (:func:`lab_difference_split`).
    clipped : numpy.ndarray or None
        (N,) patches outside sRGB that the pipeline clipped to its edge (:func:`gamut_clipped`).
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


# ============================================================================ running
@dataclass
class _Exposed:
    """One exposed chart: what every pipeline of a cell develops."""

    refset: ReflectanceSet
    illuminant: str
    camera: str
    exposure: ExposureSpec
    chart: Chart
    reference: np.ndarray
    raw: object
    dng_name: str
    seed: int = 0


def _slug(text: str) -> str:
    text = Path(text).stem if str(text).lower().endswith(".csv") else str(text)
    return re.sub(r"[^A-Za-z0-9.+-]+", "_", text).strip("_") or "x"


def _exposure_mask(chart: Chart, camera: str, illuminant: str, config) -> np.ndarray:
    """Interior of the patch with the largest camera response (normally the white)."""
    from ...sensor import colour_calibration

    responses = colour_calibration.camera_responses(camera, illuminant, chart.sds,
                                             transmission=(config.lens.transmission, config.sensor.ir_cut))
    brightest = int(np.argmax(responses.max(axis=1)))
    if responses.max(axis=1)[brightest] <= responses.max(axis=1)[chart.white_index] * (1 + 1e-9):
        brightest = chart.white_index
    height, width = chart.radiance.data.shape[:2]
    mask = np.zeros((height, width), dtype=bool)
    mask[chart.patches[brightest].interior(PATCH_MARGIN)] = True
    return mask


def _render_key(config, illuminant: str, camera: str, exposure: ExposureSpec) -> tuple:
    """Renders are shared by cameras and exposures unless the film holds the camera's own
    curves, or ``spp = "auto"`` sizes the render by the sensor's noise at the exposure."""
    render = config.render
    bands = getattr(render, "bands", "400:700:10")
    camera_film = bands == "camera" or (bands == "auto" and not getattr(render, "spectral_output", True))
    auto_spp = render.spp == "auto"
    return (illuminant, camera if camera_film or auto_spp else None, exposure.name if auto_spp else None)


def _exposed_charts(plan: Plan) -> Iterator[list[_Exposed]]:
    """Every chart of the plan, exposed once per seed, in report order (set, illuminant, camera,
    exposure)."""
    from ... import colour_ground_truth
    from ...sensor import expose

    render_cache: dict = {}
    for s, refset in enumerate(plan.reflectance_sets):
        for i, illuminant in enumerate(plan.illuminants):
            synthetic = None
            if plan.chart == "synthetic":
                synthetic = synthetic_chart(refset, illuminant, illuminance_lux=plan.illuminance_lux,
                                            bands=plan.bands, patch_px=plan.patch_px, gap_px=plan.gap_px)
                reference = colour_ground_truth.patch_linear_srgb(illuminant, synthetic.sds)
            for camera in plan.cameras:
                for e, exposure in enumerate(plan.exposures):
                    chart = synthetic
                    if chart is None:
                        config = plan.scene_config(illuminant, camera, exposure)
                        key = _render_key(config, illuminant, camera, exposure)
                        if key not in render_cache:
                            render_cache[key] = rendered_chart(config)
                        chart = render_cache[key]
                        reference = colour_ground_truth.patch_linear_srgb(illuminant, chart.sds)
                    config = plan.scene_config(illuminant, camera, exposure, chart)
                    mask = _exposure_mask(chart, camera, illuminant, config)
                    seeded = []
                    for k in range(plan.seeds):  # noise realisations: the temporal noise's seed
                        raw = expose(chart.radiance, config, white_mask=mask, frame_seed=config.render.seed + k)
                        # positions keep names unique (two CSVs may share a file name)
                        dng_name = (f"{s:02d}-{_slug(refset.name)}__{i:02d}-{_slug(illuminant)}__"
                                    f"{_slug(camera)}__{e:02d}-{_slug(exposure.name)}"
                                    + (f"__seed{k}" if plan.seeds > 1 else "") + ".dng")
                        seeded.append(_Exposed(refset, illuminant, camera, exposure, chart, reference, raw, dng_name, k))
                    yield seeded


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


def _context(exposed: _Exposed) -> CellContext:
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


def _cell_fields(pipeline, exposed: _Exposed) -> dict:
    """What a cell records whatever its pipeline did: its coordinates, chart, truth and RAW."""
    chart, meta = exposed.chart, exposed.raw.meta or {}
    return dict(set_name=exposed.refset.name, illuminant=exposed.illuminant, camera=exposed.camera,
                exposure=exposed.exposure.name, pipeline=pipeline.name, patch_names=[p.name for p in chart.patches],
                n_set=chart.n_set, white_index=chart.white_index, reference=exposed.reference,
                exposure_s=float(meta.get("exposure_s", float("nan"))), iso=float(meta.get("iso", exposed.exposure.iso)),
                gain_dn_per_e=float(meta.get("K_dn_per_e", float("nan"))), dng=f"raw/{exposed.dng_name}",
                calibration=calibration_sample(exposed.refset.name, meta))


def _run_cell(pipeline, exposed: _Exposed, dng_path: Path, work_dir: Path, plan: Plan) -> CellResult:
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
    warnings = []
    if abs(stats["tone_slope"] - 1.0) > TONE_SLOPE_TOLERANCE:  # NaN compares False: no neutrals, no warning
        warnings.append(f"a tone curve: the neutral patches' luminance follows the truth's to the power "
                        f"{stats['tone_slope']:.2f}, not 1 (an encoded image read as linear is ≈ 0.45; a filmic or "
                        "S-curve also bends it): ΔE then measures the curve; declare the output's encoding or "
                        "turn the curve off")
    if stats["patches_clipped"]:
        warnings.append(f"{int(stats['patches_clipped'])} patch(es) lie outside the sRGB gamut and came out on its "
                        "edge: their ΔE measures the gamut, not the pipeline")
    grey = angular_error_deg(measured["test"][chart.white_index], np.ones(3))
    tint = angular_error_deg(exposed.reference[chart.white_index], np.ones(3))  # the truth's own, from grey
    if grey < SELF_BALANCED_FRACTION * tint:
        warnings.append(f"the white reference comes out grey ({grey:.3f}° from R = G = B, its truth "
                        f"{tint:.2f}°): a pipeline that "
                        "white-balances on the patch the metric scores makes its WB error the patch's own tint, not "
                        "a measurement of the balance (balance on the light or on another patch)")
    failures = plan.thresholds.failures(stats)
    return CellResult(status="fail" if failures else "pass", failures=failures, test=measured["test"],
                      delta_e=measured["delta_e"], snr=measured["snr"], stats=stats, runtime_s=runtime,
                      warnings=warnings, delta_lch=measured["delta_lch"], clipped=measured["clipped"], **common)


def _skipped_cell(pipeline, exposed: _Exposed, message: str) -> CellResult:
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
        for seeded in _exposed_charts(plan):
            paths = [write_dng(exposed.raw, raw_dir / exposed.dng_name) for exposed in seeded]
            for pipeline in plan.pipelines:
                errors = repeated[pipeline.name]
                if len(errors) >= FAIL_FAST_AFTER and len({signature for _, signature in errors}) == 1:
                    cell = _skipped_cell(pipeline, seeded[0], errors[-1][0])
                else:
                    runs = []
                    for exposed, path in zip(seeded, paths):
                        runs.append(_run_cell(pipeline, exposed, path, work_dir, plan))
                        if runs[-1].status == "error":
                            break  # the other seeds would fail alike
                    cell = _combine(runs, plan)
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
