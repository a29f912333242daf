"""The validation report's figures (matplotlib, drawn off-screen through :func:`spectral_cam.viz.figure`).

- :func:`heatmap_figure`: mean ΔE2000, illuminant × camera, one panel per pipeline;
- :func:`swatches_figure`: one cell's patches, ground truth beside the pipeline's, each labelled
  with its ΔE2000;
- :func:`cct_figure`: mean ΔE2000 against the illuminants' correlated colour temperature;
- :func:`cdf_figure`: the cumulative distribution of ΔE2000 per pipeline.

Swatches are shown sRGB-encoded (IEC 61966-2-1 OETF) and clipped to the display range; the
numbers stay unclipped in the CSVs (:mod:`.report_csv`). :mod:`.report` embeds each figure
as a PNG data: URL.

References
----------
.. [1] IEC 61966-2-1:1999, sRGB.
.. [2] Sharma, G., Wu, W., & Dalal, E. N. (2005). The CIEDE2000 color-difference formula.
   Color Research & Application 30(1), 21–30.
.. [3] Robertson, A. R. (1968). Computation of correlated color temperature and distribution
   temperature. JOSA 58(11), 1528–1535 (the CCT axis).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ...viz import figure

__all__ = ["HEATMAPS_PER_ROW", "heatmap_figure", "swatches_figure", "cct_figure", "cdf_figure"]

#: Pipelines per row of heat maps (seven in one row made 6-px digits).
HEATMAPS_PER_ROW = 3


def heatmap_figure(values: np.ndarray, failed: np.ndarray, *, rows: Sequence[str], columns: Sequence[str],
                   titles: Sequence[str], vmax: float, suptitle: str):
    """Heatmaps of mean ΔE2000, one panel per pipeline.

    Parameters
    ----------
    values : numpy.ndarray
        (P, R, C) mean ΔE2000 (NaN where a pipeline failed to run).
    failed : numpy.ndarray
        (P, R, C) bool, cells that did not pass (outlined and marked).
    rows, columns : sequence of str
        Illuminant and camera labels.
    titles : sequence of str
        Pipeline names.
    vmax : float
        Top of the colour scale (ΔE2000).
    suptitle : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib
    from matplotlib.patches import Rectangle

    count = values.shape[0]
    per_row = min(count, HEATMAPS_PER_ROW)  # rows of panels keep the digits legible with many pipelines
    lines = math.ceil(count / per_row)
    width = max(2.6, 1.15 * len(columns) + 1.6)
    height = max(2.0, 0.55 * len(rows) + 1.4)
    fig = figure(width * per_row + 0.8, height * lines, dpi=90)
    grid = fig.subplots(lines, per_row, squeeze=False)
    for ax in grid.flat[count:]:
        ax.set_axis_off()
    axes = [grid.flat[:count]]
    cmap = matplotlib.colormaps["RdYlGn_r"].with_extremes(bad="#bbbbbb")
    image = None
    for p, ax in enumerate(axes[0]):
        image = ax.imshow(np.ma.masked_invalid(values[p]), cmap=cmap, vmin=0.0, vmax=vmax, aspect="auto")
        for r in range(len(rows)):
            for c in range(len(columns)):
                value = values[p, r, c]
                text = "error" if not np.isfinite(value) else f"{value:.2f}" + ("\nFAIL" if failed[p, r, c] else "")
                ax.text(c, r, text, ha="center", va="center", fontsize=10,
                        color="black" if not np.isfinite(value) or value < 0.75 * vmax else "white")
                if failed[p, r, c]:
                    ax.add_patch(Rectangle((c - 0.5, r - 0.5), 1, 1, fill=False, edgecolor="black", linewidth=2))
        ax.set_xticks(range(len(columns)), labels=columns, rotation=30, ha="right", fontsize=8)
        ax.set_yticks(range(len(rows)), labels=rows, fontsize=8)
        ax.set_title(titles[p], fontsize=9)
    fig.colorbar(image, ax=grid.ravel().tolist(), label="mean ΔE2000", shrink=0.9)
    fig.suptitle(suptitle, fontsize=10)
    return fig


def _display(linear: np.ndarray) -> np.ndarray:
    """Linear sRGB → sRGB-encoded, clipped to [0, 1] for display."""
    from ...isp.tone import srgb_oetf

    return np.clip(srgb_oetf(np.clip(linear, 0.0, None)), 0.0, 1.0)


