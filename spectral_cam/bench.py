"""Speed against accuracy: benchmarks that chart one against the other.

``spectral-cam bench -o DIR [--quick]`` runs, each in one process so every time ratio has
its baseline measured in the same run:

- ``spp``: samples per pixel for the LLVM and scalar variants — time against Monte-Carlo
  noise and against ΔE2000 of the developed ColorChecker;
- ``bands``: spectral sampling — the camera film (3 measured curves + CMFs) and 8/16/31
  bands against a 1-nm reference integration, under D65 and FL11: render time against
  ΔE2000 and per-channel bias;
- ``isp``: demosaic methods and denoisers — time against PSNR and ΔE2000;
- ``rawpy``: our ISP against LibRaw (LINEAR, AHD, DCB) on the same DNG — time against ΔE2000.

Each writes ``DIR/<name>.csv`` and ``DIR/<name>.png`` with the Pareto front marked.

References
----------
.. [1] Pharr, Jakob & Humphreys (2023). Physically Based Rendering, 4th ed., §2.1
   (Monte-Carlo error falls as 1/√spp).
.. [2] Sharma, Wu & Dalal (2005). The CIEDE2000 colour-difference formula.
"""

from __future__ import annotations

import csv
import time
from pathlib import Path

import numpy as np

from .io import atomic_path
from .scene import SceneConfig, scene_from_dict

__all__ = ["run_benchmarks", "pareto_front", "configure_parser", "BENCHMARKS"]

WHITE_PATCH = 18


# ----------------------------------------------------------------------------- helpers
def pareto_front(cost: np.ndarray, error: np.ndarray) -> np.ndarray:
    """Indices of the points no other point beats in both cost and error (lower is better),
    sorted by cost."""
    cost, error = np.asarray(cost, float), np.asarray(error, float)
    order = np.lexsort((error, cost))
    front, best = [], np.inf
    for index in order:
        if error[index] < best:
            front.append(int(index))
            best = error[index]
    return np.asarray(front, dtype=int)


def _timed(func, *args, repeats: int = 1, **kwargs):
    best, result = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = func(*args, **kwargs)
        best = min(best, time.perf_counter() - t0)
    return result, best


def _write_csv(rows: list[dict], path: Path) -> Path:
    with atomic_path(path) as tmp:
        with tmp.open("w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    return path


def _chart(rows: list[dict], path: Path, *, x: str, y: str, label: str, title: str,
           group: str | None = None, ylabel: str | None = None, xlabel: str | None = None) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=110)
    groups = sorted({r[group] for r in rows}) if group else [None]
    for number, name in enumerate(groups):
        subset = [r for r in rows if group is None or r[group] == name]
        colour = f"C{number}"
        ax.scatter([r[x] for r in subset], [r[y] for r in subset], label=name, s=30, zorder=3, color=colour)
        for r in subset:
            ax.annotate(str(r[label]), (r[x], r[y]), fontsize=7, xytext=(3, 3), textcoords="offset points")
        cost = np.array([r[x] for r in subset], float)
        error = np.array([r[y] for r in subset], float)
        front = pareto_front(cost, error)
        # the front of each group: a staircase from its cheapest to its most accurate point
        ax.step(cost[front], error[front], where="post", color=colour, lw=1, ls="--", zorder=2,
                label="Pareto front" if number == 0 else None)
    ax.set_xscale("log")
    ax.set_xlabel(xlabel or x)
    ax.set_ylabel(ylabel or y)
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)
    return path


def _mark_front(rows: list[dict], x: str, y: str) -> None:
    front = set(pareto_front([r[x] for r in rows], [r[y] for r in rows]).tolist())
    for index, row in enumerate(rows):
        row["pareto"] = index in front


def _chart_scene(width: int, height: int, **overrides) -> SceneConfig:
    base = {
        "scene": {"preset": "colorchecker", "fill": 0.95, "gap": 0.2},
        "lens": {"model": "pinhole"},
        "sensor": {"width_px": width, "height_px": height, "vignetting": False},
        "render": {"diffraction": "off", "max_depth": 2},
    }
    return scene_from_dict(base, overrides=overrides)


