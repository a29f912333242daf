"""Sampling benchmarks: samples per pixel (``spp``) and spectral bands (``bands``).

- ``spp``: samples per pixel for the LLVM and scalar variants — render time against
  Monte-Carlo noise (which falls as 1/√spp) and against ΔE2000 of the developed ColorChecker;
- ``bands``: the camera film (3 measured curves + CMFs) and 8/16/31 bands against a 1-nm
  reference integration, under D65 and FL11 — render time against ΔE2000 and per-channel bias.

References
----------
.. [1] Pharr, Jakob & Humphreys (2023). Physically Based Rendering, 4th ed., §2.1
   (Monte-Carlo error falls as 1/√spp).
.. [2] Sharma, Wu & Dalal (2005). The CIEDE2000 colour-difference formula.
.. [3] docs/design.md, "Rendering" (bands and the camera film) and "Sensor" (the signal model).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...scene import SceneConfig, scene_from_dict
from .common import NOISE_FREE, chart_scene, mark_front, pareto_chart, timed, write_rows

__all__ = ["bench_spp", "bench_bands", "bands_charts"]

#: The bands benchmark's reference grid: 1-nm bands from 380 to 730 nm (band centres).
REFERENCE_BANDS = "380.5:729.5:1"


def _develop_delta_e(radiance, config: SceneConfig) -> float:
    """Mean ΔE2000 of the developed, noise-free ColorChecker against the analytic ground truth."""
    from ...colour_ground_truth import patch_linear_srgb
    from ...isp import develop
    from ...metrics import colorchecker_delta_e
    from ...presets import colorchecker_patches, white_reference_mask
    from ...sensor import expose

    noise_free = config.replace(**{**NOISE_FREE, "isp.tone": "linear"})
    raw = expose(radiance, noise_free, white_mask=white_reference_mask(noise_free))
    linear = develop(raw, noise_free.isp).linear
    truth = patch_linear_srgb(config.illuminant.spd)
    return colorchecker_delta_e(linear, truth, colorchecker_patches(config))["mean"]


def bench_spp(out: Path, *, quick: bool) -> list[dict]:
    """Render time against Monte-Carlo noise and ΔE2000 over samples per pixel, per variant.

    Parameters
    ----------
    out : pathlib.Path
        Folder for ``spp.csv``, ``spp.png`` and ``spp_delta_e.png``.
    quick : bool
        72×48 pixels and 4–64 spp instead of 144×96 and 4–256.

    Returns
    -------
    list of dict
        One row per variant and spp (columns as in ``spp.csv``).
    """
    from ...presets import colorchecker_patches
    from ...render import choose_variant, render

    width, height = (72, 48) if quick else (144, 96)
    spps = [4, 16, 64] if quick else [4, 16, 64, 256]
    variants = ["llvm_ad_spectral", "scalar_spectral"] if choose_variant("auto") != "scalar_spectral" \
        else ["scalar_spectral"]
    rows = []
    for variant in variants:
        render(chart_scene(width, height, **{"render.spp": 1, "render.variant": variant}), with_depth=False)  # JIT warm-up
        for spp in spps:
            config = chart_scene(width, height, **{"render.spp": spp, "render.variant": variant})
            first, seconds = timed(render, config, with_depth=False, repeats=2)
            second = render(config.replace(**{"render.seed": 1}), with_depth=False)
            noise = []
            for patch in colorchecker_patches(config):
                a = first.data[patch.interior(0.2)].sum(axis=-1)
                b = second.data[patch.interior(0.2)].sum(axis=-1)
                noise.append(np.std(a - b) / np.sqrt(2) / max(np.mean((a + b) / 2), 1e-30))
            rows.append({"variant": variant, "spp": spp, "seconds": seconds,
                         "mc_noise_rel": float(np.median(noise)),
                         "delta_e2000": _develop_delta_e(first, config)})
    baseline = next(r["seconds"] for r in rows if r["spp"] == spps[0] and r["variant"] == variants[0])
    for row in rows:
        row["time_ratio"] = row["seconds"] / baseline
    mark_front(rows, "time_ratio", "mc_noise_rel")
    write_rows(rows, out / "spp.csv")
    pareto_chart(rows, out / "spp.png", x="time_ratio", y="mc_noise_rel", label="spp", group="variant",
                 xlabel=f"render time / {variants[0]} at {spps[0]} spp ({baseline:.2f} s)",
                 ylabel="relative Monte-Carlo noise per pixel",
                 title=f"Samples per pixel: time vs Monte-Carlo noise ({width}×{height} ColorChecker)")
    pareto_chart(rows, out / "spp_delta_e.png", x="time_ratio", y="delta_e2000", label="spp", group="variant",
                 xlabel=f"render time / {variants[0]} at {spps[0]} spp", ylabel="mean ΔE2000 (noise-free sensor)",
                 title="Samples per pixel: time vs colour error")
    return rows


def _channel_rates(radiance, config: SceneConfig) -> np.ndarray:
    """Photo-electrons per second of every pixel in every CFA channel, (N, 3): the radiance
    through the sensor's signal model (:func:`spectral_cam.sensor.signal_model`)."""
    from ...sensor import signal_model

    data = radiance.data.reshape(-1, radiance.data.shape[-1]).astype(float)
    return data @ signal_model(radiance, config).weights


