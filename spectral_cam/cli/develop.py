"""``spectral-cam develop RAW -o IMAGE``: develop any raw file LibRaw reads with our ISP."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def configure_parser(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``spectral-cam develop``."""
    parser.add_argument("raw", help="RAW file (.dng, or any format LibRaw reads)")
    parser.add_argument("-o", "--output", required=True,
                        help="image file; the suffix picks the format (.png, .jpg, .tif, .exr)")
    parser.add_argument("--set", action="append", metavar="isp.KEY=VALUE",
                        help="ISP setting, e.g. --set isp.demosaic=menon2007 (repeatable)")
    parser.add_argument("--force", action="store_true", help="replace an existing output file")
    parser.add_argument("-q", "--quiet", action="store_true", help="no summary line")


def run(args: argparse.Namespace) -> int:
    """Develop ``args.raw`` into ``args.output``."""
    from ..errors import ConfigError
    from ..isp import develop
    from ..isp.encode import write_image
    from ..raw import read_raw
    from ..scene import parse_override, section_from_table
    from . import keep_large_blocks

    overrides = dict(parse_override(item) for item in args.set or [])
    wrong = [key for key in overrides if not key.startswith("isp.")]
    if wrong:
        raise ConfigError(f"develop takes isp.* settings only; got {', '.join(wrong)}")
    # the [isp] section alone: a whole scene would validate (and load) spectra develop never uses
    config = section_from_table("isp", {key.split(".", 1)[1]: value for key, value in overrides.items()})
    output = Path(args.output)
    if output.exists() and not args.force:
        raise ConfigError(f"{output} exists; pass --force to overwrite it")
    raw = read_raw(args.raw)
    keep_large_blocks(raw.mosaic.size)
    developed = develop(raw, config)
    write_image(developed, output, quality=config.jpeg_quality)
    if not args.quiet:
        print(f"wrote {output} in {developed.total_s:.2f} s", file=sys.stderr)
    return 0
