"""Validation report: a self-contained HTML page and CSV files of every number.

:func:`write_report` writes, into a report folder,

- ``report.html``: one page, no scripts, images inline as PNG data: URLs
  (:func:`spectral_cam.viz.png_data_uri`): the verdict, then the answer — the pivot (mean
  ΔE2000, pipeline × illuminant) and the comparisons —, the method, the per-cell table, ΔE2000 heatmaps
  (illuminant × camera, one panel per pipeline, for every reflectance set and exposure), and
  per cell the patch swatches — ground truth and pipeline side by side — with each patch's
  ΔE2000;
- ``cells.csv``: one row per cell (set, illuminant, camera, exposure, pipeline) with the
  status, ΔE2000 mean / 95th percentile / max, white-balance angular error, SNR summary,
  exposure, gain and run time;
- ``patches.csv``: one row per cell and patch with the ground-truth and pipeline linear
  sRGB, their CIELAB (D65), ΔE2000 and SNR.

Swatches are shown sRGB-encoded (IEC 61966-2-1 OETF) and clipped to the display range;
the numbers in the CSVs are unclipped linear values at full precision
(:func:`spectral_cam.records.exact_number`).

References
----------
.. [1] IEC 61966-2-1:1999, sRGB.
.. [2] Sharma, G., Wu, W., & Dalal, E. N. (2005). The CIEDE2000 color-difference formula.
   Color Research & Application 30(1), 21–30.
.. [3] WHATWG HTML Living Standard (data: URLs for inline images, RFC 2397).
.. [4] docs/design.md, "Errors, outputs, provenance" (atomic files, one CSV writer).
"""

from __future__ import annotations

import html
import math
from datetime import datetime, timezone
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np

from ...io import atomic_path
from ...records import exact_number, write_csv
from ...viz import figure, png_data_uri

__all__ = ["CELL_COLUMNS", "PATCH_COLUMNS", "reference_data", "write_report", "write_cells_csv", "write_patches_csv",
           "heatmap_figure", "swatches_figure", "cct_figure", "render_html"]

CELL_COLUMNS = ("set", "illuminant", "camera", "exposure", "pipeline", "status", "failures", "warnings", "calibration",
                "reference_data", "n_patches", "seeds", "delta_e_mean_ci95",
                "delta_e_mean", "delta_e_p95", "delta_e_max", "wb_angular_error_deg", "snr_median", "snr_min",
                "exposure_scale", "delta_l_mean", "delta_c_mean", "delta_h_mean", "patches_clipped", "tone_slope",
                "exposure_s", "iso", "K_dn_per_e", "runtime_s", "dng")
PATCH_COLUMNS = ("set", "illuminant", "camera", "exposure", "pipeline", "patch_index", "patch", "role",
                 "reference_r", "reference_g", "reference_b", "test_r", "test_g", "test_b",
                 "reference_L", "reference_a", "reference_b_star", "test_L", "test_a", "test_b_star",
                 "delta_e2000", "delta_l", "delta_c", "delta_h", "clipped", "snr", "snr_db")
#: patches.csv's per-patch numbers, by name (a slice by position once dropped two of them)
_PATCH_NUMBERS = ("reference_r", "reference_g", "reference_b", "test_r", "test_g", "test_b",
                  "reference_L", "reference_a", "reference_b_star", "test_L", "test_a", "test_b_star",
                  "delta_e2000", "delta_l", "delta_c", "delta_h")
#: Pipelines per row of heat maps (seven in one row made 6-px digits).
HEATMAPS_PER_ROW = 3
#: Columns of comparisons.csv (:func:`spectral_cam.apps.validate.statistics.compare_pipelines`).
COMPARISON_COLUMNS = ("set", "illuminant", "camera", "exposure", "a", "b", "difference", "ci95", "seeds",
                      "significant")
#: Cell statistics written as they are, in CELL_COLUMNS order.
_STAT_COLUMNS = ("delta_e_mean", "delta_e_p95", "delta_e_max", "wb_angular_error_deg", "snr_median", "snr_min",
                 "exposure_scale", "delta_l_mean", "delta_c_mean", "delta_h_mean", "patches_clipped", "tone_slope")


