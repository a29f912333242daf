"""Study (a): where demosaicing loses detail and invents colour.

Every registered demosaicing method (:data:`spectral_cam.isp.demosaic.DEMOSAIC`) on
black-and-white checkerboards of square size 1, 2, 4, 8, … px (averaged over the four CFA
phases) and on a zone plate: per-channel error maps, mean absolute error against square
size and against spatial frequency, a false-colour measure, and the feature size at which
each method becomes essentially lossless (:data:`LOSSLESS_TOLERANCE`).

References
----------
.. [1] Li, X., Gunturk, B., & Zhang, L. (2008). Image demosaicing: a systematic survey.
   Proc. SPIE 6822, 68221J (false colour and zipper artefacts; test patterns).
.. [2] docs/design.md, "ISP" (the demosaicing methods and their registry).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...viz import figure, save_png
from .settings import StressSettings
from .summary import summary_row

__all__ = ["LOSSLESS_TOLERANCE", "DEMOSAIC_BORDER_PX", "STUDY_CFA", "checkerboard", "zone_plate",
           "demosaic_errors", "demosaic_study", "plot_demosaic"]

#: A demosaicing result counts as essentially lossless when its mean absolute error in
#: every channel and its false colour stay at or below this fraction of the white level.
LOSSLESS_TOLERANCE = 0.01
#: Pixels left out at each border of the demosaicing error statistics (the reach of the
#: methods' largest kernels; borders are handled by padding, which differs per method).
DEMOSAIC_BORDER_PX = 6
#: The demosaicing studies use this CFA (the methods are phase-equivariant; tests check it).
STUDY_CFA = "RGGB"


def checkerboard(square_px: int, shape: tuple[int, int], *, offset: tuple[int, int] = (0, 0)) -> np.ndarray:
    """A black-and-white checkerboard, point sampled on the pixel grid.

    Parameters
    ----------
    square_px
        Side of one square, pixels (≥ 1).
    shape
        (height, width) of the image, pixels.
    offset
        (row, column) shift of the pattern, pixels (to move it against the CFA phase).

    Returns
    -------
    numpy.ndarray
        (H, W) float32, 1 on white squares and 0 on black ones (the top-left square is
        white without offset).

    References
    ----------
    .. [1] Li, Gunturk & Zhang (2008), Proc. SPIE 6822 (synthetic demosaicing targets).
    """
    if not (isinstance(square_px, (int, np.integer)) and square_px >= 1):
        raise ConfigError(f"checkerboard square size {square_px!r} must be a whole number of pixels >= 1")
    rows = (np.arange(shape[0]) + offset[0]) // square_px
    cols = (np.arange(shape[1]) + offset[1]) // square_px
    return ((rows[:, None] + cols[None, :]) % 2 == 0).astype(np.float32)


def zone_plate(size_px: int, *, max_frequency: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """A circular zone plate ``½ + ½·cos(π·k·r²)`` whose local frequency ``k·r`` (cycles/px)
    rises linearly from 0 at the centre to ``max_frequency`` at the middle of each edge.

    Parameters
    ----------
    size_px
        Side of the square image, pixels.
    max_frequency
        Local frequency at radius ``size_px / 2``, cycles per pixel (0.5 = Nyquist).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        (H, W) float32 image in [0, 1] and (H, W) local frequency, cycles/px.

    References
    ----------
    .. [1] Li, Gunturk & Zhang (2008), Proc. SPIE 6822; the zone plate's instantaneous
       frequency d(k·r²/2)/dr = k·r.
    """
    centre = size_px / 2.0
    y, x = np.mgrid[0:size_px, 0:size_px].astype(np.float64) + 0.5 - centre
    radius = np.hypot(x, y)
    k = max_frequency / centre
    image = 0.5 + 0.5 * np.cos(np.pi * k * radius ** 2)
    return image.astype(np.float32), k * radius


def demosaic_errors(truth: np.ndarray, *, method: str, cfa: str = STUDY_CFA,
                    border_px: int = DEMOSAIC_BORDER_PX) -> dict:
    """Demosaic the CFA samples of an achromatic image and measure the error.

    Parameters
    ----------
    truth
        (H, W) linear grey image (R = G = B), 1 = white level.
    method
        A name of :data:`spectral_cam.isp.demosaic.DEMOSAIC`.
    cfa
        Bayer tile.
    border_px
        Pixels left out at each border of the statistics.

    Returns
    -------
    dict
        ``error``: (H, W, 3) signed error (output − truth); ``mae``: (3,) mean absolute
        error per channel over the interior; ``mae_all``: their mean; ``false_colour``:
        mean of max(R, G, B) − min(R, G, B) over the interior (0 for a neutral output);
        ``output``: (H, W, 3) demosaiced image.

    References
    ----------
    .. [1] Li, Gunturk & Zhang (2008), Proc. SPIE 6822 (false colour of achromatic detail).
    """
    from ...isp.demosaic import demosaic

    truth = np.asarray(truth, dtype=np.float32)
    # an achromatic scene white-balanced to gains 1 gives every CFA site the grey value
    output = demosaic(truth, cfa, method=method)
    error = output - truth[..., None]
    inner = (slice(border_px, -border_px or None), slice(border_px, -border_px or None))
    mae = np.abs(error[inner]).reshape(-1, 3).mean(axis=0)
    inside = output[inner]
    false_colour = float(np.mean(inside.max(axis=-1) - inside.min(axis=-1)))
    return {"error": error, "mae": mae, "mae_all": float(mae.mean()), "false_colour": false_colour,
            "output": output}


def _lossless_from(sizes, mae_per_channel, false_colour, tolerance) -> float | None:
    """Smallest size from which on (towards larger sizes) every channel and the false
    colour stay within the tolerance; None if never."""
    ok = [bool(np.all(np.asarray(m) <= tolerance) and f <= tolerance)
          for m, f in zip(mae_per_channel, false_colour)]
    best = None
    for size, good in zip(reversed(list(sizes)), reversed(ok)):
        if not good:
            break
        best = size
    return best


def demosaic_study(settings: StressSettings, *, methods=None) -> dict:
    """Demosaicing on checkerboards and a zone plate (study (a)).

    Each checkerboard is measured at the four shifts (0|1, 0|1) against the CFA and the
    errors averaged; images are ``max(64, 4·square)`` pixels wide so every size shows at
    least four squares.

    Parameters
    ----------
    settings
        Square sizes, zone-plate size and frequency rings.
    methods
        Demosaicing method names; default every method of the registry.

    Returns
    -------
    dict
        ``rows`` (summary) and ``data``: per method the mean absolute error per channel and
        false colour per square size, the zone-plate error per frequency ring, the lossless
        square size (px) and the lossless zone-plate frequency (cycles/px) with its
        half-period feature size (px); ``maps`` (arrays for the figures, not serialised).

    References
    ----------
    .. [1] Li, Gunturk & Zhang (2008), Proc. SPIE 6822.
    .. [2] Malvar, He & Cutler (2004); Menon, Andriani & Calvagno (2007) (the methods).
    """
    from ...isp.demosaic import bayer_methods

    methods = bayer_methods() if methods is None else list(methods)
    sizes = [int(s) for s in settings.square_sizes_px]
    phases = [(0, 0), (0, 1), (1, 0), (1, 1)]
    data: dict = {"square_sizes_px": sizes, "tolerance": LOSSLESS_TOLERANCE, "methods": {}}
    maps: dict = {"checker": {}, "zone": {}}
    rows = []
    plate, frequency = zone_plate(settings.zone_plate_px)
    edges = np.linspace(0.0, 0.5, settings.frequency_bins + 1)
    inner = np.zeros(plate.shape, bool)
    b = DEMOSAIC_BORDER_PX
    inner[b:-b, b:-b] = True
    ring_of = np.digitize(frequency, edges) - 1
    for method in methods:
        mae, fc = [], []
        for size in sizes:
            side = max(64, 4 * size)
            results = [demosaic_errors(checkerboard(size, (side, side), offset=p), method=method)
                       for p in phases]
            mae.append(np.mean([r["mae"] for r in results], axis=0))
            fc.append(float(np.mean([r["false_colour"] for r in results])))
            maps["checker"][(method, size)] = results[0]
        zone = demosaic_errors(plate, method=method)
        maps["zone"][method] = zone
        abs_err = np.abs(zone["error"]).mean(axis=-1)
        chroma = zone["output"].max(axis=-1) - zone["output"].min(axis=-1)
        ring_mae, ring_fc = [], []
        for i in range(len(edges) - 1):
            sel = inner & (ring_of == i)
            ring_mae.append(float(abs_err[sel].mean()) if sel.any() else float("nan"))
            ring_fc.append(float(chroma[sel].mean()) if sel.any() else float("nan"))
        limit = 0.0
        for upper, e, f in zip(edges[1:], ring_mae, ring_fc):
            if not (e <= LOSSLESS_TOLERANCE and f <= LOSSLESS_TOLERANCE):
                break
            limit = float(upper)
        lossless = _lossless_from(sizes, mae, fc, LOSSLESS_TOLERANCE)
        data["methods"][method] = {
            "checker_mae_per_channel": [list(map(float, m)) for m in mae],
            "checker_mae": [float(np.mean(m)) for m in mae],
            "checker_false_colour": fc,
            "lossless_square_px": lossless,
            "zone_frequency_edges": [float(e) for e in edges],
            "zone_mae": ring_mae,
            "zone_false_colour": ring_fc,
            "zone_lossless_frequency": limit,
            "zone_lossless_feature_px": (0.5 / limit) if limit > 0 else None,
        }
        first = sizes.index(1) if 1 in sizes else 0
        rows += [
            summary_row("demosaic", method, f"mean abs error, {sizes[first]}-px checkerboard",
                 float(np.mean(mae[first])), "of white"),
            summary_row("demosaic", method, f"false colour, {sizes[first]}-px checkerboard", fc[first], "of white"),
            summary_row("demosaic", method, "lossless square size", lossless, "px",
                 "" if lossless is not None else f"error > {LOSSLESS_TOLERANCE:g} up to {sizes[-1]} px"),
            summary_row("demosaic", method, "lossless zone-plate half period", data["methods"][method]["zone_lossless_feature_px"],
                 "px", f"frequency <= {limit:.4g} cycles/px"),
        ]
        if 8 in sizes:
            rows.append(summary_row("demosaic", method, "mean abs error, 8-px checkerboard",
                                    float(np.mean(mae[sizes.index(8)])), "of white"))
    return {"rows": rows, "data": data, "maps": maps}


def plot_demosaic(result: dict, directory: Path) -> list[str]:
    """Figures of :func:`demosaic_study`: checkerboard outputs, per-channel error maps
    (checkerboards and zone plate) and the error-versus-size/frequency charts."""
    data, maps = result["data"], result["maps"]
    methods = list(data["methods"])
    sizes = [s for s in data["square_sizes_px"] if s <= 8] or data["square_sizes_px"][:4]
    directory = Path(directory)
    return [save_png(_checkerboard_figure(maps, methods, sizes), directory / "demosaic_checkerboards.png").name,
            save_png(_checker_error_figure(maps, methods, sizes), directory / "demosaic_error_maps.png",
                     palette=True).name,
            save_png(_zone_plate_figure(maps, methods), directory / "demosaic_zone_plate.png", palette=True).name,
            save_png(_error_chart(data, methods), directory / "demosaic_error_vs_size.png").name]


#: Pixels of each checkerboard output and error map shown (top-left corner).
_CROP_PX = 32


def _checkerboard_figure(maps: dict, methods: list, sizes: list):
    """Each method's demosaiced checkerboards (rows) at each square size (columns)."""
    fig = figure(1.6 * len(sizes) + 0.8, 1.5 * len(methods) + 0.6)
    axes = fig.subplots(len(methods), len(sizes), squeeze=False)
    for i, method in enumerate(methods):
        for j, size in enumerate(sizes):
            out = maps["checker"][(method, size)]["output"]
            ax = axes[i, j]
            ax.imshow(np.clip(out[:_CROP_PX, :_CROP_PX], 0, 1) ** (1 / 2.2), interpolation="nearest")
            ax.set_xticks([]), ax.set_yticks([])
            if i == 0:
                ax.set_title(f"{size}-px squares", fontsize=9)
            if j == 0:
                ax.set_ylabel(method, fontsize=9)
    fig.suptitle("Demosaiced black-and-white checkerboards (RGGB; colour = false colour)", fontsize=10)
    return fig


