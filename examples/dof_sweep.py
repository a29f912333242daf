"""A depth-of-field sweep: the same targets through apertures f/4 … f/16, blur measured against the
thin-lens circle of confusion.

Renders the ``dof_targets`` preset (checkered planes at 0.6, 1.2, 2.4 and 4.8 m, focused at 1.2 m)
through a 25 mm lens at each f-number of the sweep, with each item's pinhole twin
(``all_in_focus``); the dataset run measures the blur of every plane between the two images
(a uniform disc fitted per plane, :func:`spectral_cam.metrics.blur.measure_blur`) and draws
``blur_vs_depth.png`` (measured markers on the thin-lens |CoC|(z) curves) with the numbers in
``blur_vs_depth.csv``. This script then recomputes the prediction from the textbook formula,

    CoC = (f / N) · f · |z − z_f| / (z · (z_f − f)) / pixel pitch      [pixels],

prints predicted beside measured, and checks both: the CSV's prediction equals the formula, and
each blur of at least 3 px (where a disc fitted on the pixel grid resolves it) is measured within
10 % of it. It exits non-zero when a check fails.

    python examples/dof_sweep.py [-o DIR] [--width 192] [--spp 16]
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import tempfile
from pathlib import Path

F_NUMBERS = [4.0, 8.0, 16.0]
FOCAL_M, FOCUS_M = 0.025, 1.2
#: Blurs from this size up are checked (smaller ones read high: metrics.blur fits a disc on pixels).
CHECKED_FROM_PX, TOLERANCE = 3.0, 0.10


def spec(width: int, spp: int) -> dict:
    """The sweep's spec: everything fixed but the f-number (the --sweep axis)."""
    return {"dataset": {"seed": 2, "outputs": ["image", "depth", "defocus", "all_in_focus", "camera"]},
            "scene": {"preset": "dof_targets", "depths_m": [0.6, 1.2, 2.4, 4.8]},
            "sensor": {"width_px": width, "height_px": width * 2 // 3},
            "render": {"spp": spp},
            "lens": {"focal_length_mm": FOCAL_M * 1e3, "focus_distance_m": FOCUS_M}}


def thin_lens_coc_px(depth_m: float, f_number: float, pitch_m: float) -> float:
    """The thin-lens blur-circle diameter on the sensor, in pixels (Ray 2002, ch. 10)."""
    return (FOCAL_M / f_number) * FOCAL_M * abs(depth_m - FOCUS_M) / (depth_m * (FOCUS_M - FOCAL_M)) / pitch_m


def run(folder: Path, width: int, spp: int) -> list[dict]:
    """Render the sweep (or resume it) and return the blur table the run wrote."""
    from spectral_cam.apps.dataset import generate_dataset, spec_from_dict

    sweep = f"lens.f_number={json.dumps(F_NUMBERS)}"
    summary = generate_dataset(spec_from_dict(spec(width, spp), sweeps=[sweep]), folder, scheduler="inline",
                               progress=False)
    print(f"sweep {folder}: {summary.rendered} rendered, {summary.resumed} resumed, {summary.failed} failed; "
          f"chart {folder / 'blur_vs_depth.png'}")
    with open(folder / "blur_vs_depth.csv", newline="") as handle:
        return list(csv.DictReader(handle))


def check(folder: Path, rows: list[dict]) -> bool:
    """Print predicted beside measured blur; True when both checks hold."""
    pitch = {}  # each item's pixel pitch (m), from the scene it recorded
    for line in (folder / "manifest.jsonl").read_text().splitlines():
        row = json.loads(line)
        if row["status"] == "done":
            meta = json.loads((folder / row["path"] / "meta.json").read_text())
            pitch[row["id"]] = meta["config"]["sensor"]["pixel_pitch_um"] * 1e-6
    ok = True
    print(f"{'f-number':>8} {'depth m':>8} {'formula px':>10} {'csv px':>8} {'measured px':>11}  verdict")
    for row in rows:
        f_number, depth = float(row["lens.f_number"]), float(row["depth_m"])
        formula = thin_lens_coc_px(depth, f_number, pitch[row["id"]])
        predicted = float(row["predicted_coc_px"])
        measured = float(row["measured_coc_px"]) if row["measured_coc_px"] else None
        verdict = ("in focus" if formula < 0.5 else "too small to check" if formula < CHECKED_FROM_PX
                   else f"unmeasured: {row['note']}")
        ok &= abs(predicted - formula) <= 1e-3 * max(formula, 1.0)
        if measured is not None and formula >= CHECKED_FROM_PX:
            error = measured / formula - 1
            verdict = f"{error:+.0%}" + ("" if abs(error) <= TOLERANCE else " FAIL")
            ok &= abs(error) <= TOLERANCE
        shown = f"{measured:11.2f}" if measured is not None else f"{'—':>11}"
        print(f"{f_number:8.1f} {depth:8.2f} {formula:10.2f} {predicted:8.2f} {shown}  {verdict}")
    print(f"measured blur within {TOLERANCE:.0%} of the thin-lens CoC (>= {CHECKED_FROM_PX:g} px): {ok}")
    return ok


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", help="dataset folder (default: a temporary one)")
    parser.add_argument("--width", type=int, default=192, help="frame width, px (height 2/3 of it)")
    parser.add_argument("--spp", type=int, default=16, help="samples per pixel")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(args.output or Path(scratch) / "dof")
        rows = run(folder, args.width, args.spp)
        return 0 if check(folder, rows) else 1


if __name__ == "__main__":
    sys.exit(main())
