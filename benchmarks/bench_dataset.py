"""Dataset throughput: items per minute, and what the Dask path costs over a plain loop.

Renders the same randomised items (ColorChecker, depth-of-field planes and slanted edges
under several cameras, illuminants, ISOs, apertures and focus distances; 256 × 256 pixels,
16 spp; the default outputs: RAW, developed image, depth, defocus map, all-in-focus image,
clean camera RGB; each item is a thin-lens render, a pinhole render and a depth render,
two sensor exposures and ISP runs, and its files) in three modes:

- ``loop``: :func:`spectral_cam.apps.dataset.render_item` called item after item in this
  process, Mitsuba using every core;
- ``dask ×K``: :func:`spectral_cam.apps.dataset.generate_dataset` on a warm LocalCluster of K
  spawned workers (one render each, Mitsuba using cores/K threads), K = 1 and 2 by default.

Each mode first makes a timed first pass over the items (``warmup_s``: Mitsuba compiles a
kernel per scene layout, cached on disk for every later process, and each process fills
its colour-calibration caches; for Dask after the timed cluster start, ``startup_s``).
Then ``--rounds`` rounds each run every mode once over the same items, into fresh
folders, interleaved so that load from other processes on a shared machine hits every
mode alike; medians are reported. ``ratio_vs_loop`` is a mode's median wall time over
the loop's for the same items (``> 1``: the Dask path costs time); ``ratio_first_pass``
compares the first passes, cluster start included (what a fresh ``spectral-cam dataset``
run of these items pays over a fresh in-process loop).

Usage::

    python benchmarks/bench_dataset.py OUTDIR [--items 8] [--rounds 3] [--size 256] [--spp 16]
        [--workers 1 2]

Writes ``OUTDIR/bench_dataset.csv`` (one row per mode and round, plus the median rows) and
``OUTDIR/bench_dataset.png``, and prints a summary.

References
----------
.. [1] Rocklin, M. (2015). Dask: parallel computation with blocked algorithms and task
   scheduling. Proc. 14th Python in Science Conference, 130–136.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import os
import platform
import shutil
import statistics
import sys
import time
from pathlib import Path

SPEC = """
[dataset]
seed = 2024

[scene]
preset = {{ choice = ["colorchecker", "dof_targets", "slanted_edge"] }}
depths_m = [1.0, 2.0, 4.0]

[illuminant]
spd = {{ choice = ["D65", "A", "D50", "blackbody:5000"] }}
illuminance_lux = {{ log_uniform = [200, 5000] }}

[lens]
focal_length_mm = 25.0
f_number = {{ log_uniform = [1.8, 11.0] }}
focus_distance_m = {{ uniform = [1.0, 4.0] }}

[sensor]
model = {{ choice = ["nikon_d850", "canon_eos_5d_mkiv", "sony_ilce_7m3"] }}
width_px = {size}
height_px = {size}

[exposure]
iso = {{ choice = [100, 400, 1600] }}