def _checker_error_figure(maps: dict, methods: list, sizes: list):
    """Each method's signed error per channel on the checkerboards, on one colour scale."""
    fig = figure(0.95 * 3 * len(sizes) + 1.2, 1.1 * len(methods) + 0.8)
    axes = fig.subplots(len(methods), 3 * len(sizes), squeeze=False)
    image = None
    for i, method in enumerate(methods):
        for j, size in enumerate(sizes):
            err = maps["checker"][(method, size)]["error"][:_CROP_PX, :_CROP_PX]
            for c, name in enumerate("RGB"):
                ax = axes[i, 3 * j + c]
                image = ax.imshow(err[..., c], cmap="RdBu_r", vmin=-1, vmax=1, interpolation="nearest")
                ax.set_xticks([]), ax.set_yticks([])
                if i == 0:
                    ax.set_title(f"{size} px {name}", fontsize=7)
            if j == 0:
                axes[i, 0].set_ylabel(method, fontsize=8)
    fig.colorbar(image, ax=axes, shrink=0.6, label="signed error (of white)")
    fig.suptitle("Per-channel demosaicing error on checkerboards (output − truth)", fontsize=10)
    return fig


def _zone_plate_figure(maps: dict, methods: list):
    """Each method's demosaiced zone plate and its error per channel, one quadrant each."""
    # about one screen pixel per image pixel: a resampled zone plate would show its own moiré
    panel_in = maps["zone"][methods[0]]["output"].shape[0] / 2 / 100 + 0.15
    fig = figure(panel_in * 4 + 1.0, panel_in * len(methods) + 0.7)
    axes = fig.subplots(len(methods), 4, squeeze=False)
    image = None
    for i, method in enumerate(methods):
        zone = maps["zone"][method]
        half = zone["output"].shape[0] // 2  # one quadrant: centre (0 cycles/px) to the edges (0.5)
        axes[i, 0].imshow(np.clip(zone["output"][half:, half:], 0, 1), interpolation="nearest")
        for c, name in enumerate("RGB"):
            image = axes[i, c + 1].imshow(zone["error"][half:, half:, c], cmap="RdBu_r", vmin=-0.5, vmax=0.5,
                                          interpolation="nearest")
            if i == 0:
                axes[i, c + 1].set_title(f"error {name}", fontsize=9)
        axes[i, 0].set_ylabel(method, fontsize=9)
        if i == 0:
            axes[i, 0].set_title("output", fontsize=9)
        for ax in axes[i]:
            ax.set_xticks([]), ax.set_yticks([])
    fig.colorbar(image, ax=axes, shrink=0.6, label="signed error (of white)")
    fig.suptitle("Zone plate: demosaiced output and per-channel error", fontsize=10)
    return fig


