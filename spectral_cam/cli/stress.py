"""``spectral-cam stress -o DIR [--quick] [--only STUDY]... [--force] [-q]``: chart where
methods break (:mod:`spectral_cam.apps.stress`).

References
----------
.. [1] docs/design.md, "CLI" (thin commands, exit codes).
"""

from __future__ import annotations

import argparse

from ..errors import ConfigError

__all__ = ["configure_parser", "run"]


def configure_parser(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``spectral-cam stress`` (study names from the ``STUDIES`` registry)."""
    from ..apps.stress.run import STUDIES

    parser.add_argument("-o", "--output", required=True,
                        help="output folder for the charts (PNG), summary.csv/png and results.json "
                             "(must not exist unless --force)")
    parser.add_argument("--quick", action="store_true",
                        help="fewer levels, samples and pixels: about 15 s instead of 30 s on 2 cores")
    parser.add_argument("--only", action="append", choices=list(STUDIES), metavar="STUDY",
                        help=f"run only this study (repeatable): {', '.join(STUDIES)}")
    parser.add_argument("--force", action="store_true", help="replace an existing output folder")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress lines")


def run(args: argparse.Namespace) -> int:
    """Run the studies into a staged folder renamed onto ``args.output`` when complete (an
    interrupted run leaves no partial result); 0 on success."""
    from ..apps.stress import StressSettings, run_studies
    from ..io import staged_directory
    from ..progress import ProgressLine

    settings = StressSettings.quick() if args.quick else StressSettings.full()
    progress = ProgressLine(enabled=not args.quiet)
    try:
        with staged_directory(args.output, force=args.force) as stage:
            results = run_studies(stage, settings, only=args.only,
                                  log=lambda line: progress.log(f"stress: {line}"))
    except OSError as exc:  # an output path that cannot be a folder (a file's child, no permission, ...)
        raise ConfigError(f"cannot write the stress results to {str(args.output)!r}: "
                          f"{exc.strerror or exc} ({exc.filename or args.output})") from None
    progress.log(f"stress: wrote {args.output}/ ({len(results['files'])} files) in {progress.elapsed_s:.0f} s")
    return 0
