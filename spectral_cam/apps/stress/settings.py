"""How large and how long each stress study is (:class:`StressSettings`), and the camera
the colour studies use.

References
----------
.. [1] docs/design.md, "Where to make a change" (a stress study reads its sizes from here).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

__all__ = ["StressSettings", "STUDY_CAMERA"]

#: Colour sensor of the exposure and illuminant studies.
STUDY_CAMERA = "nikon_d850"


@dataclass(frozen=True)
class StressSettings:
    """How large and how long each study is.

    Attributes
    ----------
    square_sizes_px
        Checkerboard square sizes, pixels.
    zone_plate_px
        Side of the square zone-plate image, pixels.
    frequency_bins
        Number of spatial-frequency rings of the zone-plate statistics (0 … 0.5 cycles/px).
    exposure_levels
        Number of signal levels, log-spaced over ``exposure_range_e``.
    exposure_range_e
        Smallest and largest mean photo-electrons per pixel.
    flat_px
        Side of the square flat-field frames, pixels.
    highlight_factors
        Exposures of the highlight study as multiples of the exposure that brings the
        brightest channel to saturation.
    optics_px
        Side of the optics study's renders, pixels.
    optics_spp
        Samples per pixel of the optics renders.
    bokeh_px
        Side of the bokeh renders, pixels.
    bokeh_thin_spp, bokeh_tracer_spp, bokeh_remedy_spp
        Samples per pixel of the thin-lens path tracer, the light tracer and the remedy's
        pinhole render.
    bokeh_reference_spp
        Samples per pixel of each of the two independent halves of the thin-lens reference.
    patch_px
        Side of a ColorChecker patch in the illuminant study, pixels.
    lens_pixel_um
        Pixel pitch the lens study measures spots in, µm.
    flicker_exposures
        Exposure times of the flicker study (log-spaced 0.1–40 ms, plus 10 and 20 ms).
    skew_px
        Height of the rolling-shutter skew renders, pixels (width 1.5×).
    seed
        Seed of every render and frame (each gets its own derived seed, :meth:`seed_for`).
    """

    square_sizes_px: tuple[int, ...] = (1, 2, 4, 8, 16, 32, 64)
    zone_plate_px: int = 256
    frequency_bins: int = 40
    exposure_levels: int = 25
    exposure_range_e: tuple[float, float] = (0.01, 1e5)
    flat_px: int = 128
    highlight_factors: tuple[float, ...] = (0.25, 0.5, 0.8, 1.0, 1.25, 1.5, 2.0, 4.0, 8.0, 16.0, 64.0)
    optics_px: int = 40
    optics_spp: int = 1024
    bokeh_px: int = 40
    bokeh_thin_spp: tuple[int, ...] = (16, 64, 256, 1024, 4096, 16384)
    bokeh_tracer_spp: tuple[int, ...] = (4, 16, 64, 256, 1024, 4096)
    bokeh_remedy_spp: tuple[int, ...] = (4, 16, 64, 256, 1024)
    bokeh_reference_spp: int = 65536
    patch_px: int = 20
    lens_pixel_um: float = 6.0
    flicker_exposures: int = 25
    skew_px: int = 48
    seed: int = 7

    @classmethod
    def full(cls) -> "StressSettings":
        """The full run (a few minutes on 2 cores)."""
        return cls()

    @classmethod
    def quick(cls) -> "StressSettings":
        """``--quick``: the same studies on fewer levels, samples and pixels (about a minute)."""
        return cls(square_sizes_px=(1, 2, 4, 8, 16, 32), zone_plate_px=192, frequency_bins=32,
                   exposure_levels=15, flat_px=96,
                   highlight_factors=(0.5, 0.8, 1.0, 1.5, 2.0, 4.0, 16.0, 64.0),
                   optics_px=40, optics_spp=256,
                   bokeh_thin_spp=(16, 64, 256, 1024, 4096), bokeh_tracer_spp=(4, 16, 64, 256, 1024),
                   bokeh_remedy_spp=(4, 16, 64, 256), bokeh_reference_spp=8192, patch_px=16,
                   flicker_exposures=13, skew_px=32)

    def replace(self, **changes) -> "StressSettings":
        """A copy with some fields changed (e.g. tiny settings for tests)."""
        return dataclasses.replace(self, **changes)

    def seed_for(self, *keys: int) -> int:
        """A reproducible 31-bit seed for one render or frame of a study, derived from
        :attr:`seed` and the integer ``keys`` (study number, series, index, ...).

        Examples
        --------
        >>> settings = StressSettings.quick()
        >>> settings.seed_for(2, 0, 1) == settings.seed_for(2, 0, 1) != settings.seed_for(2, 0, 2)
        True
        """
        return int(np.random.SeedSequence([self.seed, *keys]).generate_state(1)[0] >> 1)