def _develop_delta_e(radiance, config: SceneConfig, isp_overrides: dict | None = None) -> float:
    """Mean ΔE2000 of the developed, noise-free ColorChecker against the analytic ground truth."""
    from .colorimetry import patch_linear_srgb
    from .isp import develop
    from .metrics import colorchecker_delta_e
    from .presets import colorchecker_patches, white_reference_mask
    from .sensor import expose

    noise_free = config.replace(**{"sensor.shot_noise": False, "sensor.read_noise_e": 0.0,
                                   "sensor.dark_current_e_per_s": 0.0, "sensor.dsnu_e": 0.0,
                                   "sensor.prnu": 0.0, "isp.tone": "linear",
                                   **(isp_overrides or {})})
    raw = expose(radiance, noise_free, white_mask=white_reference_mask(noise_free))
    linear = develop(raw, noise_free.isp).linear
    truth = patch_linear_srgb(config.illuminant.spd)
    return colorchecker_delta_e(linear, truth, colorchecker_patches(config))["mean"]


# ----------------------------------------------------------------------------- benchmarks
def bench_spp(out: Path, *, quick: bool) -> list[dict]:
    """Time vs Monte-Carlo noise and ΔE2000 over samples per pixel, per variant."""
    from .presets import colorchecker_patches
    from .render import choose_variant, render

    width, height = (72, 48) if quick else (144, 96)
    spps = [4, 16, 64] if quick else [4, 16, 64, 256]
    variants = ["llvm_ad_spectral", "scalar_spectral"] if choose_variant("auto") != "scalar_spectral" \
        else ["scalar_spectral"]
    rows = []
    for variant in variants:
        render(_chart_scene(width, height, **{"render.spp": 1, "render.variant": variant}), with_depth=False)  # JIT warm-up
        for spp in spps:
            config = _chart_scene(width, height, **{"render.spp": spp, "render.variant": variant})
            first, seconds = _timed(render, config, with_depth=False, repeats=2)
            second = render(config.replace(**{"render.seed": 1}), with_depth=False)
            patches = colorchecker_patches(config)
            noise = []
            for patch in patches:
                a = first.data[patch.interior(0.2)].sum(axis=-1)
                b = second.data[patch.interior(0.2)].sum(axis=-1)
                noise.append(np.std(a - b) / np.sqrt(2) / max(np.mean((a + b) / 2), 1e-30))
            rows.append({"variant": variant, "spp": spp, "seconds": seconds,
                         "mc_noise_rel": float(np.median(noise)),
                         "delta_e2000": _develop_delta_e(first, config)})
    baseline = next(r["seconds"] for r in rows if r["spp"] == spps[0] and r["variant"] == variants[0])
    for row in rows:
        row["time_ratio"] = row["seconds"] / baseline
    _mark_front(rows, "time_ratio", "mc_noise_rel")
    _write_csv(rows, out / "spp.csv")
    _chart(rows, out / "spp.png", x="time_ratio", y="mc_noise_rel", label="spp", group="variant",
           xlabel=f"render time / {variants[0]} at {spps[0]} spp ({baseline:.2f} s)",
           ylabel="relative Monte-Carlo noise per pixel",
           title=f"Samples per pixel: time vs Monte-Carlo noise ({width}×{height} ColorChecker)")
    _chart(rows, out / "spp_delta_e.png", x="time_ratio", y="delta_e2000", label="spp", group="variant",
           xlabel=f"render time / {variants[0]} at {spps[0]} spp", ylabel="mean ΔE2000 (noise-free sensor)",
           title="Samples per pixel: time vs colour error")
    return rows


def _reference_electrons(config: SceneConfig) -> np.ndarray:
    """Electrons per patch and channel from a 1-nm integration of ρ(λ)E(λ)/π (the sensor's
    camera equation on a synthetic 1-nm-band image)."""
    from . import spectra
    from .image import SpectralImage
    from .sensor import signal_model

    grid = spectra.BandGrid(tuple(np.arange(380.5, 730.0, 1.0)), tuple(np.arange(380.0, 730.5, 1.0)))
    wl, irradiance = spectra.absolute_irradiance(config.illuminant.spd, config.illuminant.illuminance_lux)
    white = spectra.band_integrals(irradiance / np.pi, wl, grid)
    rho = np.stack([spectra.sample(sd, np.asarray(grid.centres_nm))
                    for sd in spectra.colorchecker_reflectances().values()])
    cube = (rho * white)[None].astype(np.float32)  # (1, 24, B)
    image = SpectralImage(cube, np.asarray(grid.centres_nm), np.asarray(grid.edges_nm))
    return cube[0].astype(float) @ signal_model(image, config).weights  # (24, 3) per second


