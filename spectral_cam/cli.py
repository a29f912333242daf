"""``spectral-cam``: the command-line face of the Python API.

    spectral-cam render SCENE.toml -o OUTDIR [--set section.key=value]... [--force]
    spectral-cam cameras

User errors (bad scene files, names, values, existing outputs) print one clear message and
exit with status 2, never a traceback. Results appear atomically: a render writes into a
hidden staging folder that is renamed onto OUTDIR only when every file is complete.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from importlib import metadata
from pathlib import Path

from .errors import SpectralCamError

__all__ = ["main"]


def _versions() -> dict[str, str]:
    out = {}
    for name in ("spectral_cam", "mitsuba", "drjit", "colour-science", "numpy", "OpenEXR", "rawpy", "tifffile"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


class _Progress:
    """One status line on stderr, redrawn in place on a terminal."""

    def __init__(self, label: str, quiet: bool = False):
        self.label, self.quiet = label, quiet
        self.tty = sys.stderr.isatty()

    def __call__(self, done: int, total: int, seconds: float) -> None:
        if self.quiet:
            return
        rate = done / seconds if seconds > 0 else 0.0
        eta = (total - done) / rate if rate > 0 else 0.0
        line = f"{self.label}: {done}/{total} spp ({100 * done / total:.0f} %), {seconds:.1f} s, ~{eta:.0f} s left"
        if self.tty:
            end = "\n" if done >= total else ""
            print("\r" + line, end=end, file=sys.stderr, flush=True)
        elif done >= total or done == 0:
            print(line, file=sys.stderr, flush=True)


def _write_json(data: dict, path: Path) -> None:
    from .io import atomic_path

    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(data, indent=2, default=_json_default) + "\n")


def _json_default(value):
    import numpy as np

    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"cannot serialise {type(value).__name__}")


def cmd_render(args: argparse.Namespace) -> int:
    from .io import staged_directory
    from .render import render
    from .scene import load_scene
    from .spectral_exr import write_depth_exr, write_spectral_exr

    started = time.perf_counter()
    config = load_scene(args.scene, overrides=args.set or [])
    out = Path(args.output)
    timings: dict[str, float] = {}
    with staged_directory(out, force=args.force) as stage:
        radiance = render(config, progress=_Progress("render", args.quiet))
        timings.update(radiance.meta["timings_s"])
        t0 = time.perf_counter()
        write_spectral_exr(radiance, stage / "radiance.exr")
        write_depth_exr(radiance.depth_m, stage / "depth.exr")
        timings["write_exr"] = time.perf_counter() - t0
        timings["total"] = time.perf_counter() - started
        meta = {
            "scene_file": str(Path(args.scene).resolve()),
            "config": config.to_dict(),
            "optics": radiance.meta["optics"],
            "render": {k: v for k, v in radiance.meta.items() if k not in ("optics", "timings_s")},
            "model_decisions": radiance.meta.get("model_decisions", {}),
            "timings_s": timings,
            "versions": _versions(),
        }
        _write_json(meta, stage / "meta.json")
    if not args.quiet:
        print(f"wrote {out}/ (radiance.exr, depth.exr, meta.json) in {timings['total']:.1f} s "
              f"with {radiance.meta['variant']}", file=sys.stderr)
    return 0


def cmd_cameras(args: argparse.Namespace) -> int:
    from .spectra import camera_names

    for name in camera_names():
        print(name)
    print("ideal  (flat QE; with sensor.cfa = 'none' a monochrome sensor)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="spectral-cam",
        description="Spectral, path-traced scene-to-sensor camera simulator.",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("render", help="render a scene file into OUTDIR")
    p.add_argument("scene", help="scene file (.toml)")
    p.add_argument("-o", "--output", required=True, help="output folder (must not exist unless --force)")
    p.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE",
                   help="override a scene key, e.g. --set lens.f_number=2.8 (repeatable)")
    p.add_argument("--force", action="store_true", help="replace an existing output folder")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("cameras", help="list the measured camera sensors")
    p.set_defaults(func=cmd_cameras)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except SpectralCamError as exc:
        print(f"spectral-cam: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("spectral-cam: interrupted; no partial output was kept", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
