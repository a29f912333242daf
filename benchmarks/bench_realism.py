"""Realism, measured (issue 23 #4, widened in issue 37 #8): natural-image statistics of the bundled
scenes developed at their defaults, beside real photographs and a real camera raw measured the
same way, and whether each scene lies inside the photographs' range.

Statistics (:mod:`spectral_cam.metrics.realism`) on the 8-bit display image, every image first
resampled to a short side of 320 px (the bundled scenes' frames; ``INTER_AREA`` when shrinking):
median L*, clipped share, power-spectrum slope, share of texture-free 8 × 8 blocks,
Hasler–Süsstrunk colourfulness, detail (95th percentile of the L* gradient after a σ = 1 px
Gaussian, L* per pixel), He–Sun–Tang dark channel's 25th percentile (0–255), firefly share; and on
the RAW: median and 99th percentile as fractions of full scale. Fireflies of our scenes are
counted on the render's radiance, before the sensor.

References: the photographs of the world that the installed packages ship offline
(``spectral_cam.metrics.realism.PHOTOGRAPHS``, sources and licences in that module's notes):
scikit-image's ``astronaut`` (NASA, public domain), ``coffee`` and ``chelsea`` (CC0), ``rocket``
(SpaceX, public domain) and the left view of ``stereo_motorcycle`` (Middlebury 2014);
Matplotlib's ``grace_hopper.jpg`` (U.S. Navy, public domain); scikit-learn's ``china.jpg`` and
``flower.jpg`` (CC BY 2.0; left out with a warning where scikit-learn is not installed). And the
Canon EOS 30D raw the tests fetch from Debian's archive (tests/support/samples.py), developed by
LibRaw through rawpy (camera white balance, its default sRGB rendering) and by our ISP; it is not
one of the photographs whose range is scored.

The range: for each scored measure (detail, dark channel p25, colourfulness, median L*, clipped)
a photograph is checked leave-one-out, against the min–max of the *other* photographs (how tight
the range is: a photograph outside the others' range shows the range does not hold every real
photograph); every other image against the min–max of all the photographs. Columns ``in_<measure>``
hold the verdicts, ``inside`` whether all hold, ``outside`` the measures that do not.

Writes ``OUT/realism.csv`` and ``OUT/realism.png`` (the measures, photographs against ours);
``--readme README.md`` rewrites its table there from the CSV; ``--from-csv`` redraws the chart and
the table from an existing CSV without rendering. ``--layout-seeds 0,1,2`` measures instead the
world's scenes (:data:`SEED_SCENES`: issue 37's acceptance, every outdoor and indoor preset at
three layouts) at each of those ``scene.layout_seed`` values, into ``OUT/realism_seeds.csv`` and
its own README block (each scene's range over the seeds, and whether every seed is inside). A scene that fails to render is reported and
left out (the script then exits with status 1, after writing what it measured).

Usage::

    python benchmarks/bench_realism.py docs/bench [--readme README.md] [--from-csv] [--layout-seeds 0,1,2]
"""

from __future__ import annotations

import argparse
import sys
import traceback
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENES = ("colorchecker", "dof", "dead_leaves", "slanted_edge", "cornell_box", "tabletop", "vegetation", "meadow", "field",
          "room", "mixed_light_room", "glass_sphere")
SHORT_SIDE = 320  # the bundled scenes' 480 × 320 frames
#: The measures scored against the photographs' range: CSV column, README heading, format.
MEASURES = (("detail", "detail (L* per px)", ".2f"), ("dark_p25", "dark channel p25", ".0f"),
            ("colourfulness", "colourfulness", ".1f"), ("median_L", "median L*", ".1f"),
            ("clipped", "clipped", "%"))
SHORT = {"detail": "detail", "dark_p25": "dark channel", "colourfulness": "colourfulness", "median_L": "median L*",
         "clipped": "clipped"}
PHOTOGRAPH = "photograph"
BEGIN, END = "<!-- realism:begin -->", "<!-- realism:end -->"
#: The world's scenes (an outdoor or indoor preset each) measured over layouts by ``--layout-seeds``.
SEED_SCENES = ("tabletop", "vegetation", "meadow", "field", "room")
SEEDS_BEGIN, SEEDS_END = "<!-- realism-seeds:begin -->", "<!-- realism-seeds:end -->"