def _role(cell, index: int) -> str:
    if index < cell.n_set:
        return "patch" if index != cell.white_index else "patch, white reference"
    return "white reference"


def _coordinates(cell) -> dict:
    return {"set": cell.set_name, "illuminant": cell.illuminant, "camera": cell.camera, "exposure": cell.exposure,
            "pipeline": cell.pipeline}


def reference_data(refset) -> str:
    """What a set's truth is computed from: its spectra's source (the scores depend on it: the
    ColorChecker's BabelColor average and ISO 17321-1's measurement of the same chart give other
    truths) and, for a set other than the ColorChecker, the white reference appended to it."""
    from ...colour_ground_truth import WHITE_PATCH
    from ...spectra import COLORCHECKER_SET

    colorchecker = f"colour-science SDS_COLOURCHECKERS[{COLORCHECKER_SET!r}]"
    if refset.name == "colorchecker":
        return f"{refset.description}; {colorchecker}"
    return f"{refset.description}; white reference: ColorChecker {WHITE_PATCH} of {colorchecker}"


def _cell_rows(result) -> Iterator[dict]:
    sources = {refset.name: reference_data(refset) for refset in result.plan.reflectance_sets}
    for c in result.cells:
        # whole numbers and the rounded run time as text: exact_number writes every number as a float
        yield {**_coordinates(c), "status": c.status, "failures": "; ".join(c.failures),
               "warnings": "; ".join(c.warnings), "calibration": c.calibration,
               "reference_data": sources.get(c.set_name, ""),
               "n_patches": str(c.n_set), "seeds": str(len(c.seed_means)), "delta_e_mean_ci95": c.delta_e_mean_ci95,
               **{k: c.stats.get(k) for k in _STAT_COLUMNS}, "exposure_s": c.exposure_s, "iso": c.iso,
               "K_dn_per_e": c.gain_dn_per_e, "runtime_s": f"{c.runtime_s:.4f}", "dng": c.dng}


def write_cells_csv(result, path: str | Path) -> Path:
    """One row per cell (see :data:`CELL_COLUMNS`), every number at full precision, written atomically."""
    return write_csv(_cell_rows(result), path, CELL_COLUMNS, number=exact_number)


def _snr_db(snr: float) -> float:
    if snr > 0 and math.isfinite(snr):
        return 20 * math.log10(snr)
    return math.inf if snr > 0 else math.nan


def _patch_rows(result) -> Iterator[dict]:
    from ...metrics.image_quality import linear_srgb_to_lab

    for c in result.cells:
        if c.test is None:
            continue
        ref_lab = linear_srgb_to_lab(c.reference)
        test_lab = linear_srgb_to_lab(c.test)
        for i, name in enumerate(c.patch_names):
            snr = float(c.snr[i])
            values = (*c.reference[i], *c.test[i], *ref_lab[i], *test_lab[i], c.delta_e[i], *c.delta_lch[i])
            yield {**_coordinates(c), "patch_index": str(i), "patch": name, "role": _role(c, i),
                   **dict(zip(_PATCH_NUMBERS, (float(v) for v in values), strict=True)),
                   "clipped": "true" if c.clipped[i] else "false", "snr": snr, "snr_db": _snr_db(snr)}


def write_patches_csv(result, path: str | Path) -> Path:
    """One row per cell and patch (see :data:`PATCH_COLUMNS`), written atomically."""
    return write_csv(_patch_rows(result), path, PATCH_COLUMNS, number=exact_number)


# ----------------------------------------------------------------------------- figures
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


