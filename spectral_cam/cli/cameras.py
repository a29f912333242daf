"""``spectral-cam cameras``: the measured sensors a scene's ``sensor.model`` may name."""

from __future__ import annotations

import argparse


def configure_parser(parser: argparse.ArgumentParser) -> None:
    """``spectral-cam cameras`` takes no arguments."""


def run(args: argparse.Namespace) -> int:
    """Print one camera name a line, then ``ideal``."""
    from ..spectra import camera_names

    for name in camera_names():
        print(name)
    print("ideal  (flat QE; with sensor.cfa = 'none' a monochrome sensor)")
    return 0