def scene_row(name: str, layout_seed: int | None = None) -> dict:
    """The measures of a bundled scene at its defaults (or at ``layout_seed``)."""
    from spectral_cam import load_scene
    from spectral_cam.job import simulate
    from spectral_cam.metrics.realism import firefly_share, image_statistics, raw_levels

    overrides = {} if layout_seed is None else {"scene.layout_seed": int(layout_seed)}
    config = load_scene(ROOT / "scenes" / f"{name}.toml", overrides=overrides)
    sim = simulate(config)
    display = np.round(np.clip(sim.developed.image, 0, 1) * 255).astype(np.uint8)
    stats = image_statistics(display, short_side=SHORT_SIDE)
    framed = sim.radiance.framed() if hasattr(sim.radiance, "framed") else sim.radiance
    stats["fireflies"] = firefly_share(np.asarray(framed.data).sum(axis=-1))  # the render's, before the sensor
    raw = sim.raw
    top, left, height, width = raw.crop or (0, 0, *raw.mosaic.shape)
    median, p99 = raw_levels(raw.mosaic[top:top + height, left:left + width], raw.black_level, raw.white_level)
    kind = "ours (defaults)" if layout_seed is None else f"ours (layout_seed {layout_seed})"
    return {"image": f"scenes/{name}.toml", "kind": kind,
            "source": f"{display.shape[1]} × {display.shape[0]}", "licence": "", **stats, "raw_median": median,
            "raw_p99": p99,
            "estimator": sim.radiance.meta["model_decisions"].get("estimator", {}).get("choice", "mean")}


def photograph_rows() -> list[dict]:
    from spectral_cam.metrics.realism import PHOTOGRAPHS, image_statistics, reference_photographs

    rows = []
    for name, image in reference_photographs().items():
        _load, source, licence = PHOTOGRAPHS[name]
        rows.append({"image": name, "kind": PHOTOGRAPH, "source": f"{source} ({image.shape[1]} × {image.shape[0]})",
                     "licence": licence, **image_statistics(image, short_side=SHORT_SIDE), "raw_median": None,
                     "raw_p99": None, "estimator": None})
    return rows


def camera_raw_rows() -> list[dict]:
    try:
        import rawpy
    except ImportError:
        print("rawpy is not installed; the Canon 30D rows are left out", file=sys.stderr)
        return []

    sys.path.insert(0, str(ROOT))
    from spectral_cam import develop, read_raw
    from spectral_cam.metrics.realism import image_statistics, raw_levels
    from tests.support.samples import CANON_30D_CR2, sample_path

    try:
        path = sample_path(CANON_30D_CR2)
    except BaseException as exc:  # pytest.skip outside pytest: the archive cannot be reached
        print(f"the Canon 30D raw is not available ({exc}); its rows are left out", file=sys.stderr)
        return []
    raw = read_raw(path)
    median, p99 = raw_levels(raw.mosaic, raw.black_level, raw.white_level)
    with rawpy.imread(str(path)) as handle:
        libraw = handle.postprocess(use_camera_wb=True, output_bps=8)
    ours = np.round(np.clip(develop(raw).image, 0, 1) * 255).astype(np.uint8)
    common = {"kind": "camera raw", "source": CANON_30D_CR2.provenance.split(":")[0], "licence": "GPL-3+",
              "raw_median": median, "raw_p99": p99, "estimator": None}
    return [{"image": "Canon EOS 30D raw, LibRaw (rawpy)", **common, **image_statistics(libraw, short_side=SHORT_SIDE)},
            {"image": "Canon EOS 30D raw, our develop", **common, **image_statistics(ours, short_side=SHORT_SIDE)}]


def score_ranges(rows: list[dict]) -> None:
    """Set ``in_<measure>``, ``inside`` and ``outside`` on every row: a photograph against the
    min–max of the other photographs (leave one out), any other image against all of them."""
    photographs = [r for r in rows if r["kind"] == PHOTOGRAPH]
    for row in rows:
        others = [p for p in photographs if p is not row]
        outside = []
        for key, _heading, _spec in MEASURES:
            values = [float(p[key]) for p in others]
            inside = bool(values) and min(values) <= float(row[key]) <= max(values)
            row[f"in_{key}"] = inside
            if not inside:
                outside.append(key)
        row["inside"] = not outside
        row["outside"] = " ".join(outside)