def _patch_electrons(radiance, config: SceneConfig) -> np.ndarray:
    from .sensor import signal_model

    rates = radiance.data.reshape(-1, radiance.data.shape[-1]).astype(float) @ signal_model(radiance, config).weights
    return rates  # (24, 3): one pixel per patch


def bench_bands(out: Path, *, quick: bool) -> list[dict]:
    """Camera film vs 8/16/31 bands against a 1-nm reference: time vs ΔE2000 and bias."""
    from .sensor.calibration import camera_to_xyz_d65
    from .colorimetry import xyz_to_linear_srgb
    from .metrics import delta_e2000
    from .render import render

    spp_bias = 1 << (16 if quick else 18)
    width, height = (72, 48) if quick else (144, 96)
    modes = [("camera", "camera"), ("8 bands", "410:690:40"), ("16 bands", "400:700:20"),
             ("31 bands", "400:700:10")]
    rows = []
    for illuminant in ("D65", "FL11"):
        exact_config = scene_from_dict({"illuminant": {"spd": illuminant}, "sensor": {"vignetting": False}})
        reference = _reference_electrons(exact_config)
        ccm = np.asarray(camera_to_xyz_d65(exact_config.sensor.model, illuminant))

        def to_srgb(rgb, white):
            return xyz_to_linear_srgb((rgb / white) @ ccm.T)

        reference_srgb = to_srgb(reference, reference[WHITE_PATCH])
        for label, bands in modes:
            spectral = bands != "camera"
            keys = {"illuminant.spd": illuminant, "render.bands": bands, "render.spectral_output": spectral}
            # one pixel per patch, many samples: the band-discretisation bias, not noise
            patch_config = scene_from_dict({
                "scene": {"preset": "colorchecker", "fill": 1.0, "gap": 0.0},
                "lens": {"model": "pinhole"},
                "sensor": {"width_px": 6, "height_px": 4, "pixel_pitch_um": 500.0, "vignetting": False},
                "render": {"spp": spp_bias, "max_depth": 2, "diffraction": "off"},
            }, overrides=keys)
            patch_image = render(patch_config, with_depth=False)
            electrons = _patch_electrons(patch_image, patch_config)
            scale = reference[WHITE_PATCH, 1] / electrons[WHITE_PATCH, 1]  # pixel areas differ
            bias = electrons * scale / reference - 1
            delta = delta_e2000(to_srgb(electrons, electrons[WHITE_PATCH]), reference_srgb)
            timing_config = _chart_scene(width, height, **{**keys, "render.spp": 16 if quick else 64})
            render(timing_config, with_depth=False)  # warm-up (kernel compilation)
            _, seconds = _timed(render, timing_config, with_depth=False, repeats=3)
            rows.append({"illuminant": illuminant, "bands": label, "seconds": seconds,
                         "delta_e2000_mean": float(np.mean(delta)), "delta_e2000_max": float(np.max(delta)),
                         "bias_r_pct": float(np.median(bias[:, 0]) * 100),
                         "bias_g_pct": float(np.median(bias[:, 1]) * 100),
                         "bias_b_pct": float(np.median(bias[:, 2]) * 100),
                         "bias_max_abs_pct": float(np.max(np.abs(bias)) * 100)})
    for illuminant in ("D65", "FL11"):
        subset = [r for r in rows if r["illuminant"] == illuminant]
        baseline = next(r["seconds"] for r in subset if r["bands"] == "31 bands")
        for row in subset:
            row["time_ratio"] = row["seconds"] / baseline
        _mark_front(subset, "time_ratio", "delta_e2000_mean")
    _write_csv(rows, out / "bands.csv")
    _chart(rows, out / "bands.png", x="time_ratio", y="delta_e2000_mean", label="bands", group="illuminant",
           xlabel="render time / 31 bands (same illuminant)", ylabel="mean ΔE2000 vs 1-nm integration",
           title="Spectral sampling: time vs colour error (ColorChecker)")
    _chart(rows, out / "bands_bias.png", x="time_ratio", y="bias_max_abs_pct", label="bands", group="illuminant",
           xlabel="render time / 31 bands (same illuminant)", ylabel="worst per-channel bias vs 1 nm (%)",
           title="Spectral sampling: time vs per-channel bias")
    return rows


