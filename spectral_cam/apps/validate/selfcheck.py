"""``spectral-cam validate --self``: the simulator's own physics checks, measured against references.

Each check is one entry of :data:`SELF_CHECKS` (a :class:`~spectral_cam.registry.Registry`),
a function returning :class:`CheckResult` rows — a measured value, its reference and a
tolerance. They are small and fast (seconds each):

- ``radiometry``: rendered band radiance of a Lambertian plane against colour-science;
- ``thin_lens``: defocus blur of a point source against the circle of confusion;
- ``shot_noise``, ``monte_carlo``: the √n laws of photon noise and of Monte-Carlo sampling;
- ``emva1288``: a photon-transfer round trip recovers the configured sensor;
- ``dng_libraw``: our DNG read by LibRaw (mosaic, tags, LibRaw's development against ours);
- ``colour_chain``: the ground truth by two routes; sensor + ISP against analytic responses.

References
----------
.. [1] McCluney, W. R. (2014). Introduction to Radiometry and Photometry, 2nd ed., §1.6.
.. [2] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10 (circle of confusion).
.. [3] EMVA Standard 1288, Release 4.0 (2021) (photon transfer).
.. [4] Adobe (2023). DNG Specification 1.7.1.0.
.. [5] docs/design.md, "Ground truth and metrics" (the table of checks and what they measure).
"""

from __future__ import annotations

import dataclasses
import math
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ...radiance_targets import narrow_band_flat, reflectance_set, synthetic_chart
from ...records import exact_number, format_number, write_csv
from ...registry import Registry
from .run import PATCH_MARGIN

__all__ = ["SELF_CHECKS", "CheckResult", "self_checks", "format_checks", "write_checks_csv"]

#: The --self checks, in the order they run: name → function() -> list of CheckResult.
SELF_CHECKS = Registry("self-check")


@dataclass
class CheckResult:
    """One physics self-check: a measured value against a reference and a tolerance.

    Attributes
    ----------
    check : str
        What is checked.
    quantity : str
        The measured quantity, with its unit.
    measured, reference, tolerance : float
        Pass when ``|measured − reference| ≤ tolerance`` (``tolerance`` relative to the
        reference when ``relative``).
    relative : bool
    seconds : float
        Time the check took (shared checks report their first row's time).
    """

    check: str
    quantity: str
    measured: float
    reference: float
    tolerance: float
    relative: bool = False
    seconds: float = 0.0

    @property
    def passed(self) -> bool:
        limit = self.tolerance * (abs(self.reference) if self.relative else 1.0)
        return bool(np.isfinite(self.measured) and abs(self.measured - self.reference) <= limit)

    @property
    def tolerance_text(self) -> str:
        return f"±{self.tolerance * 100:g} %" if self.relative else f"±{self.tolerance:g}"


def _render_table(**values) -> dict:
    """A [render] table with the explicit spectral settings the checks need."""
    from ...scene import RenderSection

    table = {"bands": "400:700:10", "diffraction": "off", **values}
    if "spectral_output" in {f.name for f in dataclasses.fields(RenderSection)}:
        table["spectral_output"] = True
    return table


