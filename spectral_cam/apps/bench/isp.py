"""ISP benchmarks: our demosaic methods and denoisers (``isp``), and our ISP against LibRaw
on the same DNG (``rawpy``), on a rendered ColorChecker.

- ``isp``: demosaic methods on the noise-free RAW and denoisers on the ISO 800 RAW — develop
  time against PSNR and ΔE2000;
- ``rawpy``: LibRaw's LINEAR, AHD and DCB demosaics against ours on the DNG we write — develop
  time against ΔE2000 (both with the DNG's colour matrix).

References
----------
.. [1] Sharma, Wu & Dalal (2005). The CIEDE2000 colour-difference formula.
.. [2] docs/design.md, "ISP" and "Ground truth and metrics".
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .common import NOISE_FREE, chart_scene, mark_front, pareto_chart, timed, write_rows

__all__ = ["bench_isp", "bench_rawpy", "libraw_xyz", "demosaic_methods_for"]


def _isp_fixture(quick: bool):
    """A rendered ColorChecker exposed with and without noise, its ground truth and white patch."""
    from ...colour_ground_truth import groundtruth_linear_srgb, white_patch_index
    from ...presets import colorchecker_patches, white_reference_mask
    from ...render import render
    from ...sensor import expose

    width, height = (144, 96) if quick else (576, 384)
    config = chart_scene(width, height, **{"render.spp": 32 if quick else 64, "exposure.iso": 800,
                                           "isp.tone": "linear"})
    radiance = render(config, with_depth=False)
    mask = white_reference_mask(config)
    clean = expose(radiance, config.replace(**NOISE_FREE), white_mask=mask)
    noisy = expose(radiance, config, white_mask=mask)
    white = colorchecker_patches(config)[white_patch_index()].interior(0.2)
    truth = groundtruth_linear_srgb(radiance, config.illuminant.spd, white_region=white)
    return config, clean, noisy, truth, white


def _score(linear, truth, white, config) -> tuple[float, float]:
    """PSNR (dB, against the truth's 99.5th percentile as peak) and mean ΔE2000 of the
    patches, after matching exposure on the white patch."""
    from ...colour_ground_truth import match_exposure
    from ...metrics import colorchecker_delta_e, psnr
    from ...presets import colorchecker_patches

    matched = match_exposure(linear, truth, white)
    reference_peak = float(np.percentile(truth, 99.5))
    quality = psnr(np.clip(matched / reference_peak, 0, 1), np.clip(truth / reference_peak, 0, 1))
    delta = colorchecker_delta_e(matched, truth, colorchecker_patches(config))["mean"]
    return quality, delta


def demosaic_methods_for(cfa: str) -> list[str]:
    """The registered demosaic methods that take a ``cfa`` mosaic as asked, in registry order.

    :func:`spectral_cam.isp.demosaic.method_for` is what the develop asks: it refuses a method made
    for another tile (a Quad Bayer remosaic on a Bayer mosaic) and swaps a Bayer method for the
    tile's default on a larger tile; a method is listed only where it runs unchanged.

    Parameters
    ----------
    cfa : str
        The mosaic's tile (``"RGGB"``, ``"XTRANS"``, ``"QUAD_RGGB"``, ...).

    Returns
    -------
    list of str
        Names from :data:`spectral_cam.isp.demosaic.DEMOSAIC`.
    """
    from ...errors import ConfigError
    from ...isp.demosaic import DEMOSAIC, method_for

    accepted = []
    for name in DEMOSAIC:
        try:
            if method_for(cfa, name) == name:
                accepted.append(name)
        except ConfigError:  # made for another tile
            continue
    return accepted


def _rank_by_detail(rows: list[dict]) -> float:
    """Time ratios against the first row, and the Pareto flags of time against PSNR (stored
    as ``neg_psnr_db``, an error to minimise); returns the baseline time (s)."""
    baseline = rows[0]["seconds"]
    for row in rows:
        row["time_ratio"] = row["seconds"] / baseline
        row["neg_psnr_db"] = -row["psnr_db"]
    mark_front(rows, "time_ratio", "neg_psnr_db")
    return baseline


def bench_isp(out: Path, *, quick: bool) -> list[dict]:
    """Demosaic methods (noise-free RAW) and denoisers (ISO 800 RAW): develop time against
    PSNR and ΔE2000. Only the methods that take the chart's mosaic run
    (:func:`demosaic_methods_for`); the Quad Bayer and RGBW ones have their own tiles.

    Parameters
    ----------
    out : pathlib.Path
        Folder for ``isp.csv``, ``demosaic.png`` and ``denoise.png``.
    quick : bool
        A 144×96 chart at 32 spp instead of 576×384 at 64.

    Returns
    -------
    list of dict
        One row per stage and method (columns as in ``isp.csv``).
    """
    from ...isp import ISPConfig, develop
    from ...isp.config import DENOISE_METHODS

    config, clean, noisy, truth, white = _isp_fixture(quick)
    rows = []
    for method in demosaic_methods_for(clean.cfa):
        isp = ISPConfig(demosaic=method, tone="linear")
        developed, seconds = timed(develop, clean, isp, repeats=2)
        quality, delta = _score(developed.linear, truth, white, config)
        rows.append({"stage": "demosaic", "method": method, "seconds": seconds, "psnr_db": quality,
                     "delta_e2000": delta})
    for strength in ("off", "auto"):
        for method in (DENOISE_METHODS if strength == "auto" else ("none",)):
            isp = ISPConfig(denoise=strength, denoise_method=method if method != "none" else "nlmeans",
                            tone="linear")
            developed, seconds = timed(develop, noisy, isp)
            quality, delta = _score(developed.linear, truth, white, config)
            rows.append({"stage": "denoise", "method": method, "seconds": seconds, "psnr_db": quality,
                         "delta_e2000": delta})
    for stage in ("demosaic", "denoise"):
        _rank_by_detail([r for r in rows if r["stage"] == stage])
    write_rows(rows, out / "isp.csv")
    # the charts show what the CSV's Pareto flags are computed on: PSNR against the ground truth
    pareto_chart([r for r in rows if r["stage"] == "demosaic"], out / "demosaic.png", x="time_ratio",
                 y="psnr_db", label="method", xlabel="develop time / bilinear", higher_is_better=True,
                 ylabel="PSNR (dB) vs ground truth (noise-free RAW)",
                 title="Demosaic methods: time vs detail (higher is better)")
    pareto_chart([r for r in rows if r["stage"] == "denoise"], out / "denoise.png", x="time_ratio",
                 y="psnr_db", label="method", xlabel="develop time / no denoise", higher_is_better=True,
                 ylabel="PSNR (dB) vs ground truth (ISO 800)",
                 title="Denoisers: time vs image quality (higher is better)")
    return rows


def libraw_xyz(path: str | Path, algorithm) -> np.ndarray:
    """Develop a DNG with LibRaw to linear XYZ: camera white balance, no gamma, no
    auto-brightening, the DNG's colour matrix (LibRaw's own footing for a comparison).

    Parameters
    ----------
    path : path-like
        The DNG.
    algorithm : rawpy.DemosaicAlgorithm
        LibRaw's demosaic.

    Returns
    -------
    numpy.ndarray
        uint16 (H, W, 3) XYZ, 65535 = 1 (:func:`spectral_cam.colour_ground_truth.xyz_to_linear_srgb`
        of it divided by 65535 is linear sRGB).

    References
    ----------
    .. [1] LibRaw, ``dcraw_process`` output parameters (via rawpy's ``postprocess``).
    """
    import rawpy

    with rawpy.imread(str(path)) as handle:
        return handle.postprocess(demosaic_algorithm=algorithm, use_camera_wb=True, gamma=(1, 1),
                                  no_auto_bright=True, output_bps=16, adjust_maximum_thr=0,
                                  output_color=rawpy.ColorSpace.XYZ, user_flip=0)


def bench_rawpy(out: Path, *, quick: bool) -> list[dict]:
    """Our ISP against LibRaw's demosaics on the same DNG: develop time against ΔE2000.

    Parameters
    ----------
    out : pathlib.Path
        Folder for ``rawpy.csv`` and ``rawpy.png`` (the DNG is written there and removed).
    quick : bool
        A 144×96 chart at 32 spp instead of 576×384 at 64.

    Returns
    -------
    list of dict
        One row per pipeline (columns as in ``rawpy.csv``).
    """
    import rawpy

    from ...colour_ground_truth import xyz_to_linear_srgb
    from ...isp import ISPConfig, develop
    from ...raw import read_raw, write_dng

    config, clean, _, truth, white = _isp_fixture(quick)
    path = out / "bench_chart.dng"
    write_dng(clean, path)
    raw = read_raw(path)
    rows = []
    for name, algorithm in (("rawpy LINEAR", rawpy.DemosaicAlgorithm.LINEAR),
                            ("rawpy AHD", rawpy.DemosaicAlgorithm.AHD),
                            ("rawpy DCB", rawpy.DemosaicAlgorithm.DCB)):
        xyz, seconds = timed(libraw_xyz, path, algorithm, repeats=2)
        quality, delta = _score(xyz_to_linear_srgb(xyz.astype(float) / 65535.0), truth, white, config)
        rows.append({"pipeline": name, "seconds": seconds, "psnr_db": quality, "delta_e2000": delta})
    for method in ("bilinear", "malvar2004", "menon2007"):
        developed, seconds = timed(develop, raw, ISPConfig(demosaic=method, tone="linear", colour_matrix="dng"),
                                   repeats=2)
        quality, delta = _score(developed.linear, truth, white, config)
        rows.append({"pipeline": f"ours {method}", "seconds": seconds, "psnr_db": quality, "delta_e2000": delta})
    path.unlink()
    # colour error is the DNG matrix's for every pipeline (≈ 0.99 ΔE); detail tells them apart
    baseline = _rank_by_detail(rows)
    write_rows(rows, out / "rawpy.csv")
    pareto_chart(rows, out / "rawpy.png", x="time_ratio", y="psnr_db", label="pipeline", higher_is_better=True,
                 xlabel=f"develop time / rawpy LINEAR ({baseline:.3f} s)", ylabel="PSNR (dB) vs ground truth",
                 title="Our ISP vs LibRaw on the same DNG (higher is better)")
    return rows
