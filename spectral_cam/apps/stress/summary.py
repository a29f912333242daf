"""The stress studies' shared outputs: summary rows, ``summary.csv``/``summary.png`` and
``results.json``.

Every study returns its headline numbers as rows of :data:`SUMMARY_FIELDS`
(:func:`summary_row`); :func:`write_summary` writes them as a CSV (numbers through
:func:`spectral_cam.records.format_number`) and as a table image, :func:`write_results`
writes everything a run measured as strict JSON.

References
----------
.. [1] docs/design.md, "Errors, outputs, provenance" (atomic files, strict JSON, provenance).
"""

from __future__ import annotations

from pathlib import Path

from ...records import format_number, write_csv, write_json
from ...viz import figure, save_png

__all__ = ["SUMMARY_FIELDS", "summary_row", "write_summary", "write_results"]

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
    """Write the summary table as ``summary.csv`` and ``summary.png``.

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
    cells = [[row["study"], row["case"][:44], row["metric"][:58], format_number(row["value"]), row["unit"],
              row["note"][:70]] for row in rows]
    fig = figure(17, 0.6 + 0.19 * (len(cells) + 1))
    ax = fig.subplots()
    ax.axis("off")
    table = ax.table(cellText=cells or [[""] * 6], colLabels=list(SUMMARY_FIELDS), loc="upper left",
                     cellLoc="left", colLoc="left", colWidths=[0.06, 0.2, 0.27, 0.07, 0.05, 0.35])
    table.auto_set_font_size(False)
    table.set_fontsize(7)
    table.scale(1.0, 1.0)
    for (r, _), cell in table.get_celld().items():
        cell.set_height(1.0 / (len(cells) + 1))
        if r == 0:
            cell.set_text_props(weight="bold")
    return ["summary.csv", save_png(fig, directory / "summary.png", dpi=80, palette=True).name]


def write_results(results: dict, directory: Path) -> str:
    """Write a run's ``results.json`` (settings, per-study data and rows, files, timings,
    package versions) as strict JSON, atomically; returns the file name."""
    return write_json(results, Path(directory) / "results.json").name
