"""The capture plan's budget against what the job then takes (issue 26): for every bundled scene
at two frame sizes, the plan's estimated wall time and peak memory
(:func:`spectral_cam.job.plan_render_job`, what ``spectral-cam render --dry-run`` prints) next to
a whole ``spectral-cam render`` of the same scene: wall time and peak RSS of the process
(``os.wait4`` from a small launcher, as ``bench_render.py`` measures), and the plan's inputs (the
depth probe's seconds, pixels, samples, channels) so the time model can be fitted.

``--fit`` refits :data:`spectral_cam.budget.MEASURED_MODEL` (what a job takes beyond the parts its
probes measure) by least squares on the relative error and prints it (copy it into budget.py, then run again without ``--fit`` to write the CSV the
README quotes). Writes ``OUT/plan.csv``, ``OUT/plan.png`` and, with ``--readme``, the block
between ``<!-- bench-plan:begin -->`` and ``<!-- bench-plan:end -->``.

Usage::

    python benchmarks/bench_plan.py docs/bench --readme README.md [--scale 1,2] [--fit]

References
----------
.. [1] Linux ``getrusage(2)``/``wait4(2)``: ``ru_maxrss`` of a waited-for child, in kB.
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BEGIN, END = "<!-- bench-plan:begin -->", "<!-- bench-plan:end -->"
LAUNCHER = r"""
import json, os, subprocess, sys
proc = subprocess.Popen(json.loads(sys.argv[1]), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
_, status, usage = os.wait4(proc.pid, 0)
sys.stdout.write("%d\n" % usage.ru_maxrss)
sys.exit(os.waitstatus_to_exitcode(status))
"""


def _scenes() -> list[Path]:
    return sorted((ROOT / "scenes").glob("*.toml"))


def _overrides(config, scale: float) -> dict:
    """The scene at ``scale`` × its own frame size (each side), spp capped at 64 to keep the run short."""
    width = int(round(config.sensor.width_px * scale / 2)) * 2
    height = int(round(config.sensor.height_px * scale / 2)) * 2
    over = {"sensor.width_px": width, "sensor.height_px": height}
    if config.render.spp != "auto" and int(config.render.spp) > 64:
        over["render.spp"] = 64
    return over


def measure(scene: Path, scale: float, folder: Path) -> dict:
    """One row: the plan's estimates (``--dry-run --json`` in its own process, as a user runs it)
    and the job's measured wall time and peak RSS."""
    import spectral_cam as sc

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        over = _overrides(sc.load_scene(scene), scale)
    sets = [f"--set={key}={json.dumps(value)}" for key, value in over.items()]
    cli = [sys.executable, "-m", "spectral_cam.cli", "render", str(scene)]
    started = time.perf_counter()
    planned = subprocess.run(cli + ["--dry-run", "--json"] + sets, capture_output=True, text=True, check=True)
    dry_run_s = time.perf_counter() - started
    plan = json.loads(planned.stdout)
    out = folder / f"{scene.stem}_{scale:g}"
    argv = cli + ["-o", str(out), "-q", "--force"] + sets
    started = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", LAUNCHER, json.dumps(argv)], capture_output=True, text=True)
    wall = time.perf_counter() - started
    if done.returncode != 0:
        raise RuntimeError(f"{scene.name} at ×{scale:g} failed ({done.returncode})")
    peak = float(done.stdout.strip()) * 1024.0
    meta = json.loads((out / "meta.json").read_text())
    frame, budget, probe = plan["frame"], plan["budget"], plan["budget"]["probe"]
    pixels = (frame["width_px"] + 2 * (frame["crop_margin_px"] + frame["layered_margin_px"])) * \
        (frame["height_px"] + 2 * (frame["crop_margin_px"] + frame["layered_margin_px"]))
    return {"scene": scene.stem, "scale": scale, "width": frame["width_px"], "height": frame["height_px"],
            "pixels": pixels, "spp": int(meta["render"]["spp"]), "channels": plan["film"]["channels"],
            "lens_model": plan["lens_model"], "tiles": frame["tiles"],
            "calls": frame["tiles"] * max(frame["estimator_passes"], 1),
            "depth_probe_s": meta["timings_s"].get("render_depth", 0.0), **probe, "dry_run_s": dry_run_s,
            "estimated_s": budget["time_s"], "measured_s": wall,
            "estimated_mb": budget["memory_bytes"] / 1e6, "measured_mb": peak / 1e6,
            "time_error": budget["time_s"] / wall - 1.0, "memory_error": budget["memory_bytes"] / peak - 1.0}


def fit(rows: list[dict]) -> dict:
    """MEASURED_MODEL's start and pipeline seconds, and its memory per pixel, by least squares:
    what the measured job takes beyond the probed parts."""
    from spectral_cam.budget import MEASURED_MODEL

    pixels = np.array([r["pixels"] for r in rows], dtype=float)
    amon = np.array([r["calls"] > r["tiles"] for r in rows])
    probed = np.array([r["depth_probe_s"] + r["scene_load_s"] + r["compile_s"] + r["call_s"] * r["calls"]
                       + r["s_per_msample"] * r["pixels"] * r["spp"] / 1e6 for r in rows])
    probed += amon * MEASURED_MODEL["amon_s_per_mp"] * pixels / 1e6
    measured = np.array([r["measured_s"] for r in rows])
    weights = 1.0 / measured  # relative error
    design = np.stack([np.ones_like(pixels), pixels / 1e6], axis=1) * weights[:, None]
    (start, per_mp), *_ = np.linalg.lstsq(design, (measured - probed) * weights, rcond=None)
    extra = np.array([r["measured_mb"] * 1e6 - r["resident_bytes"] for r in rows])
    channels = np.array([r["channels"] for r in rows], dtype=float)
    per_pixel = float(np.median((extra / pixels - 4.0 * channels)[~amon]))
    return {**MEASURED_MODEL, "start_s": float(start), "pipeline_s_per_mp": float(per_mp), "bytes_per_pixel": per_pixel}


def chart(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, key, unit, bound in ((axes[0], "s", "wall time (s)", 0.30), (axes[1], "mb", "peak memory (MB)", 0.15)):
        measured = np.array([r[f"measured_{key}"] for r in rows])
        estimated = np.array([r[f"estimated_{key}"] for r in rows])
        low, top = 0.7 * min(measured.min(), estimated.min()), 1.4 * max(measured.max(), estimated.max())
        line = np.geomspace(low, top, 50)
        ax.fill_between(line, line * (1 - bound), line * (1 + bound), color="0.9", label=f"±{bound:.0%}")
        ax.plot(line, line, color="0.5", lw=1)
        for scale, marker in ((1.0, "o"), (2.0, "s")):
            pick = [i for i, r in enumerate(rows) if r["scale"] == scale]
            ax.scatter(measured[pick], estimated[pick], marker=marker, label=f"scene size ×{scale:g}", zorder=3)
        ax.set(xscale="log", yscale="log", xlim=(low, top), ylim=(low, top), xlabel=f"measured {unit}",
               ylabel=f"plan's estimate {unit}")
        worst = int(np.argmax(np.abs(estimated / measured - 1)))
        ax.annotate(f"{rows[worst]['scene']} ×{rows[worst]['scale']:g}", (measured[worst], estimated[worst]),
                    textcoords="offset points", xytext=(0, -28), ha="center", fontsize=8,
                    arrowprops={"arrowstyle": "-", "color": "0.4", "lw": 0.8})
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
            axis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.legend(loc="upper left", frameon=False)
    fig.suptitle("--dry-run budget against the whole job, bundled scenes (2 cores)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def readme_block(rows: list[dict]) -> str:
    time_errors = np.abs([r["time_error"] for r in rows])
    memory_errors = np.abs([r["memory_error"] for r in rows])
    worst = max(rows, key=lambda r: abs(r["time_error"]))
    return (f"{BEGIN}\n`--dry-run`'s budget against whole jobs of the {len({r['scene'] for r in rows})} bundled scenes at "
            f"two sizes (docs/bench/plan.csv, 2 cores): time within {100 * np.median(time_errors):.0f} % (median), "
            f"{100 * time_errors.max():.0f} % at worst ({worst['scene']} ×{worst['scale']:g}); peak memory within "
            f"{100 * np.median(memory_errors):.0f} % (median), {100 * memory_errors.max():.0f} % at worst.\n{END}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--readme", type=Path)
    parser.add_argument("--scale", default="1,2", help="frame scales (each side) of each scene's own size")
    parser.add_argument("--fit", action="store_true", help="print a refitted MEASURED_MODEL")
    parser.add_argument("--only", default="", help="comma-separated scene names")
    parser.add_argument("--from-csv", action="store_true", help="redraw OUT/plan.png from OUT/plan.csv")
    args = parser.parse_args(argv)
    if args.from_csv:
        with open(args.out / "plan.csv", newline="") as handle:
            rows = [{k: (v if k in ("scene", "lens_model") else float(v)) for k, v in row.items()}
                    for row in csv.DictReader(handle)]
        chart(rows, args.out / "plan.png")
        return 0
    scenes = [s for s in _scenes() if not args.only or s.stem in args.only.split(",")]
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for scale in (float(s) for s in args.scale.split(",")):
            for scene in scenes:
                rows.append(measure(scene, scale, Path(folder)))
                r = rows[-1]
                print(f"{r['scene']:>14} ×{scale:g}: {r['measured_s']:6.1f} s (plan {r['estimated_s']:6.1f}), "
                      f"{r['measured_mb']:6.0f} MB (plan {r['estimated_mb']:6.0f}), probe {r['depth_probe_s']:.2f} s",
                      flush=True)
    if args.fit:
        print("MEASURED_MODEL =", fit(rows))
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "plan.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    chart(rows, args.out / "plan.png")
    if args.readme:
        text = args.readme.read_text()
        if BEGIN in text and END in text:
            head, _, rest = text.partition(BEGIN)
            text = head + readme_block(rows) + rest.partition(END)[2]
            args.readme.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