def _format(value, spec: str) -> str:
    if value in (None, ""):
        return "–"
    return f"{100 * float(value):.2f} %" if spec == "%" else format(float(value), spec)


def _truth(value) -> bool:
    return value is True or value == "True"


def readme_block(rows: list[dict]) -> str:
    """The README's realism table, from the CSV rows: per image the scored measures, fireflies and
    the verdict against the photographs' range, then the range itself."""
    photographs = [r for r in rows if r["kind"] == PHOTOGRAPH]
    names = {"skimage": "scikit-image", "matplotlib": "Matplotlib", "sklearn": "scikit-learn"}
    packages = list(dict.fromkeys(names.get(p["image"].split(".")[0].split()[0], p["image"]) for p in photographs))
    shipped = ", ".join(packages[:-1]) + " and " + packages[-1] if len(packages) > 1 else "".join(packages)
    lines = [BEGIN,
             f"Every image resampled to a short side of {SHORT_SIDE} px. Photographs: the colour photographs of",
             f"the world that {shipped} ship ({len(photographs)}; sources and licences in",
             "`spectral_cam/metrics/realism.py`), each checked leave-one-out against the others' range; every",
             "other image against all of them. Detail: 95th percentile of the L* gradient after a σ = 1 px",
             "Gaussian; dark channel: He, Sun & Tang's, 15 × 15 px, in 8-bit levels. Fireflies of our scenes",
             "are counted on the render's radiance; spectrum slope, flat share and RAW levels are in the CSV.",
             "",
             "| image | " + " | ".join(heading for _key, heading, _spec in MEASURES)
             + " | fireflies | inside the photographs' range (a photograph: the others') |",
             "|---|" + "---|" * (len(MEASURES) + 2)]
    for r in rows:
        verdict = "yes" if _truth(r["inside"]) else "no: " + ", ".join(SHORT[k] for k in str(r["outside"]).split())
        lines.append(f"| {r['image']} ({r['kind']}) | "
                     + " | ".join(_format(r[key], spec) for key, _heading, spec in MEASURES)
                     + f" | {100 * float(r['fireflies']):.3f} % | {verdict} |")
    if photographs:
        spans = []
        for key, _heading, spec in MEASURES:
            values = [float(p[key]) for p in photographs]
            spans.append(f"{_format(min(values), spec)} – {_format(max(values), spec)}")
        held = sum(_truth(p["inside"]) for p in photographs)
        lines.append(f"| **photographs' range** ({len(photographs)}) | " + " | ".join(spans)
                     + f" | | {held} of {len(photographs)} photographs inside the others' range on every measure |")
    lines.append(END)
    return "\n".join(lines)


def seeds_block(rows: list[dict]) -> str:
    """The README's table of the world's scenes over layouts, from realism_seeds.csv: per scene
    the lowest and highest of each scored measure over its layout seeds, and the seeds outside."""
    photographs = [r for r in rows if r["kind"] == PHOTOGRAPH]
    ours = [r for r in rows if r["kind"] != PHOTOGRAPH]
    seeds = sorted({int(str(r["kind"]).rsplit(" ", 1)[-1].rstrip(")")) for r in ours})
    lines = [SEEDS_BEGIN,
             f"Each scene at `scene.layout_seed` = {', '.join(map(str, seeds))} (its other keys at their defaults),",
             "measured as above against the same photographs: the lowest and highest over the layouts.",
             "",
             "| scene | " + " | ".join(heading for _key, heading, _spec in MEASURES) + " | layouts outside the range |",
             "|---|" + "---|" * (len(MEASURES) + 1)]
    for image in dict.fromkeys(r["image"] for r in ours):
        mine = [r for r in ours if r["image"] == image]
        spans = []
        for key, _heading, spec in MEASURES:
            values = [float(r[key]) for r in mine]
            spans.append(f"{_format(min(values), spec)} – {_format(max(values), spec)}")
        outside = [f"{str(r['kind']).rsplit(' ', 1)[-1].rstrip(')')} ({', '.join(SHORT[k] for k in str(r['outside']).split())})"
                   for r in mine if not _truth(r["inside"])]
        lines.append(f"| {image} | " + " | ".join(spans) + f" | {'; '.join(outside) or 'none'} |")
    if photographs:
        spans = []
        for key, _heading, spec in MEASURES:
            values = [float(p[key]) for p in photographs]
            spans.append(f"{_format(min(values), spec)} – {_format(max(values), spec)}")
        lines.append(f"| **photographs' range** ({len(photographs)}) | " + " | ".join(spans) + " | |")
    lines.append(SEEDS_END)
    return "\n".join(lines)