def _isp_fixture(quick: bool):
    """A rendered ColorChecker exposed with and without noise, and its ground truth."""
    from .colorimetry import groundtruth_linear_srgb
    from .presets import colorchecker_patches, white_reference_mask
    from .render import render
    from .sensor import expose

    width, height = (144, 96) if quick else (576, 384)
    config = _chart_scene(width, height, **{"render.spp": 32 if quick else 64, "exposure.iso": 800,
                                            "isp.tone": "linear"})
    radiance = render(config, with_depth=False)
    mask = white_reference_mask(config)
    clean_config = config.replace(**{"sensor.shot_noise": False, "sensor.read_noise_e": 0.0,
                                     "sensor.dark_current_e_per_s": 0.0, "sensor.dsnu_e": 0.0, "sensor.prnu": 0.0})
    clean = expose(radiance, clean_config, white_mask=mask)
    noisy = expose(radiance, config, white_mask=mask)
    white = colorchecker_patches(config)[WHITE_PATCH].interior(0.2)
    truth = groundtruth_linear_srgb(radiance, config.illuminant.spd, white_region=white)
    return config, clean, noisy, truth, white


def _score(linear, truth, white, config) -> tuple[float, float]:
    from .colorimetry import match_exposure
    from .metrics import colorchecker_delta_e, psnr
    from .presets import colorchecker_patches

    matched = match_exposure(linear, truth, white)
    reference_peak = float(np.percentile(truth, 99.5))
    quality = psnr(np.clip(matched / reference_peak, 0, 1), np.clip(truth / reference_peak, 0, 1))
    delta = colorchecker_delta_e(matched, truth, colorchecker_patches(config))["mean"]
    return quality, delta


def bench_isp(out: Path, *, quick: bool) -> list[dict]:
    """Demosaic methods (noise-free RAW) and denoisers (ISO 800 RAW): time vs PSNR/ΔE."""
    from .isp import ISPConfig, develop
    from .isp.config import DEMOSAIC_METHODS, DENOISE_METHODS

    config, clean, noisy, truth, white = _isp_fixture(quick)
    rows = []
    for method in DEMOSAIC_METHODS:
        isp = ISPConfig(demosaic=method, tone="linear")
        developed, seconds = _timed(develop, clean, isp, repeats=2)
        quality, delta = _score(developed.linear, truth, white, config)
        rows.append({"stage": "demosaic", "method": method, "seconds": seconds, "psnr_db": quality,
                     "delta_e2000": delta})
    for strength in ("off", "auto"):
        for method in (DENOISE_METHODS if strength == "auto" else ("none",)):
            isp = ISPConfig(denoise=strength, denoise_method=method if method != "none" else "nlmeans",
                            tone="linear")
            developed, seconds = _timed(develop, noisy, isp)
            quality, delta = _score(developed.linear, truth, white, config)
            rows.append({"stage": "denoise", "method": method, "seconds": seconds, "psnr_db": quality,
                         "delta_e2000": delta})
    for stage in ("demosaic", "denoise"):
        subset = [r for r in rows if r["stage"] == stage]
        baseline = subset[0]["seconds"]
        for row in subset:
            row["time_ratio"] = row["seconds"] / baseline
            row["neg_psnr_db"] = -row["psnr_db"]
        _mark_front(subset, "time_ratio", "neg_psnr_db")
    _write_csv(rows, out / "isp.csv")
    _chart([r for r in rows if r["stage"] == "demosaic"], out / "demosaic.png", x="time_ratio", y="delta_e2000",
           label="method", xlabel="develop time / bilinear", ylabel="mean ΔE2000 (noise-free RAW)",
           title="Demosaic methods: time vs colour error")
    _chart([r for r in rows if r["stage"] == "denoise"], out / "denoise.png", x="time_ratio", y="neg_psnr_db",
           label="method", xlabel="develop time / no denoise", ylabel="−PSNR (dB) vs ground truth (ISO 800)",
           title="Denoisers: time vs image error (lower is better)")
    return rows


