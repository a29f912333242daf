"""``spectral-cam keys [SECTION]...``: every scene key, its default and what it is, grouped by the code
that declares it (the scene, a preset, a lens model, a sensor kind; :mod:`spectral_cam.scene.key_table`)."""

from __future__ import annotations

import argparse


def configure_parser(parser: argparse.ArgumentParser) -> None:
    """Optional section names."""
    parser.add_argument("sections", nargs="*", metavar="SECTION",
                        help="sections to list (scene, illuminant, sky, lens, sensor, exposure, motion, render, isp); "
                             "default: all")


def run(args: argparse.Namespace) -> int:
    """Print the keys of the sections asked for."""
    from ..errors import ConfigError
    from ..scene import SECTION_NAMES
    from ..scene.key_table import text_listing

    unknown = [name.strip("[]") for name in args.sections if name.strip("[]") not in SECTION_NAMES]
    if unknown:
        raise ConfigError(f"unknown section(s) {', '.join(unknown)}; valid: {', '.join(SECTION_NAMES)}")
    print(text_listing(tuple(name.strip("[]") for name in args.sections) or SECTION_NAMES))
    return 0