@SELF_CHECKS.register("radiometry", description="rendered band radiance of a Lambertian plane vs colour-science")
def _check_radiometry() -> list[CheckResult]:
    """Band radiance of a rendered ρ = 0.5 Lambertian plane under D65 at 1000 lx against
    colour-science's illuminant and photometry (L = ρE/π, E scaled by ``luminous_flux``)."""
    import colour

    from ...render import render
    from ...scene import scene_from_dict

    t0 = time.perf_counter()
    lux, rho = 1000.0, 0.5
    config = scene_from_dict({
        "scene": {"preset": "flat_field", "reflectance": rho, "distance_m": 2.0},
        "illuminant": {"spd": "D65", "illuminance_lux": lux},
        "lens": {"model": "pinhole"},
        "sensor": {"width_px": 8, "height_px": 8, "pixel_pitch_um": 100.0},
        "render": _render_table(spp=1 << 14, max_depth=2, seed=3),
    })
    image = render(config, with_depth=False)
    measured = image.data.reshape(-1, image.data.shape[-1]).astype(np.float64).mean(axis=0)
    shape = colour.SpectralShape(360, 830, 1)
    spd = colour.SDS_ILLUMINANTS["D65"].copy().align(shape, interpolator=colour.LinearInterpolator)
    spd = spd * (lux / colour.luminous_flux(spd))
    radiance = rho * np.asarray(spd.values) / np.pi
    expected = []
    for lo, hi in zip(image.band_edges_nm[:-1], image.band_edges_nm[1:]):
        fine = np.linspace(lo, hi, 101)
        expected.append(np.trapezoid(np.interp(fine, shape.wavelengths, radiance), fine))
    relative = measured / np.asarray(expected) - 1.0
    seconds = time.perf_counter() - t0
    return [
        CheckResult("radiometry vs colour-science", "worst of 31 band radiances, error (%)",
                    float(np.max(np.abs(relative)) * 100), 0.0, 1.5, seconds=seconds),
        CheckResult("radiometry vs colour-science", "mean band radiance error, bias (%)",
                    float(np.mean(relative) * 100), 0.0, 0.3),
    ]


@SELF_CHECKS.register("thin_lens", description="defocus blur of a point source vs the circle of confusion")
def _check_thin_lens() -> list[CheckResult]:
    """Defocus blur of a point source against the thin-lens circle of confusion
    c = A·f·|z − z_f| / (z·(z_f − f)), measured by second moments (a disc has ⟨r²⟩ = c²/8;
    :func:`spectral_cam.metrics.blur.disc_diameter_from_moments`)."""
    from ...metrics.blur import disc_diameter_from_moments
    from ...render import render
    from ...scene import scene_from_dict

    t0 = time.perf_counter()
    focal_m, f_number, focus_m, pitch_m, size, depth = 0.05, 2.0, 2.0, 10e-6, 48, 3.0
    image_distance = 1.0 / (1.0 / focal_m - 1.0 / focus_m)
    source_px = 3.0
    config = scene_from_dict({
        "scene": {"preset": "point_sources", "depths_m": [depth],
                  "source_radius_m": source_px * pitch_m * depth / image_distance},
        "lens": {"focal_length_mm": focal_m * 1e3, "f_number": f_number, "focus_distance_m": focus_m, "model": "thin"},
        "sensor": {"width_px": size, "height_px": size, "pixel_pitch_um": pitch_m * 1e6},
        "render": _render_table(spp=512, max_depth=2, seed=0),
    })
    image = render(config, with_depth=False)
    # the sharp source: a disc of source_px pixels' radius, pixel-integrated (⟨r²⟩ = r²/2 + 2/12)
    measured = disc_diameter_from_moments(image.data.sum(axis=-1), source_px ** 2 / 2 + 2 / 12)
    return [CheckResult("thin-lens CoC", f"blur diameter at z = {depth:g} m, focus {focus_m:g} m (px)",
                        measured, float(image.lens.coc_diameter_px(depth)), 0.02, relative=True,
                        seconds=time.perf_counter() - t0)]


def _flat_field_radiance(config, electrons: float, exposure_s: float, wavelength_nm: float = 550.0) -> float:
    """Band radiance that gives ``electrons`` per pixel in ``exposure_s`` on a monochrome sensor
    (:func:`spectral_cam.sensor.electrons_per_band_radiance`)."""
    from ...sensor import electrons_per_band_radiance

    return electrons / (electrons_per_band_radiance(config, wavelength_nm) * exposure_s)


