"""The example validation plan's pivot and comparison, for the README: runs plans/validate_example.toml,
keeps its pivot.csv and comparisons.csv as docs/validate/example_pivot.csv and
example_comparisons.csv, and rewrites the README block between ``<!-- validate-example:begin -->``
and ``<!-- validate-example:end -->`` from them.

    .venv/bin/python docs/make_validation_tables.py
"""

from __future__ import annotations

import csv
import shutil
import tempfile
from pathlib import Path

from spectral_cam.apps.validate import load_plan, run_plan

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "validate"
BEGIN, END = "<!-- validate-example:begin -->", "<!-- validate-example:end -->"


def _rows(path: Path) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def block(pivot: list[dict], comparisons: list[dict], seeds: int) -> str:
    illuminants = [k for k in pivot[0] if k != "pipeline"]
    lines = [BEGIN, "Mean ΔE2000 by pipeline × illuminant (both cameras, both reflectance sets, both exposures; "
             f"{seeds} noise seeds per cell; `python docs/make_validation_tables.py` writes "
             "[example_pivot.csv](docs/validate/example_pivot.csv) and this block):", "",
             "| pipeline | " + " | ".join(illuminants) + " |", "|---|" + "---|" * len(illuminants)]
    for row in pivot:
        lines.append(f"| {row['pipeline']} | " + " | ".join(f"{float(row[i]):.2f}" for i in illuminants) + " |")
    significant = [r for r in comparisons if r["significant"] == "true"]
    lines += ["", f"ours − libraw-ahd, paired over the seeds (95 % interval; {len(significant)} of {len(comparisons)} "
              "cells differ significantly, [example_comparisons.csv](docs/validate/example_comparisons.csv)):", "",
              "| set | illuminant | camera | exposure | ours − LibRaw | |", "|---|---|---|---|---|---|"]
    for r in comparisons:
        mark = "significant" if r["significant"] == "true" else "n.s."
        value = f"{float(r['difference']):+.2f} ± {float(r['ci95']):.2f}"
        lines.append(f"| {r['set']} | {r['illuminant']} | {r['camera']} | {r['exposure']} | "
                     + (f"**{value}**" if mark == "significant" else value) + f" | {mark} |")
    return "\n".join(lines + [END])


def main() -> None:
    plan = load_plan(ROOT / "plans" / "validate_example.toml")
    with tempfile.TemporaryDirectory() as folder:
        run_plan(plan, Path(folder) / "report")
        OUT.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(Path(folder) / "report" / "pivot.csv", OUT / "example_pivot.csv")
        shutil.copyfile(Path(folder) / "report" / "comparisons.csv", OUT / "example_comparisons.csv")
    text = block(_rows(OUT / "example_pivot.csv"), _rows(OUT / "example_comparisons.csv"), plan.seeds)
    readme = ROOT / "README.md"
    current = readme.read_text(encoding="utf-8")
    start, end = current.index(BEGIN), current.index(END) + len(END)
    readme.write_text(current[:start] + text + current[end:], encoding="utf-8")
    print(f"wrote {OUT / 'example_pivot.csv'}, example_comparisons.csv and the README block")


if __name__ == "__main__":
    main()
