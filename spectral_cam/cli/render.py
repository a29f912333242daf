"""``spectral-cam render SCENE.toml -o OUTDIR``: one render job (render → expose → develop → files)."""

from __future__ import annotations

import argparse
import sys


def configure_parser(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``spectral-cam render``."""
    parser.add_argument("scene", help="scene file (.toml)")
    parser.add_argument("-o", "--output", required=True, help="output folder (must not exist unless --force)")
    parser.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE",
                        help="override a scene key, e.g. --set lens.f_number=2.8 (repeatable)")
    parser.add_argument("--force", action="store_true", help="replace an existing output folder")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress output")


def run(args: argparse.Namespace) -> int:
    """Render the scene file into ``args.output`` (atomically)."""
    from ..job import run_render_job
    from ..progress import spp_progress
    from ..scene import load_scene

    config = load_scene(args.scene, overrides=args.set or [])
    meta = run_render_job(config, args.output, force=args.force, scene_file=args.scene,
                          progress=spp_progress("render", enabled=not args.quiet))
    if not args.quiet:
        print(f"wrote {args.output}/ ({', '.join(meta['files'])}) in {meta['timings_s']['total']:.1f} s "
              f"with {meta['render']['variant']}", file=sys.stderr)
    return 0
