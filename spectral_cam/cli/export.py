"""``spectral-cam export DATASET_DIR --format coco|depth_png|flo -o OUT``: a generated dataset in
the files other tools read (:mod:`spectral_cam.apps.dataset.exports`)."""

from __future__ import annotations

import argparse
import sys


def configure_parser(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``spectral-cam export`` (the formats: :data:`~.exports.EXPORTS`)."""
    from ..apps.dataset.exports import EXPORTS

    parser.add_argument("dataset", metavar="DATASET_DIR", help="a dataset folder (spectral-cam dataset ... -o DIR)")
    parser.add_argument("--format", required=True, metavar="FORMAT",
                        help="; ".join(f"{name}: {entry.description}" for name, entry in EXPORTS.items()))
    parser.add_argument("-o", "--output", required=True, metavar="OUT",
                        help="the file (coco) or folder (depth_png, flo) to write")
    parser.add_argument("--depth-scale", default=None, metavar="M",
                        help="depth_png: metres per PNG unit, a number or a fraction (default 0.001: millimetres, "
                             "NYU; 1/256: KITTI)")
    parser.add_argument("--force", action="store_true", help="replace an existing OUT")


def run(args: argparse.Namespace) -> int:
    """``spectral-cam export``: exit 0 when the export is written, 2 for a user error."""
    from ..apps.dataset.exports import EXPORTS, export
    from ..errors import ConfigError

    options = {} if args.depth_scale is None else {"scale_m": args.depth_scale}
    takes = [name for name, entry in EXPORTS.items() if "scale_m" in entry.options]
    if options and "scale_m" not in EXPORTS[args.format].options:  # EXPORTS[...] names the valid formats first
        raise ConfigError(f"--depth-scale applies to --format {' or '.join(takes)}, not {args.format}")
    out = export(args.dataset, args.output, format=args.format, force=args.force, **options)
    print(f"{args.format} export of {args.dataset}: {out}", file=sys.stderr)
    return 0
