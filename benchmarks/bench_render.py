"""The render against the engine underneath: ``spectral-cam render`` and its render stage against
a bare Mitsuba script of the same scene, in the same run, as the frame grows (issue 14 #1, #7).

The bare script is what a Mitsuba user would write: ``mi.load_dict`` of the very scene our
render builds (the ColorChecker preset, our camera as our render decides it (a pinhole for this
in-focus chart) with its sampler (multijitter) and 31-band box ``specfilm``, float32, box filter,
the same spp), one ``mi.render``, an EXR written by ``mi.Bitmap``. The scene goes
to it as JSON (transforms as 4×4 matrices), so it imports nothing of ours.

Measured per size (0.15, 0.6, 2.5, 12 MP at 3:2; fixed-cost row at 16 × 16 px; frames above
1 MP render in tiles):

- render stage: our ``render`` radiance time (``meta["timings_s"]["radiance"]``, in a fresh
  process) vs the bare script's ``mi.render`` call;
- whole process: ``spectral-cam render`` (render, depth, sensor, DNG, ISP, PNG, spectral EXR)
  vs the bare script, wall time and peak RSS of the process (``os.wait4`` in a small launcher
  process, see :data:`LAUNCHER`), per MP.

Medians of interleaved repeats with one warm-up each. ``--big`` adds one run of a 45 MP
full-frame sensor (8256 × 5504, 4 spp, no warm-up): ours whole process (its render stage read from
its meta.json) against the bare script, which holds the whole frame in Mitsuba's film. Writes ``OUT/render.csv``,
``OUT/render.png`` and, with ``--readme``, the README block between ``<!-- bench-render:begin -->``
and ``<!-- bench-render:end -->``.

Usage::

    python benchmarks/bench_render.py docs/bench --readme README.md [--sizes 0.15,0.6,2.5,12] [--repeats 3] [--big]

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3 renderer (``mi.render``, ``specfilm``, ``mi.Bitmap``).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

BEGIN, END = "<!-- bench-render:begin -->", "<!-- bench-render:end -->"
SCENE = Path(__file__).resolve().parents[1] / "scenes" / "colorchecker.toml"
SPP = 16
#: The ``--big`` frame: a 45 MP full-frame sensor, at 4 spp to keep the run to minutes.
BIG_FRAME, BIG_SPP = (8256, 5504), 4

BARE_SCRIPT = r"""
import json, sys, time
import drjit as dr
import mitsuba as mi
variant, scene_json, spp, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
mi.set_variant(variant)

def rebuild(node):
    if isinstance(node, dict):
        if "__transform__" in node:
            return mi.ScalarTransform4f(node["__transform__"])
        return {key: rebuild(value) for key, value in node.items()}
    if isinstance(node, list) and node and isinstance(node[0], list) and len(node[0]) == 2:
        return [tuple(pair) for pair in node]
    return node