def bench_rawpy(out: Path, *, quick: bool) -> list[dict]:
    """Our ISP against LibRaw's demosaics on the same DNG: time vs ΔE2000."""
    import colour
    import rawpy

    from .isp import ISPConfig, develop
    from .raw import read_raw, write_dng

    config, clean, _, truth, white = _isp_fixture(quick)
    path = out / "bench_chart.dng"
    write_dng(clean, path)
    raw = read_raw(path)
    rows = []
    xyz_to_srgb = np.asarray(colour.models.RGB_COLOURSPACE_sRGB.matrix_XYZ_to_RGB)
    for name, algorithm in (("rawpy LINEAR", rawpy.DemosaicAlgorithm.LINEAR),
                            ("rawpy AHD", rawpy.DemosaicAlgorithm.AHD),
                            ("rawpy DCB", rawpy.DemosaicAlgorithm.DCB)):
        def libraw():
            with rawpy.imread(str(path)) as handle:
                return handle.postprocess(demosaic_algorithm=algorithm, use_camera_wb=True, gamma=(1, 1),
                                          no_auto_bright=True, output_bps=16, adjust_maximum_thr=0,
                                          output_color=rawpy.ColorSpace.XYZ, user_flip=0)

        xyz, seconds = _timed(libraw, repeats=2)
        linear = (xyz.astype(float) / 65535.0) @ xyz_to_srgb.T
        quality, delta = _score(linear, truth, white, config)
        rows.append({"pipeline": name, "seconds": seconds, "psnr_db": quality, "delta_e2000": delta})
    for method in ("bilinear", "malvar2004", "menon2007"):
        developed, seconds = _timed(develop, raw, ISPConfig(demosaic=method, tone="linear", colour_matrix="dng"),
                                    repeats=2)
        quality, delta = _score(developed.linear, truth, white, config)
        rows.append({"pipeline": f"ours {method}", "seconds": seconds, "psnr_db": quality, "delta_e2000": delta})
    path.unlink()
    baseline = rows[0]["seconds"]
    for row in rows:
        row["time_ratio"] = row["seconds"] / baseline
    _mark_front(rows, "time_ratio", "delta_e2000")
    _write_csv(rows, out / "rawpy.csv")
    _chart(rows, out / "rawpy.png", x="time_ratio", y="delta_e2000", label="pipeline",
           xlabel=f"develop time / rawpy LINEAR ({baseline:.3f} s)", ylabel="mean ΔE2000 (DNG colour matrix)",
           title="Our ISP vs LibRaw on the same DNG")
    return rows


BENCHMARKS = {"spp": bench_spp, "bands": bench_bands, "isp": bench_isp, "rawpy": bench_rawpy}


def run_benchmarks(output: str | Path, *, quick: bool = False, only: list[str] | None = None,
                   log=print) -> dict[str, list[dict]]:
    """Run the benchmarks (all, or ``only`` those named) and write CSV + PNG into ``output``."""
    from .errors import ConfigError

    names = list(only or BENCHMARKS)
    unknown = [n for n in names if n not in BENCHMARKS]
    if unknown:
        raise ConfigError(f"unknown benchmark(s) {', '.join(unknown)}; valid: {', '.join(BENCHMARKS)}")
    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    results = {}
    for name in names:
        t0 = time.perf_counter()
        results[name] = BENCHMARKS[name](out, quick=quick)
        log(f"bench {name}: {len(results[name])} rows in {time.perf_counter() - t0:.1f} s -> {out}/{name}*.png")
    return results


def configure_parser(parser) -> None:
    """Arguments of ``spectral-cam bench``."""
    parser.add_argument("-o", "--output", default="bench", help="output folder for CSV + PNG (default: bench)")
    parser.add_argument("--quick", action="store_true", help="small sizes: a few minutes on 2 cores")
    parser.add_argument("--only", action="append", choices=list(BENCHMARKS), help="run only these (repeatable)")
    parser.set_defaults(func=run)


def run(args) -> int:
    import sys

    run_benchmarks(args.output, quick=args.quick, only=args.only, log=lambda m: print(m, file=sys.stderr))
    return 0