@SELF_CHECKS.register("shot_noise", description="σ_e = √μ_e on flat-field pairs")
def _check_shot_noise() -> list[CheckResult]:
    """σ_e = √μ_e: temporal noise of flat-field pairs on a noiseless-electronics sensor."""
    from ...scene import scene_from_dict
    from ...sensor import expose

    t0 = time.perf_counter()
    t_s, size = 0.01, 128
    config = scene_from_dict({
        "sensor": {"model": "ideal", "cfa": "none", "width_px": size, "height_px": size, "read_noise_e": 0.0,
                   "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0, "bit_depth": 16,
                   "full_well_e": 100000.0, "black_level_dn": 256, "peak_qe": 0.5, "vignetting": False},
        "exposure": {"time_s": t_s, "iso": 100.0},
    })
    means, sigmas = [], []
    for index, electrons in enumerate((100.0, 1000.0, 10000.0, 50000.0)):
        flat = narrow_band_flat((size, size), _flat_field_radiance(config, electrons, t_s))
        a = expose(flat, config, frame_seed=2 * index + 1)
        b = expose(flat, config, frame_seed=2 * index + 2)
        gain = a.meta["K_dn_per_e"]
        fa, fb = a.mosaic.astype(np.float64), b.mosaic.astype(np.float64)
        means.append(((fa + fb) / 2 - a.black_level).mean() / gain)
        sigmas.append(math.sqrt(max(np.var(fa - fb) / 2 - 1 / 12, 0.0)) / gain)
    slope = float(np.polyfit(np.log(means), np.log(sigmas), 1)[0])
    ratio = sigmas[2] ** 2 / means[2]
    seconds = time.perf_counter() - t0
    return [
        CheckResult("√n law (shot noise)", "slope d ln σ_e / d ln μ_e, 10²–5·10⁴ e⁻", slope, 0.5, 0.01,
                    seconds=seconds),
        CheckResult("√n law (shot noise)", "σ_e² / μ_e at 10⁴ e⁻", float(ratio), 1.0, 0.03),
    ]


def _noise_slope(sampler: str) -> float:
    """d ln σ / d ln spp of a flat field's per-pixel render noise between 16 and 256 spp."""
    from ...render import render
    from ...scene import scene_from_dict

    spread = []
    counts = (16, 256)
    for spp in counts:
        config = scene_from_dict({
            "scene": {"preset": "flat_field", "reflectance": 0.5},
            "lens": {"model": "pinhole"},
            "sensor": {"width_px": 32, "height_px": 32, "pixel_pitch_um": 100.0},
            "render": {**_render_table(spp=spp, max_depth=2, seed=11), "sampler": sampler},
        })
        data = render(config, with_depth=False).data.astype(np.float64)
        spread.append(float(np.mean(data.std(axis=(0, 1), ddof=1) / data.mean(axis=(0, 1)))))
    return math.log(spread[1] / spread[0]) / math.log(counts[1] / counts[0])


@SELF_CHECKS.register("monte_carlo", description="render noise falls as spp^(-1/2) with independent samples, "
                                                 "faster with multijitter")
def _check_monte_carlo() -> list[CheckResult]:
    """Monte-Carlo noise of the render falls as spp^(-1/2) with independent samples (the
    central limit theorem); the default multijitter sampler, stratified within a pass, must
    do clearly better on this smooth integrand (measured −0.98; accepted −0.7 to −1.3)."""
    t0 = time.perf_counter()
    independent = _noise_slope("independent")
    stratified = _noise_slope("multijitter")
    seconds = time.perf_counter() - t0
    return [CheckResult("√n law (Monte Carlo)", "slope d ln σ / d ln spp, 16–256 spp, independent", independent,
                        -0.5, 0.05, seconds=seconds),
            CheckResult("√n law (Monte Carlo)", "slope, multijitter (stratified: faster than −0.5)", stratified,
                        -1.0, 0.3)]


