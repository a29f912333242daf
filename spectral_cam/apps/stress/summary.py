"""The stress studies' shared outputs: summary rows, ``summary.csv``/``summary.html`` and
``results.json``.

Every study returns its headline numbers as rows of :data:`SUMMARY_FIELDS`
(:func:`summary_row`); :func:`write_summary` writes them as a CSV (numbers through
:func:`spectral_cam.records.format_number`) and as an HTML page of one table per study (a
table of hundreds of rows is text to search, sort and copy, not an image to squint at),
:func:`write_results` writes everything a run measured as strict JSON.

References
----------
.. [1] docs/design.md, "Errors, outputs, provenance" (atomic files, strict JSON, provenance).
"""

from __future__ import annotations

from pathlib import Path

import html

from ...io import atomic_path
from ...records import format_number, write_csv, write_json

__all__ = ["SUMMARY_FIELDS", "summary_row", "write_summary", "summary_html", "write_results"]

#: Columns of ``summary.csv``.
SUMMARY_FIELDS = ("study", "case", "metric", "value", "unit", "note")


def summary_row(study: str, case: str, metric: str, value, unit: str, note: str = "") -> dict:
    """One row of the summary table (``value`` as a float, or None when not measurable).

    Examples
    --------
    >>> summary_row("optics", "f/8", "CoC", 2, "px")
    {'study': 'optics', 'case': 'f/8', 'metric': 'CoC', 'value': 2.0, 'unit': 'px', 'note': ''}
    """
    return {"study": study, "case": case, "metric": metric,
            "value": None if value is None else float(value), "unit": unit, "note": note}


def write_summary(rows: list[dict], directory: Path) -> list[str]:
    """Write the summary table as ``summary.csv`` and ``summary.html``.

    Parameters
    ----------
    rows
        Dicts with the keys of :data:`SUMMARY_FIELDS` (``value`` a float or None).
    directory
        Output folder.

    Returns
    -------
    list of str
        The file names written.
    """
    directory = Path(directory)
    write_csv(rows, directory / "summary.csv", SUMMARY_FIELDS)
    with atomic_path(directory / "summary.html") as tmp:
        tmp.write_text(summary_html(rows), encoding="utf-8")
    return ["summary.csv", "summary.html"]


_STYLE = ("body{font-family:system-ui,sans-serif;margin:1.5em;max-width:80em}"
          "table{border-collapse:collapse;margin-bottom:1.5em}th,td{padding:2px 8px;text-align:left;"
          "vertical-align:top;border-bottom:1px solid #ddd}td.v{text-align:right;font-variant-numeric:tabular-nums}"
          "th{background:#f3f3f3;position:sticky;top:0}.small{color:#555;font-size:90%}")


def summary_html(rows: list[dict]) -> str:
    """The summary rows as a standalone HTML page: a contents line, then one table per study
    (case, metric, value, unit, note), every text escaped.

    Examples
    --------
    >>> page = summary_html([summary_row("optics", "f/8", "CoC <1 px", 2, "px")])
    >>> "<td>CoC &lt;1 px</td>" in page and '<td class="v">2</td>' in page
    True
    """
    esc = html.escape
    studies = list(dict.fromkeys(row["study"] for row in rows))
    out = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
           f"<title>Stress studies: summary</title><style>{_STYLE}</style></head><body>",
           "<h1>Stress studies: summary</h1>",
           f'<p class="small">{len(rows)} rows; the same numbers as <a href="summary.csv">summary.csv</a>. '
           + " · ".join(f'<a href="#{esc(s)}">{esc(s)}</a>' for s in studies) + "</p>"]
    for study in studies:
        out += [f'<h2 id="{esc(study)}">{esc(study)}</h2>', "<table>",
                "<tr>" + "".join(f"<th>{esc(f)}</th>" for f in SUMMARY_FIELDS[1:]) + "</tr>"]
        for row in (r for r in rows if r["study"] == study):
            out.append(f"<tr><td>{esc(row['case'])}</td><td>{esc(row['metric'])}</td>"
                       f'<td class="v">{esc(format_number(row["value"]))}</td><td>{esc(row["unit"])}</td>'
                       f"<td>{esc(row['note'])}</td></tr>")
        out.append("</table>")
    out.append("</body></html>")
    return "\n".join(out) + "\n"


def write_results(results: dict, directory: Path) -> str:
    """Write a run's ``results.json`` (settings, per-study data and rows, files, timings,
    package versions) as strict JSON, atomically; returns the file name."""
    return write_json(results, Path(directory) / "results.json").name