def chart(rows: list[dict], path: Path) -> Path:
    """One strip per scored measure: the photographs (grey, their range shaded) against our scenes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    photographs = [r for r in rows if r["kind"] == PHOTOGRAPH]
    ours = [r for r in rows if r["kind"].startswith("ours")]
    fig, axes = plt.subplots(len(MEASURES), 1, figsize=(9, 1.5 * len(MEASURES) + 0.6))
    colours = plt.get_cmap("tab10")
    for ax, (key, heading, spec) in zip(axes, MEASURES):
        scale = 100.0 if spec == "%" else 1.0
        values = [scale * float(p[key]) for p in photographs]
        if values:
            ax.axvspan(min(values), max(values), color="0.9", zorder=0)
        ax.scatter(values, np.zeros(len(values)), marker="|", s=300, color="0.35", label="photographs", zorder=2)
        for index, r in enumerate(ours):
            ax.scatter([scale * float(r[key])], [0.3 + 0.06 * (index % 5)], color=colours(index % 10), s=25, zorder=3,
                       marker="o" if _truth(r[f"in_{key}"]) else "x")
        ax.set_yticks([])
        ax.set_ylim(-0.4, 0.8)
        ax.set_xlabel(heading + (" (%)" if spec == "%" else ""))
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color="0.35", marker="|", linestyle="", markersize=12, label="photographs")]
    handles += [Line2D([], [], color=colours(i % 10), marker="o", linestyle="", label=Path(r["image"]).stem)
                for i, r in enumerate(ours)]
    axes[0].legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.05), fontsize=7, frameon=False)
    fig.suptitle(f"Our scenes (o inside, x outside) against {len(photographs)} photographs (grey, range shaded)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _measure(names, seeds) -> tuple[list[dict], list[str]]:
    """Rows of our scenes (each at its defaults, or at each of ``seeds``) and the photographs',
    scored; and the scenes that failed to render (reported, left out)."""
    rows, failed = [], []
    for name in names:
        for seed in seeds:
            try:
                rows.append(scene_row(name, seed))
            except Exception:  # report, go on with the others: one broken scene should not lose the rest
                traceback.print_exc()
                failed.append(name if seed is None else f"{name} (layout_seed {seed})")
                continue
            print(rows[-1], file=sys.stderr)
    rows += photograph_rows()
    return rows, failed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("--readme", help="rewrite the realism table in this README")
    parser.add_argument("--from-csv", action="store_true",
                        help="redraw the chart and the README table from OUTPUT/realism.csv, without measuring")
    parser.add_argument("--layout-seeds", help="measure the world's scenes at these layout seeds (e.g. 0,1,2) into "
                                               "OUTPUT/realism_seeds.csv instead")
    args = parser.parse_args()

    from spectral_cam.apps.bench.common import read_rows, write_rows

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    seeded = args.layout_seeds is not None
    table = out / ("realism_seeds.csv" if seeded else "realism.csv")
    failed = []
    if args.from_csv:
        rows = read_rows(table)
    else:
        if seeded:
            rows, failed = _measure(SEED_SCENES, [int(v) for v in args.layout_seeds.split(",")])
        else:
            rows, failed = _measure(SCENES, [None])
            rows += camera_raw_rows()
        score_ranges(rows)
        write_rows(rows, table)
        rows = read_rows(table)  # the table and chart from the CSV, as --from-csv draws them
    if not seeded:
        chart(rows, out / "realism.png")
    if args.readme:
        from spectral_cam.records import replace_block

        if seeded:
            replace_block(args.readme, SEEDS_BEGIN, SEEDS_END, seeds_block(rows))
        else:
            replace_block(args.readme, BEGIN, END, readme_block(rows))
    if failed:
        print(f"these scenes failed and are left out: {', '.join(failed)}", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