def _error_chart(data: dict, methods: list):
    """Mean error and false colour against the square size, and error against the zone plate's
    local frequency, per method, with the lossless tolerance."""
    fig = figure(13, 3.8)
    ax1, ax2, ax3 = fig.subplots(1, 3)
    all_sizes = data["square_sizes_px"]
    for method in methods:
        entry = data["methods"][method]
        ax1.plot(all_sizes, np.maximum(entry["checker_mae"], 1e-5), "o-", label=method)
        ax2.plot(all_sizes, np.maximum(entry["checker_false_colour"], 1e-5), "o-", label=method)
        centres = 0.5 * (np.asarray(entry["zone_frequency_edges"][:-1]) + np.asarray(entry["zone_frequency_edges"][1:]))
        ax3.plot(centres, entry["zone_mae"], "-", label=method)
    for ax in (ax1, ax2):
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.axhline(LOSSLESS_TOLERANCE, color="k", ls="--", lw=0.8)
        ax.set_xlabel("checkerboard square size (px)")
    ax1.set_ylabel("mean |error| (of white), 4 CFA phases")
    ax1.set_title("Error vs feature size")
    ax2.set_ylabel("mean max(RGB) − min(RGB)")
    ax2.set_title("False colour vs feature size")
    ax3.set_yscale("log")
    ax3.axhline(LOSSLESS_TOLERANCE, color="k", ls="--", lw=0.8, label=f"lossless ({LOSSLESS_TOLERANCE:g})")
    ax3.set_xlabel("zone-plate local frequency (cycles/px)")
    ax3.set_ylabel("mean |error| in ring")
    ax3.set_title("Zone plate: error vs frequency")
    ax3.legend(fontsize=8)
    ax1.legend(fontsize=8)
    return fig
