"""``spectral-cam bench -o DIR [--quick] [--only NAME]... [--force]``: the speed-against-accuracy
benchmarks (:mod:`spectral_cam.apps.bench`), CSV + PNG charts in DIR."""

from __future__ import annotations

import sys

__all__ = ["configure_parser", "run"]


def configure_parser(parser) -> None:
    """Arguments of ``spectral-cam bench`` (``--only`` choices from the benchmark registry)."""
    from ..apps.bench import BENCHMARKS

    parser.add_argument("-o", "--output", required=True, help="output folder for CSV + PNG (other files in it are kept)")
    parser.add_argument("--quick", action="store_true", help="small sizes: about 5 s instead of 20 s on 2 cores")
    parser.add_argument("--only", action="append", choices=list(BENCHMARKS), help="run only these (repeatable)")
    parser.add_argument("--force", action="store_true", help="replace the results of an earlier run in the folder")


def run(args) -> int:
    """Run the benchmarks ``args`` name; progress lines go to stderr. Returns 0."""
    from ..apps.bench import run_benchmarks

    run_benchmarks(args.output, quick=args.quick, only=args.only, force=args.force,
                   log=lambda m: print(m, file=sys.stderr))
    return 0