def _reference_rates(config: SceneConfig) -> np.ndarray:
    """Electron rates (24, 3) of the ColorChecker's patches from 1-nm bands of Lambertian
    radiance ρE/π (:func:`spectral_cam.radiance_targets.lambertian_radiance`) under the config's
    illuminant."""
    from ... import spectra
    from ...radiance_targets import lambertian_radiance, reflectance_set
    from ...image import SpectralImage

    grid = spectra.parse_bands(REFERENCE_BANDS)
    radiance = lambertian_radiance(config.illuminant.spd, reflectance_set("colorchecker").sds,
                                   illuminance_lux=config.illuminant.illuminance_lux, bands=grid)
    image = SpectralImage(radiance[None].astype(np.float32), np.asarray(grid.centres_nm), np.asarray(grid.edges_nm))
    return _channel_rates(image, config)


def bench_bands(out: Path, *, quick: bool) -> list[dict]:
    """Camera film against 8/16/31 bands, judged by a 1-nm reference: render time against
    ΔE2000 and per-channel bias, under D65 and FL11.

    The bias is measured on one pixel per patch rendered with many samples (the band
    discretisation, not noise); the time on the benchmarks' ColorChecker scene.

    Parameters
    ----------
    out : pathlib.Path
        Folder for ``bands.csv``, ``bands.png`` and ``bands_bias.png``.
    quick : bool
        2¹⁶ samples for the bias and a 72×48 timing render instead of 2¹⁸ and 144×96.

    Returns
    -------
    list of dict
        One row per illuminant and band mode (columns as in ``bands.csv``).
    """
    from ...colour_ground_truth import white_patch_index, xyz_to_linear_srgb
    from ...metrics import delta_e2000
    from ...render import render
    from ...sensor.colour_calibration import camera_to_xyz_d65

    white = white_patch_index()
    spp_bias = 1 << (16 if quick else 18)
    width, height = (72, 48) if quick else (144, 96)
    modes = [("camera", "camera"), ("8 bands", "410:690:40"), ("16 bands", "400:700:20"),
             ("31 bands", "400:700:10")]
    rows = []
    for illuminant in ("D65", "FL11"):
        exact_config = scene_from_dict({"illuminant": {"spd": illuminant}, "sensor": {"vignetting": False}})
        reference = _reference_rates(exact_config)
        ccm = np.asarray(camera_to_xyz_d65(exact_config.sensor.model, illuminant))
        reference_srgb = xyz_to_linear_srgb((reference / reference[white]) @ ccm.T)
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
            electrons = _channel_rates(render(patch_config, with_depth=False), patch_config)
            scale = reference[white, 1] / electrons[white, 1]  # pixel areas differ
            bias = electrons * scale / reference - 1
            delta = delta_e2000(xyz_to_linear_srgb((electrons / electrons[white]) @ ccm.T), reference_srgb)
            timing_config = chart_scene(width, height, **{**keys, "render.spp": 16 if quick else 64})
            render(timing_config, with_depth=False)  # warm-up (kernel compilation)
            _, seconds = timed(render, timing_config, with_depth=False, repeats=3)
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
        mark_front(subset, "time_ratio", "delta_e2000_mean")
    write_rows(rows, out / "bands.csv")
    bands_charts(rows, out)
    return rows


def bands_charts(rows: list[dict], out: Path) -> None:
    """Draw ``bands.png`` and ``bands_bias.png`` from the rows of ``bands.csv``.

    Redrawing from the committed CSV without measuring again::

        from pathlib import Path
        from spectral_cam.apps.bench.common import read_rows
        from spectral_cam.apps.bench.sampling import bands_charts
        bands_charts(read_rows("docs/bench/bands.csv"), Path("docs/bench"))
    """
    out = Path(out)
    pareto_chart(rows, out / "bands.png", x="time_ratio", y="delta_e2000_mean", label="bands", group="illuminant",
                 xlabel="render time / 31 bands (same illuminant)", ylabel="mean ΔE2000 vs 1-nm integration",
                 title="Spectral sampling: time vs colour error (ColorChecker)")
    pareto_chart(rows, out / "bands_bias.png", x="time_ratio", y="bias_max_abs_pct", label="bands",
                 group="illuminant", xlabel="render time / 31 bands (same illuminant)",
                 ylabel="worst per-channel bias vs 1 nm (%)", title="Spectral sampling: time vs per-channel bias")
