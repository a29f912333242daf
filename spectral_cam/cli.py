"""``spectral-cam``: the command-line face of the Python API.

    spectral-cam render SCENE.toml -o OUTDIR [--set section.key=value]... [--force]
    spectral-cam develop RAW.dng -o IMAGE [--set isp.key=value]... [--force]
    spectral-cam cameras

User errors (bad scene files, names, values, existing outputs) print one clear message and
exit with status 2, never a traceback. Results appear atomically: a render writes into a
hidden staging folder that is renamed onto OUTDIR only when every file is complete.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path

from .errors import SpectralCamError

__all__ = ["main"]

#: Commands implemented in their own modules: each module defines
#: ``configure_parser(parser)``, which adds its arguments and ``set_defaults(func=...)``
#: with ``func(args) -> exit status``. They are imported only when their command runs.
EXTENSIONS = {
    "validate": ("spectral_cam.validate", "validate colour pipelines against spectral ground truth"),
    "dataset": ("spectral_cam.dataset", "generate a randomised or swept synthetic dataset"),
    "stress": ("spectral_cam.stress", "chart where methods break (stress scenes)"),
    "bench": ("spectral_cam.bench", "speed-against-accuracy benchmarks (CSV + PNG charts)"),
}


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


def cmd_render(args: argparse.Namespace) -> int:
    from .job import run_render_job
    from .scene import load_scene

    config = load_scene(args.scene, overrides=args.set or [])
    meta = run_render_job(config, args.output, force=args.force, scene_file=args.scene,
                          progress=_Progress("render", args.quiet))
    if not args.quiet:
        print(f"wrote {args.output}/ ({', '.join(meta['files'])}) in {meta['timings_s']['total']:.1f} s "
              f"with {meta['render']['variant']}", file=sys.stderr)
    return 0


def cmd_develop(args: argparse.Namespace) -> int:
    from .errors import ConfigError
    from .isp import develop
    from .isp.encode import write_image
    from .raw import read_raw
    from .scene import parse_override, scene_from_dict

    overrides = dict(parse_override(item) for item in args.set or [])
    wrong = [key for key in overrides if not key.startswith("isp.")]
    if wrong:
        raise ConfigError(f"develop takes isp.* settings only; got {', '.join(wrong)}")
    config = scene_from_dict({}, overrides=overrides).isp
    output = Path(args.output)
    if output.exists() and not args.force:
        raise ConfigError(f"{output} exists; pass --force to overwrite it")
    developed = develop(read_raw(args.raw), config)
    write_image(developed, output, quality=config.jpeg_quality)
    if not args.quiet:
        print(f"wrote {output} in {developed.total_s:.2f} s", file=sys.stderr)
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

    p = sub.add_parser("develop", help="develop any DNG (ours or a camera's) into an image")
    p.add_argument("raw", help="RAW file (.dng, or any format LibRaw reads)")
    p.add_argument("-o", "--output", required=True,
                   help="image file; the suffix picks the format (.png, .jpg, .tif, .exr)")
    p.add_argument("--set", action="append", metavar="isp.KEY=VALUE",
                   help="ISP setting, e.g. --set isp.demosaic=menon2007 (repeatable)")
    p.add_argument("--force", action="store_true", help="replace an existing output file")
    p.add_argument("-q", "--quiet", action="store_true", help="no summary line")
    p.set_defaults(func=cmd_develop)

    p = sub.add_parser("cameras", help="list the measured camera sensors")
    p.set_defaults(func=cmd_cameras)
    for name, (_, help_text) in EXTENSIONS.items():
        sub.add_parser(name, help=help_text, add_help=False)
    return parser


def _extension_parser(name: str) -> argparse.ArgumentParser:
    module, help_text = EXTENSIONS[name]
    parser = argparse.ArgumentParser(prog=f"spectral-cam {name}", description=help_text)
    importlib.import_module(module).configure_parser(parser)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in EXTENSIONS:
        args = _extension_parser(argv[0]).parse_args(argv[1:])
    else:
        args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except SpectralCamError as exc:
        print(f"spectral-cam: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # e.g. an output path under a file, a read-only folder
        print(f"spectral-cam: error: {exc.strerror or exc}: {exc.filename or ''}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("spectral-cam: interrupted; no partial output was kept", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
