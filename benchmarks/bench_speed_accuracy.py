"""Speed against accuracy charts (spp, spectral sampling, ISP, LibRaw): the same as
``spectral-cam bench``.

Usage::

    python benchmarks/bench_speed_accuracy.py OUTDIR [--quick] [--only spp|bands|isp|rawpy ...]
"""

from __future__ import annotations

import argparse

from spectral_cam.apps.bench import BENCHMARKS, run_benchmarks


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--only", action="append", choices=list(BENCHMARKS))
    parser.add_argument("--force", action="store_true", help="replace an earlier run's results")
    args = parser.parse_args()
    run_benchmarks(args.output, quick=args.quick, only=args.only, force=args.force)


if __name__ == "__main__":
    main()
