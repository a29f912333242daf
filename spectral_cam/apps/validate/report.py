"""Validation report: a self-contained HTML page and CSV files of every number.

:func:`write_report` writes, into a report folder,

- ``report.html`` (:func:`render_html`): one page, no scripts, images inline as PNG data: URLs
  (:func:`spectral_cam.viz.png_data_uri`): the verdict, then the answer — the pivot (mean
  ΔE2000, pipeline × illuminant) and the comparisons —, the method, the per-cell table, ΔE2000 heatmaps
  (illuminant × camera, one panel per pipeline, for every reflectance set and exposure), and
  per cell the patch swatches — ground truth and pipeline side by side — with each patch's
  ΔE2000; each section is one function returning its lines;
- ``cells.csv``, ``patches.csv``, ``pivot.csv``, ``comparisons.csv`` and ``metamerism.csv``
  (:mod:`.report_csv`: every number at full precision).

The figures are drawn by :mod:`.report_figures`. Swatches are shown sRGB-encoded (IEC
61966-2-1 OETF) and clipped to the display range; the numbers in the CSVs are unclipped linear
values at full precision (:func:`spectral_cam.records.exact_number`).

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
from typing import Iterator

import numpy as np

from ...io import atomic_path
from ...viz import png_data_uri
# the CSV files and the figures live in their own modules; their public names stay importable from here
from .report_csv import (CELL_COLUMNS, COMPARISON_COLUMNS, PATCH_COLUMNS, reference_data, write_cells_csv,
                         write_patches_csv, write_summary_csvs)
from .report_figures import HEATMAPS_PER_ROW, cct_figure, cdf_figure, heatmap_figure, swatches_figure

__all__ = ["CELL_COLUMNS", "PATCH_COLUMNS", "reference_data", "write_report", "write_cells_csv", "write_patches_csv",
           "heatmap_figure", "swatches_figure", "cct_figure", "render_html"]


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
    return png_data_uri(cdf_figure(pooled, threshold=result.plan.thresholds.max_delta_e), dpi=90)


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


def _header_html(result, generated: str) -> list[str]:
    """The page's head, its title and the verdict: cells passing, failing and in error, the run
    time, and the versions and files behind the numbers."""
    plan, cells, esc = result.plan, result.cells, html.escape
    passed = sum(c.status == "pass" for c in cells)
    failed = sum(c.status == "fail" for c in cells)
    errors = sum(c.status == "error" for c in cells)
    verdict = "pass" if passed == len(cells) else "fail"
    return [
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
    ]


def _method_html(result) -> list[str]:
    """How every number is made: the truth, the chart, its reference data, ΔE2000, in or out of
    sample, where the error lies, white balance and SNR, and the thresholds."""
    plan, esc = result.plan, html.escape
    t = plan.thresholds
    training = _training_text(result.cells)
    return [
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
        + (f" ({esc(training)})" if training else "")
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
    ]


def _pipelines_html(plan) -> list[str]:
    """Each pipeline as it describes itself, and those the plan left out (with why)."""
    esc = html.escape
    return ["<h2>Pipelines</h2><ul>",
            *(f"<li><b>{esc(p.name)}</b>: {esc(p.describe())}</li>" for p in plan.pipelines),
            *(f"<li>not run: {esc(note)}</li>" for note in plan.skipped_pipelines),
            "</ul>"]


def _cell_row_html(c) -> str:
    """One row of the per-cell table."""
    esc, s = html.escape, c.stats
    return (f'<tr class="{_status_class(c.status)}"><td>{esc(c.set_name)}</td><td>{esc(_short(c.illuminant))}</td>'
            f"<td>{esc(c.camera)}</td><td>{esc(c.exposure)}</td><td>{esc(c.pipeline)}</td>"
            f"<td>{esc(c.status.upper())}</td><td>{esc(c.calibration.split(' (')[0])}</td>"
            f'<td class="num">{_cell_text(s.get("delta_e_mean"))}{_interval(c)}</td>'
            f'<td class="num">{_cell_text(s.get("delta_e_p95"))}</td>'
            f'<td class="num">{_cell_text(s.get("delta_e_max"))}</td>'
            f'<td class="num">{_cell_text(s.get("wb_angular_error_deg"))}</td>'
            f'<td class="num">{_cell_text(s.get("snr_median"), 1)}</td><td class="num">{c.exposure_s:.4g}</td>'
            f'<td class="num">{c.iso:g}</td><td class="num">{c.runtime_s:.2f}</td>'
            f"<td>{esc('; '.join(c.failures + [f'warning: {w}' for w in c.warnings]))}</td></tr>")


def _cells_table_html(cells) -> list[str]:
    """Every cell, errors first, then failures, then passes (the sort is stable: plan order within)."""
    order = {"error": 0, "fail": 1, "pass": 2}
    return ["<h2>Summary: every cell</h2>",
            "<table><tr><th>set</th><th>illuminant</th><th>camera</th><th>exposure</th><th>pipeline</th>"
            "<th>status</th><th>sample</th><th>ΔE mean</th><th>ΔE p95</th><th>ΔE max</th><th>WB error (°)</th>"
            "<th>SNR median</th><th>exposure (s)</th><th>ISO</th><th>time (s)</th><th>why</th></tr>",
            *(_cell_row_html(c) for c in sorted(cells, key=lambda c: (order.get(c.status, 0),))),
            "</table>"]


def _errors_html(cells) -> list[str]:
    """Where each pipeline that failed failed: its message, its traceback folded (none without errors)."""
    failed_with_trace = [c for c in cells if c.traceback]
    if not failed_with_trace:
        return []
    esc = html.escape
    out = ["<h2>Errors</h2>"]
    for c in failed_with_trace:
        where = f"{c.set_name} · {_short(c.illuminant)} · {c.camera} · {c.exposure} · {c.pipeline}"
        out.append(f"<details><summary>{esc(where)}: {esc(c.failures[0])}</summary>"
                   f"<pre>{esc(c.traceback)}</pre></details>")
    return out


def _distribution_html(result) -> list[str]:
    """The ΔE2000 CDF per pipeline (none when no cell was scored)."""
    cdf = _cdf_uri(result)
    if not cdf:
        return []
    return ["<h2>ΔE2000 distribution</h2>",
            f'<figure><img alt="cumulative distribution of ΔE2000 per pipeline" src="{cdf}">'
            '<figcaption class="small">Every scored patch of every cell (first seed), per pipeline.'
            "</figcaption></figure>"]


def _heatmaps_html(result) -> list[str]:
    """Mean ΔE2000 heatmaps, illuminant × camera, per reflectance set × exposure."""
    esc = html.escape
    return ["<h2>ΔE2000 across illuminant × camera</h2>",
            *(f'<figure><img alt="heatmap of mean ΔE2000, {esc(caption)}" src="{uri}">'
              f'<figcaption class="small">{esc(caption)}; outlined cells do not pass.</figcaption></figure>'
              for caption, uri in _heatmaps(result))]


def _swatches_html(result) -> list[str]:
    """Each scored cell's patch swatches (``swatches = "all"``, or only the cells not passing with
    ``"failing"``; none with ``"none"``), folded open where the cell does not pass."""
    plan, esc = result.plan, html.escape
    if plan.swatches == "none":
        return []
    out = ["<h2>Patches: ground truth (left) vs pipeline (right)</h2>",
           '<p class="small">Display sRGB, clipped; each swatch labelled with its ΔE2000.</p>']
    for c in result.cells:
        if c.test is None or (plan.swatches == "failing" and c.status == "pass"):
            continue
        title = (f"{c.set_name} · {_short(c.illuminant)} · {c.camera} · {c.exposure} · {c.pipeline}: "
                 f"mean ΔE {c.stats['delta_e_mean']:.2f}")
        uri = png_data_uri(swatches_figure(c, title=title), dpi=80)
        opened = " open" if c.status != "pass" else ""
        out.append(f'<details{opened}><summary class="{_status_class(c.status)}">{esc(title)} — '
                   f"{esc(c.status.upper())}</summary>"
                   f'<img alt="patch swatches, {esc(title)}" src="{uri}"></details>')
    return out


def render_html(result, *, generated: str | None = None) -> str:
    """The report page as an HTML string (no scripts; images as data: URLs).

    The answer comes first (verdict, pivot, comparisons), then the method and the long per-cell
    table, then the metamerism tables and the figures.

    Parameters
    ----------
    result : ValidationResult
    generated : str, optional
        Timestamp text (default now, UTC).

    Returns
    -------
    str
    """
    generated = generated or datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    parts = [*_header_html(result, generated), *_pivot_html(result), *_comparisons_html(result),
             *_method_html(result), *_pipelines_html(result.plan), *_cells_table_html(result.cells),
             *_errors_html(result.cells), *_metamerism_html(result), *_change_of_light_html(result),
             *_cct_html(result), *_distribution_html(result), *_heatmaps_html(result), *_swatches_html(result),
             "</body></html>"]
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
    folder = Path(folder)
    paths = {"cells_csv": write_cells_csv(result, folder / "cells.csv"),
             "patches_csv": write_patches_csv(result, folder / "patches.csv"),
             **write_summary_csvs(result, folder)}
    page = render_html(result)
    with atomic_path(folder / "report.html") as tmp:
        tmp.write_text(page, encoding="utf-8")
    paths["html"] = folder / "report.html"
    return paths