scene = mi.load_dict(rebuild(json.load(open(scene_json))))
started = time.perf_counter()
image = mi.render(scene, spp=spp)
dr.eval(image)  # the LLVM backend is lazy: run the kernel now
dr.sync_thread()
render_s = time.perf_counter() - started
mi.Bitmap(image).write(out)
print(json.dumps({"render_s": render_s}))
"""

OURS_STAGE = r"""
import json, sys
import spectral_cam as sc
from spectral_cam.cli import keep_large_blocks
scene = sc.load_scene(sys.argv[1], overrides=json.loads(sys.argv[2]))
keep_large_blocks(scene.sensor.width_px * scene.sensor.height_px)  # as spectral-cam render does
image = sc.render(scene, with_depth=False)
print(json.dumps({"render_s": image.meta["timings_s"]["radiance"], "variant": image.meta["variant"]}))
"""


def _plain(node, mi):
    """The scene dict as JSON: Mitsuba transforms as 4×4 lists, tuples as lists."""
    if isinstance(node, dict):
        return {key: _plain(value, mi) for key, value in node.items()}
    if isinstance(node, (list, tuple)):
        return [_plain(value, mi) for value in node]
    if isinstance(node, mi.ScalarTransform4f):
        return {"__transform__": np.asarray(node.matrix, dtype=float).reshape(4, 4).tolist()}
    if isinstance(node, (np.floating, np.integer)):
        return node.item()
    if isinstance(node, np.ndarray):
        return node.tolist()
    if isinstance(node, (str, int, float, bool)) or node is None:
        return node
    raise TypeError(f"cannot write {type(node).__name__} to the bare scene")


def _our_lens_model(overrides: dict) -> str:
    """The camera our render uses for this scene (``lens.model = "auto"`` decides from the
    geometry and the pixel pitch, the same at every frame size): read from a 16 × 16 render,
    so the bare script renders through the same camera with the same sampler."""
    import spectral_cam as sc

    small = dict(overrides, **{"sensor.width_px": 16, "sensor.height_px": 16, "render.spp": 1})
    return sc.render(sc.load_scene(SCENE, overrides=small), with_depth=False).meta["lens_model"]


def scene_json(overrides: dict, path: Path) -> tuple[Path, str]:
    """Our scene for ``overrides`` as the JSON the bare script loads; returns (path, variant)."""
    import mitsuba as mi

    import spectral_cam as sc
    from spectral_cam import spectra
    from spectral_cam.optics import ThinLens
    from spectral_cam.presets import build_objects
    from spectral_cam.render import choose_variant
    from spectral_cam.render.films import band_film
    from spectral_cam.render.scene_dict import camera_dict
    from spectral_cam.scene import SPECTRAL_BANDS_DEFAULT

    config = sc.load_scene(SCENE, overrides=overrides)
    variant = choose_variant(config.render.variant)
    mi.set_variant(variant)
    lens = ThinLens.from_config(config.lens, config.sensor)
    film = band_film(spectra.parse_bands(SPECTRAL_BANDS_DEFAULT), lens.width_px, lens.height_px)
    model = _our_lens_model(overrides)
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": config.render.max_depth},
             "sensor": camera_dict(mi, lens, model, film, config.render.spp, config.render.sampler)}
    scene.update(build_objects(config, lens, mi))
    path.write_text(json.dumps(_plain(scene, mi)))
    return path, variant


#: Runs one command and reports its peak RSS. The bench's own process holds Mitsuba and the
#: scene (a few hundred MB), and Linux carries a process's peak RSS across execve, so a child
#: forked from it would report at least the bench's size; forked from this small launcher it
#: reports its own.
LAUNCHER = r"""
import json, os, subprocess, sys
proc = subprocess.Popen(json.loads(sys.argv[1]), stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
out = proc.stdout.read()
_, status, usage = os.wait4(proc.pid, 0)
sys.stdout.write(out + "\n__peak_kb__ %d\n" % usage.ru_maxrss)
sys.exit(os.waitstatus_to_exitcode(status))
"""


def _run(argv: list[str]) -> tuple[float, float, str]:
    """(wall s, peak RSS MB, stdout) of one child process, started by :data:`LAUNCHER`."""
    started = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", LAUNCHER, json.dumps(argv)], capture_output=True, text=True)
    wall = time.perf_counter() - started
    if done.returncode != 0:
        raise RuntimeError(f"{argv[:4]} failed ({done.returncode})")
    out, _, peak = done.stdout.rpartition("__peak_kb__ ")
    return wall, float(peak) / 1024.0, out


def _size(megapixels: float) -> tuple[int, int]:
    width = int(round(np.sqrt(megapixels * 1e6 * 1.5) / 2)) * 2
    return width, int(round(width / 1.5 / 2)) * 2


def measure(megapixels: float, repeats: int, folder: Path, whole: bool, *, size: tuple[int, int] | None = None,
            spp: int = SPP, stage: bool = True) -> dict:
    width, height = size or (_size(megapixels) if megapixels > 0 else (16, 16))
    overrides = {"sensor.width_px": width, "sensor.height_px": height, "render.spp": spp}
    bare_scene, variant = scene_json(overrides, folder / f"scene_{width}.json")
    cli = str(Path(sys.executable).with_name("spectral-cam"))
    sets = " ".join(f"--set {k}={v}" for k, v in overrides.items()).split()
    runs = {"bare": [sys.executable, "-c", BARE_SCRIPT, variant, str(bare_scene), str(spp), str(folder / "bare.exr")]}
    if stage:
        runs["stage"] = [sys.executable, "-c", OURS_STAGE, str(SCENE), json.dumps(overrides)]
    if whole:
        runs["ours"] = [cli, "render", str(SCENE), "-o", str(folder / "ours"), "--force", "-q", *sets]
    times = {name: [] for name in runs}
    if repeats > 1:
        for name, argv in runs.items():  # one unmeasured run each
            _run(argv)
    for repeat in range(repeats):
        order = list(runs)[repeat % len(runs):] + list(runs)[:repeat % len(runs)]
        for name in order:
            try:
                times[name].append(_run(runs[name]))
            except RuntimeError as exc:  # the bare script may not fit in memory at all
                print(f"{name} at {width} x {height}: {exc}", file=sys.stderr)
    row = {"megapixels": round(width * height / 1e6, 4), "width": width, "height": height, "spp": spp,
           "variant": variant}
    if times["bare"]:
        row["bare_render_s"] = float(np.median([json.loads(out)["render_s"] for _, _, out in times["bare"]]))
        row["bare_wall_s"] = float(np.median([w for w, _, _ in times["bare"]]))
        row["bare_peak_mb"] = float(np.median([m for _, m, _ in times["bare"]]))
    if stage:
        row["ours_render_s"] = float(np.median([json.loads(out)["render_s"] for _, _, out in times["stage"]]))
    else:  # from the whole run's own record
        row["ours_render_s"] = json.loads((folder / "ours" / "meta.json").read_text())["timings_s"]["render_radiance"]
    if whole:
        row["ours_wall_s"] = float(np.median([w for w, _, _ in times["ours"]]))
        row["ours_peak_mb"] = float(np.median([m for _, m, _ in times["ours"]]))
    if times["bare"]:
        row["render_ratio"] = row["ours_render_s"] / row["bare_render_s"]
        if whole:
            row["wall_ratio"] = row["ours_wall_s"] / row["bare_wall_s"]
    return row


def _has(row: dict, key: str) -> bool:
    return row.get(key) not in (None, "")


def readme_block(rows: list[dict]) -> str:
    lines = [BEGIN,
             "`python benchmarks/bench_render.py docs/bench --readme README.md` renders the bundled ColorChecker "
             f"({SPP} spp, 31 bands) with `spectral-cam render` and with a bare Mitsuba script of the same scene "
             "(one `mi.render`, EXR written), in one run ([CSV](docs/bench/render.csv), "
             "[chart](docs/bench/render.png)). Frames above 1 MP render in tiles:", "",
             "| frame | render stage, ours / bare | whole process, ours / bare | peak memory, ours / bare |",
             "|---|---|---|---|"]
    for r in rows:
        label = f"{int(r['width'])} × {int(r['height'])}" + (" (fixed cost)" if float(r["megapixels"]) < 0.01 else "")
        if int(r["spp"]) != SPP:
            label += f", {int(r['spp'])} spp"
        if _has(r, "bare_render_s"):
            stage = f"{float(r['ours_render_s']):.2f} / {float(r['bare_render_s']):.2f} s (×{float(r['render_ratio']):.2f})"
        else:
            stage = f"{float(r['ours_render_s']):.2f} s / bare did not run"
        wall = peak = "—"
        if _has(r, "ours_wall_s") and _has(r, "bare_wall_s"):
            wall = f"{float(r['ours_wall_s']):.2f} / {float(r['bare_wall_s']):.2f} s (×{float(r['wall_ratio']):.2f})"
        if _has(r, "ours_peak_mb") or _has(r, "bare_peak_mb"):
            peak = " / ".join(f"{float(r[k]):.0f}" if _has(r, k) else "—" for k in ("ours_peak_mb", "bare_peak_mb")) + " MB"
            if _has(r, "ours_peak_mb") and _has(r, "bare_peak_mb"):
                peak += f" (×{float(r['ours_peak_mb']) / float(r['bare_peak_mb']):.2f})"
        lines.append(f"| {label} | {stage} | {wall} | {peak} |")
    lines.append(END)
    return "\n".join(lines)


def update_readme(readme: Path, rows: list[dict]) -> None:
    from spectral_cam.records import replace_block

    replace_block(readme, BEGIN, END, readme_block(rows))


def chart(rows: list[dict], path: Path) -> None:
    from spectral_cam.viz import figure, save_png

    sized = [r for r in rows if float(r["megapixels"]) >= 0.01]
    fig = figure(12, 3.6)
    cost, ratio, memory = fig.subplots(1, 3)

    def series(axis, key_rows, value, style, label):
        axis.plot([float(r["megapixels"]) for r in key_rows], [value(r) for r in key_rows], style, label=label)

    def per_mp(key):
        return lambda r: float(r[key]) / float(r["megapixels"])

    paired = [r for r in sized if _has(r, "render_ratio")]
    same_spp = [r for r in sized if int(r["spp"]) == SPP]  # a 4-spp frame's cost per sample is not comparable
    series(cost, same_spp, per_mp("ours_render_s"), "o-", "ours, render stage")
    series(cost, [r for r in same_spp if r in paired], per_mp("bare_render_s"), "s--", "bare mi.render")
    cost.set_ylabel(f"s per MP at {SPP} spp")
    series(ratio, paired, lambda r: float(r["render_ratio"]), "o-", "render stage")
    series(ratio, [r for r in sized if _has(r, "wall_ratio")], lambda r: float(r["wall_ratio"]), "s-", "whole process")
    ratio.axhline(1.0, color="grey", lw=1)
    ratio.set_ylabel("ours / bare")
    series(memory, [r for r in sized if _has(r, "ours_peak_mb")],
           lambda r: float(r["ours_peak_mb"]) / float(r["megapixels"]), "o-", "ours, whole process")
    series(memory, [r for r in sized if _has(r, "bare_peak_mb")],
           lambda r: float(r["bare_peak_mb"]) / float(r["megapixels"]), "s--", "bare script")
    memory.set_ylabel("peak RSS, MB per MP")
    for axis in (cost, ratio, memory):
        axis.set_xscale("log"), axis.set_xlabel("frame (MP)"), axis.legend(fontsize=8)
    fig.suptitle("spectral-cam render vs bare Mitsuba, ColorChecker, 31 bands (tiles above 1 MP)", fontsize=10)
    save_png(fig, path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("--sizes", default="0.15,0.6,2.5,12")
    parser.add_argument("--whole-up-to", type=float, default=12, help="whole-process runs up to this size (MP)")
    parser.add_argument("--big", action="store_true", help="add one 45 MP (8256 x 5504) run at 4 spp")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--readme", default=None)
    args = parser.parse_args()

    from spectral_cam.apps.bench.common import write_rows

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for megapixels in [0.0] + [float(v) for v in args.sizes.split(",")]:
            row = measure(megapixels, args.repeats, Path(folder), whole=megapixels <= args.whole_up_to)
            rows.append(row)
            print(json.dumps(row), file=sys.stderr)
        if args.big:
            row = measure(0, 1, Path(folder), whole=True, size=BIG_FRAME, spp=BIG_SPP, stage=False)
            rows.append(row)
            print(json.dumps(row), file=sys.stderr)
    write_rows(rows, out / "render.csv")
    chart(rows, out / "render.png")
    if args.readme:
        update_readme(Path(args.readme), rows)


if __name__ == "__main__":
    main()
