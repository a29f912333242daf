"""Realism, measured (issue 23 #4): natural-image statistics of the bundled scenes developed at
their defaults, beside real photographs and a real camera raw measured the same way.

Statistics (:mod:`spectral_cam.metrics.realism`) on the 8-bit display image: median L*, clipped
share, power-spectrum slope, share of texture-free 8 × 8 blocks, Hasler–Süsstrunk colourfulness,
firefly share; and on the RAW: median and 99th percentile as fractions of full scale.

References: scikit-image's sample photographs (``astronaut``: NASA, public domain; ``coffee``,
``chelsea``: Stéfan van der Walt, CC0; ``rocket``: SpaceX, public domain) and the Canon EOS 30D
raw the tests fetch from Debian's archive (tests/support/samples.py), developed by LibRaw through
rawpy (camera white balance, its default sRGB rendering) and by our ISP.

Writes ``OUT/realism.csv``; ``--readme README.md`` rewrites its table there.

Usage::

    python benchmarks/bench_realism.py docs/bench [--readme README.md]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENES = ("colorchecker", "dof", "dead_leaves", "slanted_edge", "cornell_box", "tabletop", "vegetation", "meadow", "field",
          "glass_sphere")
PHOTOGRAPHS = ("astronaut", "coffee", "chelsea", "rocket")
BEGIN, END = "<!-- realism:begin -->", "<!-- realism:end -->"


def scene_row(name: str) -> dict:
    from spectral_cam import load_scene
    from spectral_cam.job import simulate
    from spectral_cam.metrics.realism import firefly_share, image_statistics, raw_levels

    config = load_scene(ROOT / "scenes" / f"{name}.toml")
    sim = simulate(config)
    display = np.round(np.clip(sim.developed.image, 0, 1) * 255).astype(np.uint8)
    stats = image_statistics(display)
    framed = sim.radiance.framed() if hasattr(sim.radiance, "framed") else sim.radiance
    stats["fireflies"] = firefly_share(np.asarray(framed.data).sum(axis=-1))  # the render's, before the sensor
    raw = sim.raw
    top, left, height, width = raw.crop or (0, 0, *raw.mosaic.shape)
    median, p99 = raw_levels(raw.mosaic[top:top + height, left:left + width], raw.black_level, raw.white_level)
    return {"image": f"scenes/{name}.toml", "kind": "ours (defaults)", **stats, "raw_median": median, "raw_p99": p99,
            "estimator": sim.radiance.meta["model_decisions"].get("estimator", {}).get("choice", "mean")}


def photograph_rows() -> list[dict]:
    import skimage.data

    from spectral_cam.metrics.realism import image_statistics

    return [{"image": f"skimage.data.{name}", "kind": "photograph", **image_statistics(getattr(skimage.data, name)()),
             "raw_median": None, "raw_p99": None, "estimator": None} for name in PHOTOGRAPHS]


def camera_raw_rows() -> list[dict]:
    import rawpy

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
    ours = np.round(develop(raw).image * 255).astype(np.uint8)
    return [{"image": "Canon EOS 30D raw, LibRaw (rawpy)", "kind": "camera raw", **image_statistics(libraw),
             "raw_median": median, "raw_p99": p99, "estimator": None},
            {"image": "Canon EOS 30D raw, our develop", "kind": "camera raw", **image_statistics(ours),
             "raw_median": median, "raw_p99": p99, "estimator": None}]


def _number(value, spec: str) -> str:
    return "–" if value in (None, "") else format(float(value), spec)


def readme_block(rows: list[dict]) -> str:
    """The README's realism table, from the CSV rows."""
    lines = [BEGIN,
             "| image | median L* | clipped | spectrum slope | flat 8×8 | colourfulness | fireflies | RAW median | "
             "RAW p99 |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['image']} ({r['kind']}) | {_number(r['median_L'], '.1f')} | "
                     f"{_number(100 * float(r['clipped']), '.2f')} % | {_number(r['spectrum_slope'], '.2f')} | "
                     f"{_number(100 * float(r['flat']), '.1f')} % | {_number(r['colourfulness'], '.1f')} | "
                     f"{_number(100 * float(r['fireflies']), '.3f')} % | "
                     f"{'–' if r['raw_median'] in (None, '') else format(100 * float(r['raw_median']), '.1f') + ' %'} | "
                     f"{'–' if r['raw_p99'] in (None, '') else format(100 * float(r['raw_p99']), '.1f') + ' %'} |")
    lines.append(END)
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("--readme", help="rewrite the realism table in this README")
    args = parser.parse_args()

    from spectral_cam.apps.bench.common import write_rows

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in SCENES:
        rows.append(scene_row(name))
        print(rows[-1], file=sys.stderr)
    rows += photograph_rows() + camera_raw_rows()
    write_rows(rows, out / "realism.csv")
    if args.readme:
        import csv

        from spectral_cam.records import replace_block

        with open(out / "realism.csv", newline="") as handle:
            replace_block(args.readme, BEGIN, END, readme_block(list(csv.DictReader(handle))))


if __name__ == "__main__":
    main()
