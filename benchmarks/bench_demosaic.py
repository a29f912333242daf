"""Demosaicing speed (issue 14 #6): our float32 ``bilinear``, ``malvar2004`` and ``menon2007``
against OpenCV's Bayer conversions of the same mosaic, in megapixels per second, in the same run.

OpenCV's ``cvtColor`` demosaics 8- and 16-bit mosaics only: bilinear (``COLOR_Bayer**2RGB``) on
both, EA on 16 bits, VNG on 8 bits. Ours take the float32 linear mosaic and write (H, W, 3)
float32, twice the bytes of OpenCV's 16-bit output. The mosaic is an RGGB sampling of a smooth
random colour texture with a little noise, in [0, 1] (quantised for OpenCV).

- **warm**: every method at a size is timed in turn, the order rotated each round, after one
  warm-up call each; the median of ``--repeats`` rounds.
- **first call**: each of our methods in a fresh Python process, with glibc's large-block setting
  that the CLI makes (``spectral_cam.cli.keep_large_blocks``) and the imports done first, so the
  time is the call's own, page faults of its fresh arrays included; the median of
  ``--first-calls`` processes.
- ``--baseline REV`` adds our methods as they were at git revision ``REV`` (its ``isp/demosaic.py``
  and ``isp/menon2007.py``, loaded beside the current ones) to both measurements; the CSV names
  them ``method @REV``, the chart's legend ``method (NAME)`` with ``--baseline-name NAME``
  (default "previous") and the revision in a footnote.

Usage::

    python benchmarks/bench_demosaic.py docs/bench [--sizes 1,12,24] [--repeats 7] [--first-calls 3]
                                                   [--baseline HEAD] [--baseline-name previous]
    python benchmarks/bench_demosaic.py docs/bench --from-csv   # redraw the chart from the CSV

Writes ``OUTDIR/demosaic_speed.csv`` (one row per size and method, with the CPUs and the
highest 1-minute load average seen while measuring that size) and ``OUTDIR/demosaic_speed.png``.

References
----------
.. [1] OpenCV documentation, imgproc "Color conversions", Bayer → RGB (bilinear, VNG, EA).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

OURS = ("bilinear", "malvar2004", "menon2007")
#: OpenCV's conversions: name → (input dtype, cvtColor code suffix)
OPENCV = {"opencv bilinear 8-bit": ("uint8", ""), "opencv bilinear 16-bit": ("uint16", ""),
          "opencv EA 16-bit": ("uint16", "_EA"), "opencv VNG 8-bit": ("uint8", "_VNG")}
REFERENCE = "opencv bilinear 16-bit"


def frame_shape(megapixels: float) -> tuple[int, int]:
    """(height, width), both even, 4:3, of about ``megapixels``."""
    width = round(float(np.sqrt(megapixels * 1e6 * 4 / 3)) / 2) * 2
    return round(width * 3 / 4 / 2) * 2, width


def make_mosaic(megapixels: float) -> np.ndarray:
    """An RGGB float32 mosaic in [0, 1] of a smooth random colour texture plus a little noise."""
    import cv2

    height, width = frame_shape(megapixels)
    rng = np.random.default_rng(0)
    coarse = rng.uniform(0.05, 0.9, (height // 48 + 2, width // 48 + 2, 3)).astype(np.float32)
    rgb = cv2.resize(coarse, (width, height), interpolation=cv2.INTER_CUBIC)
    mosaic = np.empty((height, width), np.float32)
    for (a, b), c in zip(((0, 0), (0, 1), (1, 0), (1, 1)), (0, 1, 1, 2)):
        mosaic[a::2, b::2] = rgb[a::2, b::2, c]
    mosaic += rng.normal(0, 0.005, mosaic.shape).astype(np.float32)
    return np.clip(mosaic, 0, 1, out=mosaic)


def load_baseline(revision: str) -> dict:
    """Our three methods as they were at git ``revision``: its ``isp/demosaic.py`` and
    ``isp/menon2007.py`` loaded as modules beside the current ones."""
    import importlib.util

    root = Path(__file__).resolve().parents[1]

    def source(name: str) -> str:
        return subprocess.run(["git", "show", f"{revision}:spectral_cam/isp/{name}.py"], cwd=root,
                              check=True, capture_output=True, text=True).stdout

    tag = "".join(c if c.isalnum() else "_" for c in revision)
    modules = {}
    for name in ("menon2007", "demosaic"):
        text = source(name).replace("from .menon2007 import", f"from ._baseline_{tag}_menon2007 import")
        full_name = f"spectral_cam.isp._baseline_{tag}_{name}"
        spec = importlib.util.spec_from_loader(full_name, loader=None)
        module = importlib.util.module_from_spec(spec)
        module.__package__ = "spectral_cam.isp"
        sys.modules[full_name] = module
        exec(compile(text, f"{revision}:spectral_cam/isp/{name}.py", "exec"), module.__dict__)  # noqa: S102
        modules[name] = module
    return {f"{method} @{revision}": getattr(modules["demosaic"], method) for method in OURS}


def methods(baseline: str | None) -> dict:
    """Name → callable(mosaic dict) for every timed method."""
    import cv2

    from spectral_cam.isp import demosaic

    table = {method: (lambda m, f=demosaic.DEMOSAIC[method]: f(m["float32"], "RGGB")) for method in OURS}
    if baseline:
        table.update({name: (lambda m, f=f: f(m["float32"], "RGGB")) for name, f in load_baseline(baseline).items()})
    for name, (dtype, suffix) in OPENCV.items():
        code = getattr(cv2, f"COLOR_BayerBG2RGB{suffix}")  # OpenCV's BG names the RGGB tile
        table[name] = lambda m, code=code, dtype=dtype: cv2.cvtColor(m[dtype], code)
    return table


def mosaics(megapixels: float) -> dict:
    mosaic = make_mosaic(megapixels)
    return {"float32": mosaic, "uint8": np.rint(mosaic * 255).astype(np.uint8),
            "uint16": np.rint(mosaic * 65535).astype(np.uint16)}


def first_call_seconds(method: str, megapixels: float, baseline: str | None) -> float:
    """One call of ``method`` in a fresh process (see the module docstring)."""
    command = [sys.executable, __file__, "--first-call", method, "--sizes", f"{megapixels:g}"]
    if baseline:
        command += ["--baseline", baseline]
    result = subprocess.run(command, check=True, capture_output=True, text=True)
    return float(result.stdout.strip().splitlines()[-1])


def _first_call(method: str, megapixels: float, baseline: str | None) -> None:
    from spectral_cam.cli import keep_large_blocks

    keep_large_blocks()
    table = methods(baseline)
    data = mosaics(megapixels)
    small = {k: np.ascontiguousarray(v[:64, :64]) for k, v in data.items()}
    table[method](small)  # imports and first-use set-up, not the call being timed
    start = time.perf_counter()
    table[method](data)
    print(time.perf_counter() - start)


def display_name(method: str, baseline_name: str = "previous") -> str:
    """The chart's name of a CSV method: ``"bilinear @05607e8"`` (ours at a git revision)
    becomes ``"bilinear (previous)"``; other names are kept."""
    base, at, _ = method.partition(" @")
    return f"{base} ({baseline_name})" if at else method


def chart(rows: list[dict], path: Path, *, baseline_name: str = "previous") -> Path:
    """Warm MP/s per frame size (left) and our methods' first call (right); methods from a
    ``--baseline`` revision are named ``method (baseline_name)``, the revision in a footnote."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    from spectral_cam.viz import figure, save_png

    fig = figure(11, 4.6)
    warm_ax, first_ax = fig.subplots(1, 2)
    names = list(dict.fromkeys(r["method"] for r in rows))
    colours = {name: f"C{k}" for k, name in enumerate([n for n in names if "@" not in n])}
    revisions = sorted({n.partition(" @")[2] for n in names if " @" in n})

    def colour(name):
        return colours[name.split(" @")[0]]

    for name in names:
        mine = [r for r in rows if r["method"] == name]
        style = "-" if name in OURS else (":" if "@" in name else "--")
        warm_ax.plot([r["megapixels"] for r in mine], [r["warm_mp_per_s"] for r in mine], style, marker="o",
                     color=colour(name), label=display_name(name, baseline_name))
    warm_ax.set(xlabel="frame (MP)", ylabel="MP/s (median, warm)", yscale="log",
                title="Warm calls: ours float32 → float32, OpenCV 8/16-bit")
    sizes = sorted({r["megapixels"] for r in rows})
    ours = [n for n in names if n in OURS or "@" in n]
    width = 0.8 / max(len(ours), 1)
    for k, name in enumerate(ours):
        by_size = {r["megapixels"]: r for r in rows if r["method"] == name}
        first_ax.bar([i + k * width for i in range(len(sizes))], [by_size[s]["first_call_mp_per_s"] for s in sizes],
                     width, color=colour(name), hatch="//" if "@" in name else None,
                     label=display_name(name, baseline_name))
    first_ax.axhline(30, color="k", lw=0.8, ls="--", label="30 MP/s")
    first_ax.set_xticks([i + width * (len(ours) - 1) / 2 for i in range(len(sizes))], [f"{s:g} MP" for s in sizes])
    first_ax.set(ylabel="MP/s (median)", yscale="log", title="Our methods' first call in a fresh process")
    for ax, room in ((warm_ax, 6), (first_ax, 4)):  # room for the legend above the curves and bars
        low, high = ax.get_ylim()
        ax.set_ylim(low, high * room)
        ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
        ax.yaxis.set_minor_formatter(NullFormatter())
    warm_ax.legend(fontsize=7, ncol=3, loc="upper center")
    first_ax.legend(fontsize=7, ncol=3, loc="upper center")
    for ax in (warm_ax, first_ax):
        ax.grid(True, which="both", alpha=0.3)
    load = max(float(r["load_average_1min"]) for r in rows)
    fig.suptitle(f"Demosaicing speed, RGGB mosaic, {rows[0]['cpus']} CPUs (1-min load average up to {load:.1f} "
                 "from other processes)", fontsize=10)
    if revisions:
        fig.supxlabel(f"({baseline_name}): our methods as they were at git revision {', '.join(revisions)}",
                      fontsize=7, color="0.35")
    return save_png(fig, path, dpi=110)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("outdir", type=Path, nargs="?")
    parser.add_argument("--sizes", default="1,12,24", help="frame sizes, megapixels")
    parser.add_argument("--repeats", type=int, default=7, help="warm rounds (after one warm-up)")
    parser.add_argument("--first-calls", type=int, default=3, help="fresh processes per method and size")
    parser.add_argument("--baseline", help="also time our methods at this git revision")
    parser.add_argument("--baseline-name", default="previous",
                        help="what the chart's legend calls the --baseline methods (default: previous)")
    parser.add_argument("--from-csv", action="store_true", help="redraw the chart from OUTDIR/demosaic_speed.csv")
    parser.add_argument("--first-call", help=argparse.SUPPRESS)  # the child process of a first-call timing
    args = parser.parse_args(argv)
    sizes = [float(s) for s in args.sizes.split(",")]
    if args.first_call:
        _first_call(args.first_call, sizes[0], args.baseline)
        return 0
    if args.outdir is None:
        parser.error("OUTDIR is required")
    if args.from_csv:
        from spectral_cam.apps.bench.common import read_rows

        rows = read_rows(args.outdir / "demosaic_speed.csv")
        print(f"wrote {chart(rows, args.outdir / 'demosaic_speed.png', baseline_name=args.baseline_name)}")
        return 0

    from spectral_cam.apps.bench.common import write_rows
    from spectral_cam.cli import keep_large_blocks

    keep_large_blocks()
    table = methods(args.baseline)
    ours = [name for name in table if name in OURS or "@" in name]
    rows = []
    for megapixels in sizes:
        data = mosaics(megapixels)
        height, width = data["float32"].shape
        load_before = os.getloadavg()[0]
        times = {name: [] for name in table}
        for name, method in table.items():
            method(data)  # warm-up
        names = list(table)
        for round_ in range(args.repeats):
            shift = round_ % len(names)
            for name in names[shift:] + names[:shift]:
                start = time.perf_counter()
                method = table[name](data)
                times[name].append(time.perf_counter() - start)
                del method
        first = {name: [] for name in ours}
        for _ in range(args.first_calls):
            for name in ours:
                first[name].append(first_call_seconds(name, megapixels, args.baseline))
        pixels = height * width / 1e6
        load = max(load_before, os.getloadavg()[0])  # other processes competing for the CPUs
        reference = pixels / float(np.median(times[REFERENCE]))
        for name in names:
            warm = float(np.median(times[name]))
            row = {"megapixels": megapixels, "height": height, "width": width, "method": name,
                   "input": "float32" if name in ours else OPENCV[name][0],
                   "warm_s": warm, "warm_mp_per_s": pixels / warm,
                   "ratio_to_opencv_bilinear_16bit": pixels / warm / reference,
                   "first_call_s": float(np.median(first[name])) if name in first else "",
                   "first_call_mp_per_s": pixels / float(np.median(first[name])) if name in first else "",
                   "repeats": args.repeats, "first_calls": args.first_calls if name in first else 0,
                   "cpus": os.cpu_count(), "load_average_1min": round(load, 2)}
            rows.append(row)
            first_text = f"  first call {row['first_call_mp_per_s']:8.1f} MP/s" if name in first else ""
            print(f"{pixels:5.1f} MP  {name:28s} {row['warm_mp_per_s']:8.1f} MP/s  "
                  f"×{row['ratio_to_opencv_bilinear_16bit']:.2f} of OpenCV 16-bit bilinear{first_text}", flush=True)
    args.outdir.mkdir(parents=True, exist_ok=True)
    csv_path = write_rows(rows, args.outdir / "demosaic_speed.csv")
    png_path = chart(rows, args.outdir / "demosaic_speed.png", baseline_name=args.baseline_name)
    print(f"wrote {csv_path} and {png_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
