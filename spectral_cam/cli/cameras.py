"""``spectral-cam cameras``: the measured sensors a scene's ``sensor.model`` may name, with their
published figures (``spectral_cam/data/cameras/sensor_figures.csv``) and where each comes from."""

from __future__ import annotations

import argparse

#: The figures shown, in order, with how each is printed.
SHOWN = (("sensor_width_mm", "sensor width", "{:g} mm"), ("sensor_height_mm", "sensor height", "{:g} mm"),
         ("width_px", "columns", "{:d} px"), ("height_px", "rows", "{:d} px"),
         ("pixel_pitch_um", "pixel pitch", "{:.4g} µm"), ("bit_depth", "bit depth", "{:d} bit"),
         ("base_iso", "base ISO", "{:g}"), ("full_well_e", "full well", "{:,.0f} e⁻ at base ISO"),
         ("read_noise_e", "read noise", "{:.3g} e⁻ at base ISO"))


def configure_parser(parser: argparse.ArgumentParser) -> None:
    """``--names``: one camera name a line and nothing else."""
    parser.add_argument("--names", action="store_true", help="only the names, one a line")


def run(args: argparse.Namespace) -> int:
    """Print each camera's figures, one a line with its source ("assumed: …" where none was
    published), then ``ideal``."""
    from ..spectra import camera_figures, camera_names

    for name in camera_names():
        print(name)
        if getattr(args, "names", False):
            continue
        figures = camera_figures(name)
        for key, label, form in SHOWN:
            figure = figures[key]
            print(f"    {label:<14} {form.format(figure.value):<22} {figure.source}")
    print("ideal  (flat QE; with sensor.cfa = 'none' a monochrome sensor; the generic figures)")
    if not getattr(args, "names", False):
        print("\nA scene that names sensor.model gets these figures for the [sensor] keys it leaves unset "
              "(full_well_e, read_noise_e, bit_depth, pixel_pitch_um, base_iso); sensor.keep_field_of_view = true "
              "spreads width_px × height_px over the sensor's size.")
    return 0
