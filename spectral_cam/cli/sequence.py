"""``spectral-cam sequence SPEC -o DIR [--modes auto,locked] [--lock-frame K] [--drift]
[--scheduler ...] [--workers N]``: frames over time through a camera whose auto exposure and
white balance are control loops (:mod:`spectral_cam.apps.sequence`); ``--drift`` adds the
vegetation drift study's metrics and charts.

References
----------
.. [1] docs/design.md, "CLI" and "Sequences".
"""

from __future__ import annotations

import argparse
import sys

__all__ = ["configure_parser", "run"]


def configure_parser(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("spec", help="sequence spec (a scene file with [sequence] and [camera] tables)")
    parser.add_argument("-o", "--output", required=True, help="output folder (renders are reused on a re-run)")
    parser.add_argument("--modes", default="auto", help="camera modes, comma-separated: auto, locked (default auto)")
    parser.add_argument("--lock-frame", type=int, default=None,
                        help="frame whose auto settings a locked mode holds (default the middle one)")
    parser.add_argument("--drift", action="store_true",
                        help="measure the plants frame by frame (vegetation scenes): drift.csv, drift.png, "
                             "drift_strip.png, drift_summary.json")
    parser.add_argument("--scheduler", default=None,
                        help="Dask scheduler address, or 'inline' (default: a local cluster)")
    parser.add_argument("--workers", type=int, default=None, help="local cluster workers (default: one per core)")
    parser.add_argument("--force", action="store_true",
                        help="replace an output folder that holds another run (a run of the same spec resumes)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress lines")


def run(args: argparse.Namespace) -> int:
    from ..apps.sequence import MODES, load_sequence, run_sequence
    from ..errors import ConfigError

    modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    unknown = [m for m in modes if m not in MODES]
    if unknown or not modes:
        raise ConfigError(f"--modes {args.modes!r}: valid modes are {', '.join(MODES)}")
    spec = load_sequence(args.spec)
    log = None if args.quiet else (lambda line: print(line, file=sys.stderr))
    run_sequence(spec, args.output, modes=modes, scheduler=args.scheduler, workers=args.workers,
                 lock_frame=args.lock_frame, log=log, force=args.force)
    written = [f"{mode}/" for mode in modes]
    if args.drift:
        from ..apps.sequence.drift import drift_metrics, plot_drift, write_drift

        result = drift_metrics(args.output, modes, noon_frame=args.lock_frame)
        written += write_drift(result, args.output) + plot_drift(result, args.output, strip_every=-(-len(spec) // 7))
    print(f"wrote {args.output}/ ({', '.join(written)}) for {len(spec)} frames")
    return 0
