"""``spectral-cam bench -o DIR [--quick] [--only NAME]...``: the speed-against-accuracy
benchmarks (:mod:`spectral_cam.apps.bench`), CSV + PNG charts in DIR."""

from __future__ import annotations

import sys

__all__ = ["configure_parser", "run"]


def configure_parser(parser) -> None:
    """Arguments of ``spectral-cam bench`` (``--only`` choices from the benchmark registry)."""
    from ..apps.bench import BENCHMARKS

    parser.add_argument("-o", "--output", default="bench", help="output folder for CSV + PNG (default: bench)")
    parser.add_argument("--quick", action="store_true", help="small sizes: about 5 s instead of 20 s on 2 cores")
    parser.add_argument("--only", action="append", choices=list(BENCHMARKS), help="run only these (repeatable)")


def run(args) -> int:
    """Run the benchmarks ``args`` name; progress lines go to stderr. Returns 0."""
    from ..apps.bench import run_benchmarks

    run_benchmarks(args.output, quick=args.quick, only=args.only, log=lambda m: print(m, file=sys.stderr))
    return 0