@SELF_CHECKS.register("emva1288", description="EMVA 1288 photon transfer recovers the sensor's settings")
def _check_emva() -> list[CheckResult]:
    """EMVA 1288 photon transfer of simulated flat fields recovers the sensor's settings."""
    from ...metrics.emva1288 import photon_transfer
    from ...scene import scene_from_dict
    from ...sensor import expose

    t0 = time.perf_counter()
    size, t_s, read_e, dark_e_per_s, dsnu_e, prnu, qe = 128, 0.1, 3.0, 50.0, 2.0, 0.005, 0.7
    config = scene_from_dict({
        "sensor": {"model": "ideal", "cfa": "none", "width_px": size, "height_px": size, "pixel_pitch_um": 5.0,
                   "read_noise_e": read_e, "dark_current_e_per_s": dark_e_per_s, "dsnu_e": dsnu_e, "prnu": prnu,
                   "peak_qe": qe, "bit_depth": 14, "full_well_e": 20000.0, "black_level_dn": 256,
                   "vignetting": False, "seed": 7},
        "exposure": {"time_s": t_s, "iso": 100.0},
        "lens": {"f_number": 4.0},
    })
    k_ref = (2 ** 14 - 1 - 256) / 20000.0
    sigma_ref = math.sqrt(read_e ** 2 + dark_e_per_s * t_s)
    saturation_photons = 20000.0 / qe
    # dense 0.5 % steps around saturation, where the variance peak that defines μ_e.sat
    # (EMVA 1288 §6.5; a little below the full well, as PRNU and shot noise make some
    # pixels clip first) must be resolved
    levels = np.concatenate([np.linspace(0.004, 0.05, 4), np.linspace(0.06, 0.88, 12),
                             np.linspace(0.9, 1.2, 61)]) * saturation_photons

    def flat(photons: float):  # the ideal sensor's η is flat: photons · η electrons
        return narrow_band_flat((size, size), _flat_field_radiance(config, photons * qe, t_s))

    pairs = []
    for i, photons in enumerate(levels):
        field = flat(photons)
        pairs.append((expose(field, config, frame_seed=2 * i + 1), expose(field, config, frame_seed=2 * i + 2)))
    dark = flat(0.0)
    dark_pairs = [(expose(dark, config, frame_seed=10_001), expose(dark, config, frame_seed=10_002))]
    dark_stack = [expose(dark, config, frame_seed=20_000 + i) for i in range(16)]
    half = flat(0.5 * saturation_photons)
    bright_stack = [expose(half, config, frame_seed=30_000 + i) for i in range(16)]
    result = photon_transfer(pairs, dark_pairs, photons_per_pixel=levels, dark_stack=dark_stack,
                             bright_stack=bright_stack)
    seconds = time.perf_counter() - t0
    name = "EMVA 1288 round trip"
    return [
        CheckResult(name, "system gain K (DN/e⁻)", result.gain, k_ref, 0.03, relative=True, seconds=seconds),
        CheckResult(name, "dark noise σ_d (e⁻)", result.sigma_d_e, sigma_ref, 0.05, relative=True),
        CheckResult(name, "quantum efficiency η at 550 nm", float(result.quantum_efficiency[0]), qe, 0.03,
                    relative=True),
        CheckResult(name, "saturation capacity (e⁻)", result.saturation_e, 20000.0, 0.05, relative=True),
        CheckResult(name, "DSNU (e⁻)", float(result.dsnu_e), dsnu_e, 0.1, relative=True),
        CheckResult(name, "PRNU (fraction)", float(result.prnu), prnu, 0.1, relative=True),
    ]


def _noise_free_chart_raw(camera: str = "nikon_d850", illuminant: str = "D65"):
    """A ColorChecker chart and its noise-free RAW, auto-exposed on the white reference."""
    from ...scene import scene_from_dict
    from ...sensor import expose

    chart = synthetic_chart(reflectance_set("colorchecker"), illuminant, patch_px=16, gap_px=4)
    height, width = chart.radiance.data.shape[:2]
    config = scene_from_dict({
        "illuminant": {"spd": illuminant},
        "sensor": {"model": camera, "width_px": width, "height_px": height, "shot_noise": False,
                   "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0,
                   "vignetting": False},
        "exposure": {"time_s": "auto", "auto_fraction": 0.8, "metering": "etr"},
    })
    mask = np.zeros((height, width), dtype=bool)
    mask[chart.patches[chart.white_index].interior(PATCH_MARGIN)] = True
    return chart, expose(chart.radiance, config, white_mask=mask)