def swatches_figure(cell, *, title: str):
    """Patch swatches of one cell: ground truth (left half) vs pipeline (right half).

    Parameters
    ----------
    cell : CellResult
        With ``reference``, ``test`` (exposure-matched linear sRGB) and ``delta_e``.
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Each swatch is labelled with its ΔE2000 (the white reference of a set that is not a
        ColorChecker is marked "ref").
    """
    count = len(cell.patch_names)
    columns = 6 if count <= 25 else int(math.ceil(math.sqrt(1.5 * count)))
    rows = int(math.ceil(count / columns))
    size = 21  # pixels of the swatch raster: two 10-px halves and a 1-px hairline
    gap = 10 if count <= 25 else 5  # room for the patch names above the ColorChecker's swatches
    canvas = np.full((rows * (size + gap) + gap, columns * (size + gap) + gap, 3), 0.12)
    reference, test = _display(cell.reference), _display(cell.test)
    for i in range(count):
        r, c = divmod(i, columns)
        top, left = gap + r * (size + gap), gap + c * (size + gap)
        canvas[top:top + size, left:left + size // 2] = reference[i]
        canvas[top:top + size, left + size // 2 + 1:left + size] = test[i]
    scale = 0.5 if count <= 25 else 0.36
    fig = figure(columns * scale * 2.0 * (size + gap) / 26 + 0.4, rows * scale * 2.0 * (size + gap) / 26 + 0.6, dpi=80)
    ax = fig.subplots()
    ax.imshow(canvas, interpolation="nearest")
    font = 8 if count <= 25 else 6
    for i in range(count):
        r, c = divmod(i, columns)
        label = "ref" if i >= cell.n_set else f"{cell.delta_e[i]:.1f}"
        if count <= 25:  # the ColorChecker's names fit above its swatches
            ax.text(gap + c * (size + gap) + size / 2, gap + r * (size + gap) - 0.5, cell.patch_names[i].split(" (")[0][:14],
                    ha="center", va="bottom", fontsize=5.5, color="#dddddd")
        ax.text(gap + c * (size + gap) + size / 2, gap + r * (size + gap) + size + gap / 2, label,
                ha="center", va="center", fontsize=font, color="white")
    ax.set_axis_off()
    ax.set_title(title, fontsize=8)
    return fig


def cct_figure(ccts: Sequence[float], means: dict[str, Sequence[float]]):
    """Mean ΔE2000 against CCT (K, log axis ticked at the illuminants' CCTs in plain kelvin), one
    line per pipeline that scored any cell; returns (figure, names of pipelines left out)."""
    from matplotlib.ticker import NullFormatter

    fig = figure(6.4, 3.6, dpi=90)
    ax = fig.subplots()
    drawn = {name: values for name, values in means.items() if np.isfinite(np.asarray(values, float)).any()}
    for index, (name, values) in enumerate(drawn.items()):
        ax.plot(ccts, values, marker="osD^vP*X"[index % 8], label=name)
    ax.set_xscale("log")
    ax.set_xticks(list(ccts), [f"{c:.0f}" for c in ccts], fontsize=7, rotation=30)
    ax.xaxis.set_minor_formatter(NullFormatter())  # no "3×10³" between the illuminants' own ticks
    ax.set_xlabel("illuminant CCT (K, Robertson 1968)")
    ax.set_ylabel("mean ΔE2000")
    ax.grid(alpha=0.3, which="both")
    if drawn:
        ax.legend(fontsize=7)
    return fig, [name for name in means if name not in drawn]


def cdf_figure(pooled: dict[str, Sequence[float]], *, threshold: float):
    """The cumulative distribution of ΔE2000, one step line per pipeline (its patch count in the
    legend), with the plan's ``max_delta_e`` ``threshold`` marked where it is finite."""
    fig = figure(6.4, 3.6, dpi=90)
    ax = fig.subplots()
    for name, values in pooled.items():
        values = np.sort(values)
        ax.step(values, np.arange(1, len(values) + 1) / len(values), where="post", label=f"{name} ({len(values)})")
    if math.isfinite(threshold):
        ax.axvline(threshold, color="grey", linestyle=":", label=f"max threshold {threshold:g}")
    ax.set_xlabel("ΔE2000")
    ax.set_ylabel("fraction of patches ≤")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return fig