[render]
spp = {spp}
"""


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def loop_pass(spec, folder: Path, items: int) -> float:
    """Render the items through render_item in this process; wall seconds."""
    from spectral_cam.apps.dataset import item_task, render_item

    shutil.rmtree(folder, ignore_errors=True)
    started = time.perf_counter()
    for index in range(items):
        row = render_item(item_task(spec, spec.plan_item(index), folder))
        if row["status"] != "done":
            raise RuntimeError(f"loop item {index} failed: {row['error']}")
    return time.perf_counter() - started


def dask_pass(spec, folder: Path, items: int, executor, threads: int) -> float:
    """Render the items through generate_dataset on a warm cluster; wall seconds."""
    from spectral_cam.apps.dataset import generate_dataset

    shutil.rmtree(folder, ignore_errors=True)
    summary = generate_dataset(spec, folder, n=items, executor=executor, progress=False, render_threads=threads)
    if summary.failed:
        raise RuntimeError(f"{summary.failed} Dask items failed: {summary.errors}")
    return summary.seconds


def start_cluster(stack: contextlib.ExitStack, spec, folder: Path, items: int, workers: int) -> dict:
    """Start a LocalCluster (timed) and run a first pass over the items on it (timed: the
    workers import, compile or load Mitsuba kernels and fill their caches)."""
    from spectral_cam.apps.dataset import local_cluster

    threads = max(1, _cores() // workers)
    t0 = time.perf_counter()
    client = stack.enter_context(local_cluster(workers))
    client.wait_for_workers(workers)
    startup = time.perf_counter() - t0
    executor = client.get_executor(pure=False)
    first = dask_pass(spec, folder, items, executor, threads)
    return {"executor": executor, "threads": threads, "startup_s": startup, "warmup_s": first}


def plot(medians: list[dict], rounds: list[dict], path: Path, title: str) -> None:
    from spectral_cam.viz import figure, save_png

    fig = figure(10.5, 4.2)
    left, right = fig.subplots(1, 2)
    names = [m["mode"] for m in medians]
    rates = [m["items_per_min"] for m in medians]
    bars = left.bar(names, rates, color=["#4c72b0"] + ["#dd8452"] * (len(medians) - 1))
    for bar, row in zip(bars, medians):
        left.text(bar.get_x() + bar.get_width() / 2, bar.get_height() / 2,
                  f"{row['items_per_min']:.1f}/min\ntime ×{row['ratio_vs_loop']:.2f}", ha="center", va="center",
                  fontsize=8, color="white")
    for i, name in enumerate(names):
        per_round = [r["items_per_min"] for r in rounds if r["mode"] == name]
        left.plot([i] * len(per_round), per_round, "k.", ms=4)
    left.set_ylabel("items per minute (median; dots: rounds)")
    left.set_title("Throughput, warm")
    left.set_ylim(0, max(r["items_per_min"] for r in rounds) * 1.3)
    bottom = [0.0] * len(medians)
    for key, colour, label in (("startup_s", "#8172b2", "cluster start"), ("warmup_s", "#937860", "first pass"),
                               ("wall_s", "#55a868", "warm pass (median)")):
        values = [m[key] for m in medians]
        right.bar(names, values, bottom=bottom, color=colour, label=label)
        bottom = [b + v for b, v in zip(bottom, values)]
    right.set_ylabel("seconds")
    right.set_title("Cluster start, first pass, warm pass")
    right.legend(fontsize=8)
    for ax in (left, right):
        ax.tick_params(axis="x", labelsize=8)
    fig.suptitle(title, fontsize=9)
    save_png(fig, path, dpi=120)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("output", help="folder for the CSV, the PNG and the rendered items")
    parser.add_argument("--items", type=int, default=8, help="items per mode and round (default 8)")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds (default 3)")
    parser.add_argument("--size", type=int, default=256, help="square image size in pixels (default 256)")
    parser.add_argument("--spp", type=int, default=16, help="samples per pixel (default 16)")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2],
                        help="LocalCluster sizes to time (default 1 2)")
    args = parser.parse_args(argv)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    from spectral_cam.apps.dataset import load_spec

    spec_path = out / "spec.toml"
    spec_path.write_text(SPEC.format(size=args.size, spp=args.spp))
    spec = load_spec(spec_path)

    loop_warmup = loop_pass(spec, out / "warmup_loop", args.items)
    print(f"loop warm-up pass: {loop_warmup:.1f} s", file=sys.stderr)
    rounds: list[dict] = []
    with contextlib.ExitStack() as stack:
        clusters = {k: start_cluster(stack, spec, out / f"warmup_dask{k}", args.items, k) for k in args.workers}
        for k, cluster in clusters.items():
            print(f"dask ×{k}: start {cluster['startup_s']:.1f} s, warm-up {cluster['warmup_s']:.1f} s",
                  file=sys.stderr)
        for index in range(args.rounds):
            wall = loop_pass(spec, out / "items_loop", args.items)
            rounds.append({"mode": "loop", "workers": 1, "render_threads": _cores(), "round": index,
                           "wall_s": wall, "startup_s": 0.0, "warmup_s": loop_warmup})
            for k, cluster in clusters.items():
                wall = dask_pass(spec, out / f"items_dask{k}", args.items, cluster["executor"], cluster["threads"])
                rounds.append({"mode": f"dask ×{k}", "workers": k, "render_threads": cluster["threads"],
                               "round": index, "wall_s": wall, "startup_s": cluster["startup_s"],
                               "warmup_s": cluster["warmup_s"]})
            print(f"round {index + 1}/{args.rounds}: " + ", ".join(
                f"{r['mode']} {r['wall_s']:.1f} s" for r in rounds if r["round"] == index), file=sys.stderr)

    loop_walls = {r["round"]: r["wall_s"] for r in rounds if r["mode"] == "loop"}
    for row in rounds:
        row["items"] = args.items
        row["items_per_min"] = 60.0 * args.items / row["wall_s"]
        row["ratio_vs_loop"] = row["wall_s"] / loop_walls[row["round"]]
    medians = []
    for mode in dict.fromkeys(r["mode"] for r in rounds):
        mine = [r for r in rounds if r["mode"] == mode]
        wall = statistics.median(r["wall_s"] for r in mine)
        median = {**{k: mine[0][k] for k in ("mode", "workers", "render_threads", "startup_s", "warmup_s")},
                  "round": "median", "items": args.items, "wall_s": wall, "items_per_min": 60.0 * args.items / wall,
                  "ratio_vs_loop": wall / statistics.median(loop_walls.values())}
        medians.append(median)
    for row in rounds + medians:
        row["ratio_first_pass"] = (row["startup_s"] + row["warmup_s"]) / loop_warmup
        row.update(size_px=args.size, spp=args.spp, cores=_cores(), python=platform.python_version())

    csv_path = out / "bench_dataset.csv"
    with open(csv_path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(medians[0]))
        writer.writeheader()
        writer.writerows(rounds + medians)
    png = out / "bench_dataset.png"
    plot(medians, rounds, png, f"{args.items} items × {args.rounds} interleaved rounds, {args.size}×{args.size} px, "
                               f"{args.spp} spp, {_cores()} cores (item: thin-lens + pinhole + depth renders, "
                               f"2 exposures, 2 ISP runs, 6 files)")
    for row in medians:
        print(f"{row['mode']:>8}: {row['items_per_min']:6.1f} items/min (median of {args.rounds}), "
              f"time ×{row['ratio_vs_loop']:.2f} of the loop; first pass ×{row['ratio_first_pass']:.2f} "
              f"(start {row['startup_s']:.1f} s + first pass {row['warmup_s']:.1f} s)")
    print(f"wrote {csv_path} and {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