@SELF_CHECKS.register("dng_libraw", description="our DNG read and developed by LibRaw")
def _check_dng_libraw() -> list[CheckResult]:
    """Our DNG read by LibRaw: the mosaic bit for bit, AsShotNeutral, ColorMatrix1, and
    LibRaw's own development against ours with the DNG matrix."""
    import rawpy

    from ... import colour_ground_truth
    from ...isp import ISPConfig, develop
    from ...metrics.image_quality import delta_e2000, patch_means
    from ...raw import read_raw, write_dng

    t0 = time.perf_counter()
    chart, raw = _noise_free_chart_raw()
    with tempfile.TemporaryDirectory(prefix="spectral-cam-self-") as folder:
        path = write_dng(raw, Path(folder) / "chart.dng")
        with rawpy.imread(str(path)) as handle:
            mosaic = np.array(handle.raw_image_visible, copy=True)  # a view dies with the handle
            multipliers = np.asarray(handle.camera_whitebalance[:3], dtype=float)
            xyz = handle.postprocess(use_camera_wb=True, output_color=rawpy.ColorSpace.XYZ, gamma=(1, 1),
                                     no_auto_bright=True, adjust_maximum_thr=0.0, output_bps=16, user_flip=0,
                                     demosaic_algorithm=rawpy.DemosaicAlgorithm.AHD).astype(np.float64) / 65535.0
        back = read_raw(path)
    same_shape = mosaic.shape == raw.mosaic.shape
    max_dn = float(np.max(np.abs(mosaic.astype(np.int64) - raw.mosaic.astype(np.int64)))) if same_shape else math.inf
    neutral = (1.0 / multipliers) / (1.0 / multipliers).max()
    libraw = patch_means(colour_ground_truth.xyz_to_linear_srgb(xyz), chart.patches, margin=PATCH_MARGIN)
    ours = patch_means(develop(raw, ISPConfig(colour_matrix="dng", demosaic="menon2007", tone="linear",
                                              highlights="none")).linear, chart.patches, margin=PATCH_MARGIN)
    agreement = delta_e2000(ours, libraw, exposure_match_index=chart.white_index)
    seconds = time.perf_counter() - t0
    name = "DNG / LibRaw agreement"
    return [
        CheckResult(name, "mosaic read back by LibRaw, max |ΔDN|", max_dn, 0.0, 0.0, seconds=seconds),
        CheckResult(name, "AsShotNeutral via LibRaw, max relative error",
                    float(np.max(np.abs(neutral / raw.as_shot_neutral - 1))), 0.0, 1e-5),
        CheckResult(name, "ColorMatrix1 via LibRaw, max |error|",
                    float(np.max(np.abs(back.color_matrix - raw.color_matrix))), 0.0, 2e-4),
        CheckResult(name, "LibRaw vs our ISP (DNG matrix), mean ΔE2000", float(np.mean(agreement)), 0.0, 1.0),
    ]


@SELF_CHECKS.register("colour_chain", description="ground truth by two routes; sensor + ISP vs analytic")
def _check_colour_chain() -> list[CheckResult]:
    """Ground truth by two integrations, and the noise-free chain (synthetic chart →
    sensor → our ISP, fitted 3×3) against the same matrix on spectrally integrated
    camera responses."""
    import colour

    from ... import colour_ground_truth
    from ...isp import ISPConfig, develop
    from ...metrics.image_quality import delta_e2000, patch_means
    from ...sensor import colour_calibration

    t0 = time.perf_counter()
    reference = colour_ground_truth.patch_linear_srgb("A")
    white = colour_calibration.illuminant_white_xyz("A")
    d65 = colour.xy_to_XYZ(colour.models.RGB_COLOURSPACE_sRGB.whitepoint)
    cat = np.asarray(colour.adaptation.matrix_chromatic_adaptation_VonKries(white, d65, "Bradford"))
    other = colour_ground_truth.xyz_to_linear_srgb(colour_calibration.reflectance_xyz("A") @ cat.T)
    routes = float(np.max(delta_e2000(other, reference)))
    chart, raw = _noise_free_chart_raw()
    reference = colour_ground_truth.patch_linear_srgb("D65")
    matrix = colour_calibration.camera_to_xyz_d65("nikon_d850", "D65")
    linear = develop(raw, ISPConfig(colour_matrix="fitted", demosaic="menon2007", tone="linear",
                                    highlights="none"), camera_to_xyz=matrix).linear
    chain = delta_e2000(patch_means(linear, chart.patches, margin=PATCH_MARGIN), reference,
                        exposure_match_index=chart.white_index)
    balanced = colour_calibration.camera_responses("nikon_d850", "D65") / colour_calibration.camera_responses(
        "nikon_d850", "D65", [1.0])[0]
    analytic = delta_e2000(colour_ground_truth.xyz_to_linear_srgb(balanced @ matrix.T), reference,
                           exposure_match_index=chart.white_index)
    seconds = time.perf_counter() - t0
    return [
        CheckResult("ground truth", "two XYZ integrations + Bradford under A, max ΔE2000", routes, 0.0, 0.05,
                    seconds=seconds),
        CheckResult("colour chain (ColorChecker, D65)", "mean ΔE2000 through sensor + ISP minus analytic",
                    float(np.mean(chain) - np.mean(analytic)), 0.0, 0.1),
    ]