# ----------------------------------------------------------------------------- HTML
_CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:1.5em auto;max-width:1200px;color:#222;padding:0 1em}
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ddd}h3{font-size:1em}
table{border-collapse:collapse;font-size:.85em;margin:.5em 0}td,th{border:1px solid #ccc;padding:.25em .5em;text-align:left}
th{background:#f3f3f3}td.num{text-align:right;font-variant-numeric:tabular-nums}
.pass{background:#d9f2d9}.fail{background:#f9d4d4}.error{background:#f2e1a5}
.badge{display:inline-block;padding:.2em .6em;border-radius:.3em;font-weight:bold}
img{max-width:100%;height:auto}details{margin:.4em 0}summary{cursor:pointer}
.small{font-size:.85em;color:#555}code,pre{background:#f6f6f6}pre{padding:.6em;overflow-x:auto;font-size:.8em}
"""


def _status_class(status: str) -> str:
    return {"pass": "pass", "fail": "fail"}.get(status, "error")


def _cell_text(value, digits: int = 2) -> str:
    """A table cell's number: fixed ``digits`` decimals, "–" for NaN, "∞" for infinity."""
    if value is None:
        return ""
    value = float(value)
    if math.isnan(value):
        return "–"
    if math.isinf(value):
        return "∞"
    return f"{value:.{digits}f}"


def _heatmaps(result) -> Iterator[tuple[str, str]]:
    """(caption, PNG data: URI) per reflectance set × exposure."""
    plan = result.plan
    thresholds = plan.thresholds
    names = [p.name for p in plan.pipelines]
    by_key = {c.key: c for c in result.cells}
    finite = [c.stats["delta_e_mean"] for c in result.cells if c.stats]
    top = max([2 * thresholds.mean_delta_e if math.isfinite(thresholds.mean_delta_e) else 0.0, *finite, 1.0])
    top = min(top, max(2 * thresholds.mean_delta_e, 10.0)) if math.isfinite(thresholds.mean_delta_e) else top
    for refset in plan.reflectance_sets:
        for exposure in plan.exposures:
            values = np.full((len(names), len(plan.illuminants), len(plan.cameras)), np.nan)
            failed = np.zeros(values.shape, dtype=bool)
            for p, pipeline in enumerate(names):
                for r, illuminant in enumerate(plan.illuminants):
                    for c, camera in enumerate(plan.cameras):
                        cell = by_key.get((refset.name, illuminant, camera, exposure.name, pipeline))
                        if cell is None:
                            continue
                        if cell.stats:
                            values[p, r, c] = cell.stats["delta_e_mean"]
                        failed[p, r, c] = cell.status != "pass"
            caption = f"{refset.name} ({len(refset)} patches), exposure {exposure.name}"
            fig = heatmap_figure(values, failed, rows=[_short(i) for i in plan.illuminants],
                                 columns=list(plan.cameras), titles=names, vmax=top,
                                 suptitle=f"mean ΔE2000 — {caption}")
            yield caption, png_data_uri(fig, dpi=90)


def _short(text: str) -> str:
    return Path(text).name if "/" in text else text


def _number_cell(value) -> str:
    return f'<td class="num">{_cell_text(value)}</td>'


def _table_html(corner: str, columns, rows, cell=_number_cell) -> list[str]:
    """An HTML table: ``corner`` over the row names, the (escaped) ``columns``, and each row's
    ``(name, values)`` with every value rendered by ``cell`` as a whole ``<td>``."""
    esc = html.escape
    out = [f"<table><tr><th>{esc(corner)}</th>" + "".join(f"<th>{column}</th>" for column in columns) + "</tr>"]
    out += [f"<tr><td>{esc(name)}</td>" + "".join(cell(v) for v in values) + "</tr>" for name, values in rows]
    return out + ["</table>"]


def _pivot_html(result) -> list[str]:
    """Mean ΔE2000, pipeline × illuminant (over sets, cameras and exposures)."""
    from .statistics import pivot

    names, illuminants, table = pivot(result)
    return ["<h2>Pivot: mean ΔE2000 by pipeline × illuminant</h2>",
            '<p class="small">Averaged over the reflectance sets, cameras and exposures; '
            '<a href="pivot.csv">pivot.csv</a>.</p>',
            *_table_html("pipeline", [html.escape(_short(i)) for i in illuminants], zip(names, table))]


def _significance_mark(row: dict) -> str:
    """The report's mark of a comparison: none (significant, shown bold), "n.s.", or "no interval (1 seed)"."""
    from .statistics import significance_text

    text = significance_text(row)
    return {"true": "", "false": "n.s."}.get(text, text)


def _comparisons_html(result) -> list[str]:
    """The plan's pipeline comparisons, significant differences marked."""
    from .statistics import compare_pipelines

    rows = compare_pipelines(result)
    if not rows:
        return []
    esc = html.escape
    seeds = result.plan.seeds
    out = ["<h2>Comparisons</h2>",
           f'<p class="small">Difference in mean ΔE2000 (a − b) per cell, paired over {seeds} noise seed(s) with a 95 % '
           "Student's t interval; <b>bold</b>: the interval excludes 0 (significant); n.s.: it does not"
           + ("; with one seed there is no interval, so no difference is called significant or not (set "
              "validate.seeds ≥ 2)" if seeds < 2 else "") + '; <a href="comparisons.csv">comparisons.csv</a>.</p>',
           "<table><tr><th>a − b</th><th>set</th><th>illuminant</th><th>camera</th><th>exposure</th>"
           "<th>difference</th><th></th></tr>"]
    for row in rows:
        interval = f" ± {row['ci95']:.2f}" if row["ci95"] is not None else ""
        value = f"{row['difference']:+.2f}{interval}"
        shown = f"<b>{value}</b>" if row["significant"] else value
        out.append(f"<tr><td>{esc(row['a'])} − {esc(row['b'])}</td><td>{esc(row['set'])}</td>"
                   f"<td>{esc(_short(row['illuminant']))}</td><td>{esc(row['camera'])}</td><td>{esc(row['exposure'])}</td>"
                   f'<td class="num">{shown}</td><td>{esc(_significance_mark(row))}</td></tr>')
    return out + ["</table>"]


def _cdf_uri(result) -> str:
    """The cumulative distribution of ΔE2000 per pipeline (PNG data: URI; empty when nothing ran)."""
    pooled = {}
    for cell in result.cells:
        if cell.delta_e is not None:
            pooled.setdefault(cell.pipeline, []).extend(cell.delta_e[:cell.n_set].tolist())
    if not pooled:
        return ""
    fig = figure(6.4, 3.6, dpi=90)
    ax = fig.subplots()
    for name, values in pooled.items():
        values = np.sort(values)
        ax.step(values, np.arange(1, len(values) + 1) / len(values), where="post", label=f"{name} ({len(values)})")
    threshold = result.plan.thresholds.max_delta_e
    if math.isfinite(threshold):
        ax.axvline(threshold, color="grey", linestyle=":", label=f"max threshold {threshold:g}")
    ax.set_xlabel("ΔE2000")
    ax.set_ylabel("fraction of patches ≤")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return png_data_uri(fig, dpi=90)


def _metamerism_html(result) -> list[str]:
    """ISO 17321-1's sensitivity metamerism index per camera × illuminant (from the spectra)."""
    from ...errors import ConfigError
    from .statistics import sensitivity_metamerism_index

    plan, esc = result.plan, html.escape
    rows = ["<h2>Sensitivity metamerism index (ISO 17321-1)</h2>",
            '<p class="small">100 − 5.5 × mean ΔE*ab of the 18 chromatic ColorChecker patches after each camera\'s '
            "best 3 × 3 for them under each illuminant: how far the camera's curves are from the CIE observer's, a "
            "bound no pipeline's matrix beats; its drop between illuminants is the camera's metamerism.</p>"]

    def index(camera, illuminant):
        try:
            return sensitivity_metamerism_index(camera, illuminant)
        except ConfigError:  # an "ideal" camera has no three distinct channels
            return None

    table = ((camera, [index(camera, i) for i in plan.illuminants]) for camera in plan.cameras)
    return rows + _table_html("camera", [esc(_short(i)) for i in plan.illuminants], table,
                              lambda v: "<td>—</td>" if v is None else f'<td class="num">{v:.1f}</td>')


def _change_of_light_html(result) -> list[str]:
    """Each pipeline's CIE metamerism index for a change in illuminant (pair: its patch and the truth)."""
    from .statistics import pipeline_metamerism

    rows = pipeline_metamerism(result)
    if not rows:
        return []
    esc = html.escape
    tests = list(dict.fromkeys(row["test"] for row in rows))
    pipelines = list(dict.fromkeys(row["pipeline"] for row in rows))
    out = ["<h2>Metamerism index for a change in illuminant (CIE 15:2004 §8.2)</h2>",
           '<p class="small">Each patch as the pipeline reproduced it and its truth, a pair nearly matched under '
           f"{esc(_short(rows[0]['reference']))}: ΔE*ab of the pair under each other illuminant less its mismatch "
           "under the reference (the additive correction), mean over the patches, sets, cameras and exposures. "
           "What goes wrong only when the light changes (the camera's metamerism and a matrix made for another "
           'light); <a href="metamerism.csv">metamerism.csv</a>.</p>']
    means = ((name, [np.mean([r["index_mean"] for r in rows if r["pipeline"] == name and r["test"] == t] or [np.nan])
                     for t in tests]) for name in pipelines)
    return out + _table_html("pipeline", [f"→ {esc(_short(t))}" for t in tests], means)


def _cct_html(result) -> list[str]:
    """Mean ΔE2000 against the illuminants' CCT per pipeline, with three or more illuminants."""
    from .statistics import cct_sweep

    sweep = cct_sweep(result)
    if sweep is None:
        return []
    fig, missing = cct_figure(*sweep)
    left_out = (f" Not drawn (no cell scored): {html.escape(', '.join(missing))}." if missing else "")
    return ["<h2>ΔE2000 across colour temperature</h2>",
            f'<figure><img alt="mean ΔE2000 against illuminant CCT" src="{png_data_uri(fig, dpi=90)}">'
            '<figcaption class="small">Each illuminant at its correlated colour temperature; means over sets, '
            f"cameras and exposures.{left_out}</figcaption></figure>"]


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


def _interval(cell) -> str:
    """" ± half-width" of the mean ΔE's 95 % interval over the seeds (empty with one seed)."""
    return f" ± {cell.delta_e_mean_ci95:.2f}" if cell.delta_e_mean_ci95 is not None else ""


def _training_text(cells) -> str:
    """"fitted on <set>, N reflectances" as the cells record it (empty without matrices)."""
    for cell in cells:
        if cell.calibration.startswith("out of sample ("):
            return cell.calibration[len("out of sample ("):-1]
        if cell.calibration.startswith("in sample ("):
            return f"fitted on {cell.calibration[len('in sample ('):-1]}"
    return ""


def render_html(result, *, generated: str | None = None) -> str:
    """The report page as an HTML string (no scripts; images as data: URLs).

    Parameters
    ----------
    result : ValidationResult
    generated : str, optional
        Timestamp text (default now, UTC).

    Returns
    -------
    str
    """
    plan = result.plan
    t = plan.thresholds
    esc = html.escape
    cells = result.cells
    passed = sum(c.status == "pass" for c in cells)
    failed = sum(c.status == "fail" for c in cells)
    errors = sum(c.status == "error" for c in cells)
    verdict = "pass" if passed == len(cells) else "fail"
    generated = generated or datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        '<link rel="icon" href="data:,">',
        f"<title>spectral_cam colour validation — {esc(Path(plan.source).name)}</title>",
        f"<style>{_CSS}</style></head><body>",
        f"<h1>Colour-pipeline validation: {esc(Path(plan.source).name)}</h1>",
        f'<p><span class="badge {verdict}">{passed}/{len(cells)} cells pass</span> '
        f"({failed} fail, {errors} error); the cells ran in {result.elapsed_s:.1f} s; generated {esc(generated)}.</p>",
        '<p class="small">Versions: ' + ", ".join(f"{esc(k)} {esc(str(v))}" for k, v in result.versions.items())
        + ". Numbers: <a href=\"cells.csv\">cells.csv</a>, <a href=\"patches.csv\">patches.csv</a>; "
        "RAW files in <code>raw/</code>; the resolved plan in <a href=\"plan.json\">plan.json</a>.</p>",
        # the answer first: the pivot and the comparisons; the method and the long per-cell table below
        *_pivot_html(result), *_comparisons_html(result),
        "<h2>Method</h2><ul>",
        "<li><b>Ground truth</b>: CIE 1931 2° XYZ of each reflectance under the scene illuminant "
        "(colour-science integration, 1-nm CMFs, perfect diffuser Y = 1) → <b>Bradford</b> chromatic adaptation "
        "(von Kries) from the illuminant's white to D65 → linear sRGB, unclipped.</li>",
        f"<li><b>Chart</b>: {esc(plan.chart)}"
        + (f" — patches of {plan.patch_px} px, band radiance ρ·E/π on {esc(plan.bands)} nm band centres, "
           f"{plan.illuminance_lux:g} lx" if plan.chart == "synthetic" else " — Mitsuba render of the ColorChecker preset")
        + ". Sets other than the ColorChecker carry its white 9.5 patch as white reference.</li>",
        "<li><b>Reference data</b> (the truth's spectra; another measurement of the same chart gives another "
        "truth and other scores, so compare scores only on the same data; <code>cells.csv</code> column "
        "<code>reference_data</code>): "
        + "; ".join(f"<i>{esc(r.name)}</i>: {esc(reference_data(r))}" for r in plan.reflectance_sets) + ".</li>",
        "<li><b>ΔE2000</b> per patch on patch means (interior, 20 % margin), after scaling the pipeline's image "
        "so the white reference has the ground truth's luminance; mean, 95th percentile, max over the set.</li>",
        "<li><b>In or out of sample</b>: the RAW's colour matrices (DNG ColorMatrix1/2, ForwardMatrix1/2 and the "
        "fitted corrections <code>ours</code> reads) are fitted on a training set of reflectances"
        + (f" ({esc(_training_text(cells))})" if _training_text(cells) else "")
        + "; a cell scoring that set is <i>in sample</i> (optimistic), any other set <i>out of sample</i>. "
        "Each row says which.</li>",
        "<li><b>Where the error lies</b>: mean |ΔL*|, |ΔC*ab|, |ΔH*ab| per cell (lightness, chroma, hue; "
        "<code>cells.csv</code>, per patch in <code>patches.csv</code>); the <b>tone response</b> on the neutral "
        "patches (log-log slope of luminance against the truth's: 1 for a linear develop; a tone curve is named in "
        "the cell's warnings); patches outside sRGB that a pipeline <b>clipped</b> to the gamut's edge are flagged.</li>",
        "<li><b>White balance</b>: angle between the pipeline's and the ground truth's white reference in linear "
        "sRGB (degrees). <b>SNR</b>: mean / σ of luminance over each patch interior.</li>",
        f"<li><b>Pass</b> when mean ΔE ≤ {t.mean_delta_e:g}, p95 ≤ {t.p95_delta_e:g}, max ≤ {t.max_delta_e:g} "
        f"and WB error ≤ {t.wb_angular_error_deg:g}°.</li></ul>",
        "<h2>Pipelines</h2><ul>",
        *(f"<li><b>{esc(p.name)}</b>: {esc(p.describe())}</li>" for p in plan.pipelines),
        *(f"<li>not run: {esc(note)}</li>" for note in plan.skipped_pipelines),
        "</ul>",
        "<h2>Summary: every cell</h2>",
        "<table><tr><th>set</th><th>illuminant</th><th>camera</th><th>exposure</th><th>pipeline</th>"
        "<th>status</th><th>sample</th><th>ΔE mean</th><th>ΔE p95</th><th>ΔE max</th><th>WB error (°)</th>"
        "<th>SNR median</th><th>exposure (s)</th><th>ISO</th><th>time (s)</th><th>why</th></tr>",
    ]
    order = {"error": 0, "fail": 1, "pass": 2}
    for c in sorted(cells, key=lambda c: (order.get(c.status, 0),)):
        s = c.stats
        parts.append(
            f'<tr class="{_status_class(c.status)}"><td>{esc(c.set_name)}</td><td>{esc(_short(c.illuminant))}</td>'
            f"<td>{esc(c.camera)}</td><td>{esc(c.exposure)}</td><td>{esc(c.pipeline)}</td>"
            f"<td>{esc(c.status.upper())}</td><td>{esc(c.calibration.split(' (')[0])}</td>"
            f'<td class="num">{_cell_text(s.get("delta_e_mean"))}{_interval(c)}</td>'
            f'<td class="num">{_cell_text(s.get("delta_e_p95"))}</td>'
            f'<td class="num">{_cell_text(s.get("delta_e_max"))}</td>'
            f'<td class="num">{_cell_text(s.get("wb_angular_error_deg"))}</td>'
            f'<td class="num">{_cell_text(s.get("snr_median"), 1)}</td><td class="num">{c.exposure_s:.4g}</td>'
            f'<td class="num">{c.iso:g}</td><td class="num">{c.runtime_s:.2f}</td>'
            f"<td>{esc('; '.join(c.failures + [f'warning: {w}' for w in c.warnings]))}</td></tr>")
    parts.append("</table>")
    failed_with_trace = [c for c in cells if c.traceback]
    if failed_with_trace:
        parts.append("<h2>Errors</h2>")
        for c in failed_with_trace:
            where = f"{c.set_name} · {_short(c.illuminant)} · {c.camera} · {c.exposure} · {c.pipeline}"
            parts.append(f"<details><summary>{esc(where)}: {esc(c.failures[0])}</summary>"
                         f"<pre>{esc(c.traceback)}</pre></details>")
    parts += _metamerism_html(result) + _change_of_light_html(result)
    parts += _cct_html(result)
    cdf = _cdf_uri(result)
    if cdf:
        parts.append("<h2>ΔE2000 distribution</h2>")
        parts.append(f'<figure><img alt="cumulative distribution of ΔE2000 per pipeline" src="{cdf}">'
                     '<figcaption class="small">Every scored patch of every cell (first seed), per pipeline.'
                     "</figcaption></figure>")
    parts.append("<h2>ΔE2000 across illuminant × camera</h2>")
    for caption, uri in _heatmaps(result):
        parts.append(f'<figure><img alt="heatmap of mean ΔE2000, {esc(caption)}" src="{uri}">'
                     f'<figcaption class="small">{esc(caption)}; outlined cells do not pass.</figcaption></figure>')
    if plan.swatches != "none":
        parts.append("<h2>Patches: ground truth (left) vs pipeline (right)</h2>")
        parts.append('<p class="small">Display sRGB, clipped; each swatch labelled with its ΔE2000.</p>')
        for c in cells:
            if c.test is None or (plan.swatches == "failing" and c.status == "pass"):
                continue
            title = (f"{c.set_name} · {_short(c.illuminant)} · {c.camera} · {c.exposure} · {c.pipeline}: "
                     f"mean ΔE {c.stats['delta_e_mean']:.2f}")
            uri = png_data_uri(swatches_figure(c, title=title), dpi=80)
            opened = " open" if c.status != "pass" else ""
            parts.append(f'<details{opened}><summary class="{_status_class(c.status)}">{esc(title)} — '
                         f"{esc(c.status.upper())}</summary>"
                         f'<img alt="patch swatches, {esc(title)}" src="{uri}"></details>')
    parts.append("</body></html>")
    return "\n".join(parts)


def write_report(result, folder: str | Path) -> dict[str, Path]:
    """Write ``report.html``, ``cells.csv`` and ``patches.csv`` into a folder (atomically).

    Parameters
    ----------
    result : ValidationResult
    folder : str or path-like

    Returns
    -------
    dict
        ``{"html", "cells_csv", "patches_csv", "pivot_csv", "comparisons_csv", "metamerism_csv"}`` → path.
    """
    from .statistics import METAMERISM_COLUMNS, compare_pipelines, pipeline_metamerism, pivot, significance_text

    folder = Path(folder)
    paths = {"cells_csv": write_cells_csv(result, folder / "cells.csv"),
             "patches_csv": write_patches_csv(result, folder / "patches.csv")}
    names, illuminants, table = pivot(result)
    paths["pivot_csv"] = write_csv(({"pipeline": name, **{i: v for i, v in zip(illuminants, values)}}
                                    for name, values in zip(names, table)), folder / "pivot.csv",
                                   ("pipeline", *illuminants), number=exact_number)
    paths["comparisons_csv"] = write_csv(({**row, "significant": significance_text(row)}
                                          for row in compare_pipelines(result)), folder / "comparisons.csv",
                                         COMPARISON_COLUMNS, number=exact_number)
    paths["metamerism_csv"] = write_csv(pipeline_metamerism(result), folder / "metamerism.csv", METAMERISM_COLUMNS,
                                        number=exact_number)
    page = render_html(result)
    with atomic_path(folder / "report.html") as tmp:
        tmp.write_text(page, encoding="utf-8")
    paths["html"] = folder / "report.html"
    return paths
