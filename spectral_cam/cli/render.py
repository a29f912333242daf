"""``spectral-cam render SCENE.toml -o OUTDIR``: one render job (render → expose → develop → files);
``--dry-run`` prints its capture plan instead."""

from __future__ import annotations

import argparse
import sys


def configure_parser(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``spectral-cam render``."""
    parser.add_argument("scene", help="scene file (.toml), or a Mitsuba 3 scene (.xml) with every other key at its default")
    parser.add_argument("-o", "--output", help="output folder (must not exist unless --force)")
    parser.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE",
                        help="override a scene key, e.g. --set lens.f_number=2.8 (repeatable)")
    parser.add_argument("--force", action="store_true", help="replace an existing output folder")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    parser.add_argument("--dry-run", action="store_true",
                        help="print the capture plan (every decision, the estimated time, memory and output sizes) "
                             "and exit; renders only the probes the decisions need and a small radiance probe "
                             "that measures the scene's cost")
    parser.add_argument("--json", action="store_true", help="with --dry-run: the plan as JSON")
    from ..scene.key_table import help_epilog

    parser.epilog = help_epilog()  # the keys as their owners declare them, a registered one's included
    parser.formatter_class = argparse.RawDescriptionHelpFormatter


def run(args: argparse.Namespace) -> int:
    """Render the scene file into ``args.output`` (atomically)."""
    from ..errors import ConfigError
    from ..job import plan_render_job, run_render_job
    from ..progress import spp_progress
    from ..scene import load_scene

    from . import keep_large_blocks

    config = load_scene(args.scene, overrides=args.set or [])
    keep_large_blocks(config.sensor.width_px * config.sensor.height_px)
    if args.dry_run:
        plan = plan_render_job(config, measure=True)
        if args.json:
            import json

            from ..records import json_ready

            print(json.dumps(json_ready(plan.record()), indent=1))
        else:
            print(plan.summary())
        return 0
    if not args.output:
        raise ConfigError("spectral-cam render needs -o OUTDIR (the result folder), or --dry-run to see the plan")
    meta = run_render_job(config, args.output, force=args.force, scene_file=args.scene,
                          progress=spp_progress("render", enabled=not args.quiet))
    if not args.quiet:
        print(f"wrote {args.output}/ ({', '.join(meta['files'])}) in {meta['timings_s']['total']:.1f} s "
              f"with {meta['render']['variant']}", file=sys.stderr)
    return 0
