"""``spectral-cam validate PLAN -o DIR`` and ``spectral-cam validate --self [--csv F]``:
colour-pipeline validation (:mod:`spectral_cam.apps.validate`)."""

from __future__ import annotations

import argparse
from pathlib import Path


def configure_parser(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``spectral-cam validate``."""
    parser.add_argument("plan", nargs="?", help="validation plan (.toml); see plans/validate_example.toml")
    parser.add_argument("-o", "--output", help="report folder: report.html, cells.csv, patches.csv, "
                        "plan.json, raw/*.dng (must not exist unless --force)")
    parser.add_argument("--self", dest="self_check", action="store_true",
                        help="run the simulator's own physics checks and print measured vs reference")
    parser.add_argument("--csv", help="with --self: also write the checks table as CSV")
    parser.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE",
                        help="override a plan key, e.g. --set validate.patch_px=12 (repeatable)")
    parser.add_argument("--force", action="store_true", help="replace an existing report folder")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress lines")


def _self_checks(args: argparse.Namespace, progress) -> int:
    from ..apps.validate import format_checks, self_checks, write_checks_csv
    from ..errors import ConfigError

    if args.plan or args.output or args.set:
        raise ConfigError("--self takes no plan, -o or --set; run it on its own (optionally with --csv PATH)")
    if args.csv and Path(args.csv).exists() and not args.force:
        raise ConfigError(f"{args.csv} exists; pass --force to overwrite it")
    results = self_checks()
    print(format_checks(results))
    progress.log(f"({progress.elapsed_s:.1f} s)")
    if args.csv:
        write_checks_csv(results, args.csv)
    return 0 if all(r.passed for r in results) else 1


def run(args: argparse.Namespace) -> int:
    """Run ``spectral-cam validate``.

    Returns
    -------
    int
        0 when every cell (or self-check) passes, 1 when some fail; user errors raise
        :class:`~spectral_cam.errors.ConfigError` (exit status 2 from the CLI).
    """
    from ..errors import ConfigError
    from ..progress import ProgressLine

    progress = ProgressLine(enabled=not args.quiet)
    if args.self_check:
        return _self_checks(args, progress)
    if not args.plan or not args.output:
        raise ConfigError("give a plan and an output folder: spectral-cam validate PLAN.toml -o REPORT_DIR "
                          "(or --self)")
    if args.csv:
        raise ConfigError("--csv belongs to --self; a plan run writes cells.csv and patches.csv into -o")
    from ..apps.validate import load_plan, run_plan

    plan = load_plan(args.plan, overrides=args.set or [])
    result = run_plan(plan, args.output, force=args.force, progress=progress.log)
    failed = [c for c in result.cells if c.status != "pass"]
    report = Path(args.output) / "report.html"  # "-o report/" must not print report//report.html
    progress.log(f"wrote {report}: {len(result.cells) - len(failed)}/{len(result.cells)} cells "
                 f"pass in {result.elapsed_s:.1f} s")
    return 0 if not failed else 1
