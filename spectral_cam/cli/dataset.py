"""``spectral-cam dataset SPEC.toml -n N -o DIR``: a randomised or swept synthetic dataset
(:mod:`spectral_cam.apps.dataset`)."""

from __future__ import annotations

import argparse
import sys


def configure_parser(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``spectral-cam dataset``."""
    from ..apps.dataset import default_workers

    parser.add_argument("spec", help="dataset spec (.toml): a scene file whose values may be distributions, "
                                     "plus a [dataset] table")
    parser.add_argument("-n", type=int, default=None, metavar="N",
                        help="items (per grid point with --sweep); default: the spec's [dataset] n, or 1 per "
                             "grid point")
    parser.add_argument("-o", "--output", help="dataset folder (resumed when it exists)")
    parser.add_argument("--sweep", action="append", metavar="SECTION.KEY=START:STOP:COUNT[:log]",
                        help="grid axis, e.g. --sweep lens.focus_distance_m=0.5:5:10 or "
                             "--sweep 'lens.f_number=[1.4, 2.8, 5.6]' (repeatable: their product)")
    parser.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE",
                        help="fix a scene key for every item (repeatable)")
    parser.add_argument("--export", action="append", metavar="FORMAT",
                        help="also write this export into DIR/exports/ at the end of the run (repeatable; "
                             "coco, depth_png, flo: as `spectral-cam export`, default options; the spec's "
                             "[dataset] exports sets options)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="Dask scheduler address (tcp://HOST:8786), or 'inline' to render in this "
                             "process; default: a new local Dask cluster")
    parser.add_argument("--workers", type=int, default=None, metavar="K",
                        help=f"local cluster worker processes, one render each (default {default_workers()} "
                             f"here: one per core; fewer bound the memory for large frames)")
    parser.add_argument("--retries", type=int, default=2,
                        help="resubmissions of an item whose worker died (default 2)")
    parser.add_argument("--force", action="store_true",
                        help="render every item again (also when the folder holds another spec's dataset)")
    parser.add_argument("--dashboard", action="store_true",
                        help="serve Dask's dashboard on http://127.0.0.1:8787 (local cluster; off by default: "
                             "every server listens on loopback and serves no pages)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--dry-run", action="store_true",
                        help="print the capture plans of the first items and the dataset's estimated time, memory "
                             "and size on the chosen cluster, then exit")


def run(args: argparse.Namespace) -> int:
    """``spectral-cam dataset``: exit 0 when every item is done, 1 when some failed (they are
    listed in the manifest; finished items are kept), 130 when interrupted (Ctrl-C, SIGTERM:
    finished items are kept, and the message says how many and that the same command resumes)."""
    from ..apps.dataset import DatasetInterrupted, generate_dataset, load_spec, plan_dataset, with_exports
    from ..errors import ConfigError
    from ..progress import duration

    if args.scheduler and args.workers is not None:
        raise ConfigError("--workers sizes the local cluster; with --scheduler the cluster decides")
    spec = load_spec(args.spec, sweeps=args.sweep or [], overrides=args.set or [])
    if args.export:
        spec = with_exports(spec, args.export)
    if args.dry_run:
        print(plan_dataset(spec, n=args.n, workers=args.workers, scheduler=args.scheduler))
        return 0
    if not args.output:
        raise ConfigError("spectral-cam dataset needs -o DIR (the dataset folder), or --dry-run to see the plan")
    try:
        summary = generate_dataset(spec, args.output, n=args.n, scheduler=args.scheduler, workers=args.workers,
                                   retries=args.retries, force=args.force, progress=not args.quiet,
                                   dashboard=args.dashboard)
    except DatasetInterrupted as stop:  # finished items are kept: not "no partial output was kept"
        print(f"spectral-cam: interrupted: {stop.message}", file=sys.stderr)
        return 130
    if not args.quiet:
        print(f"dataset {summary.output}: {summary.items} items, {summary.rendered} rendered, "
              f"{summary.resumed} resumed, {summary.failed} failed in {duration(summary.seconds)} "
              f"({summary.items_per_minute:.1f} items/min); manifest {summary.manifest}", file=sys.stderr)
        if spec.exports:
            print(f"  exports in {summary.output / 'exports'}: {', '.join(name for name, _ in spec.exports)}",
                  file=sys.stderr)
        for item_id, error in list(summary.errors.items())[:5]:
            print(f"  failed {item_id}: {error}", file=sys.stderr)
        if len(summary.errors) > 5:
            print(f"  ... {len(summary.errors) - 5} more failures in the manifest", file=sys.stderr)
    return 0 if summary.failed == 0 else 1