def self_checks(names: Sequence[str] | None = None) -> list[CheckResult]:
    """Run the simulator's own physics checks (small and fast: seconds each).

    Parameters
    ----------
    names : sequence of str, optional
        Subset of :data:`SELF_CHECKS` (default all, in registration order): ``radiometry``
        (rendered band radiance of a Lambertian plane against colour-science), ``thin_lens``
        (defocus blur against the circle of confusion), ``shot_noise`` and ``monte_carlo``
        (the √n laws), ``emva1288`` (photon-transfer round trip), ``dng_libraw`` (our DNG
        through LibRaw), ``colour_chain`` (ground-truth routes; sensor + ISP against
        analytic responses).

    Returns
    -------
    list of CheckResult

    Raises
    ------
    ConfigError
        For an unknown check name (listing the valid ones).

    References
    ----------
    .. [1] McCluney (2014) §1.6 (Lambert); Ray, Applied Photographic Optics, 3rd ed., ch. 10
       (CoC); EMVA 1288 Release 4.0; Adobe DNG Specification 1.7.1.0; docs/design.md,
       "Ground truth and metrics".

    Examples
    --------
    >>> rows = self_checks(["shot_noise"])
    >>> [(row.check, row.passed) for row in rows]
    [('√n law (shot noise)', True), ('√n law (shot noise)', True)]
    """
    checks = [SELF_CHECKS[name] for name in (SELF_CHECKS.names() if names is None else names)]
    results: list[CheckResult] = []
    for check in checks:
        results.extend(check())
    return results


def format_checks(results: Sequence[CheckResult]) -> str:
    """The self-checks as a plain-text table: check, quantity, measured, reference,
    tolerance, result (numbers by :func:`spectral_cam.records.format_number`)."""
    header = ("check", "quantity", "measured", "reference", "tolerance", "result")
    rows = [(r.check, r.quantity, format_number(r.measured), format_number(r.reference), r.tolerance_text,
             "pass" if r.passed else "FAIL") for r in results]
    widths = [max(len(row[i]) for row in [header, *rows]) for i in range(len(header))]
    lines = ["  ".join(cell.ljust(widths[i]) if i < 2 else cell.rjust(widths[i]) if i < 5 else cell
                       for i, cell in enumerate(row)) for row in [header, *rows]]
    lines.insert(1, "  ".join("-" * w for w in widths))
    passed = sum(r.passed for r in results)
    lines.append(f"{passed}/{len(results)} checks pass")
    return "\n".join(lines)


#: Columns of the --self CSV.
CHECK_COLUMNS = ("check", "quantity", "measured", "reference", "tolerance", "tolerance_relative", "passed",
                 "seconds")


def write_checks_csv(results: Sequence[CheckResult], path: str | Path) -> Path:
    """Write the self-checks as CSV (atomically; numbers at full precision)."""
    rows = ({"check": r.check, "quantity": r.quantity, "measured": float(r.measured),
             "reference": float(r.reference), "tolerance": float(r.tolerance), "tolerance_relative": r.relative,
             "passed": r.passed, "seconds": f"{r.seconds:.3f}"} for r in results)
    return write_csv(rows, path, CHECK_COLUMNS, number=exact_number)
