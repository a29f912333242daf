"""The spectral image: what the render hands the sensor (band radiance, depth, provenance).

A :class:`SpectralImage` holds (H, W, B) band integrals of radiance, W·m⁻²·sr⁻¹ per band
(each value the integral of L(λ) over its band, as Mitsuba's ``specfilm`` returns it), the
band centres and edges in nm, the camera-space depth in metres and a provenance record.
It lives apart from the renderer so that the sensor, the charts and the EXR reader use it
without importing Mitsuba (docs/design.md, "Units").
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np


@dataclass
class SpectralImage:
    """Spectral radiance on the image plane.

    Attributes
    ----------
    data
        (H, W, B) float32 band integrals of radiance, W·m⁻²·sr⁻¹ (per band, not per nm).
    wavelengths_nm
        (B,) band centres, nm.
    band_edges_nm
        (B + 1,) band edges, nm.
    depth_m
        (H, W) camera-space z in metres (inf where nothing was hit), or None.
    meta
        Provenance: variant, spp, seeds, timings, optics.
    channels
        None for spectral bands; for ``render.bands = "camera"`` the names of the six film
        channels (:data:`spectral_cam.sensor.CAMERA_CHANNELS`): the photon-weighted camera
        curves and the CIE 1931 CMFs, each value the integral of radiance against its curve
        (``wavelengths_nm``/``band_edges_nm`` then give the film's spectral range).
    lens
        The :class:`~spectral_cam.optics.ThinLens` the image was rendered through (its
        working f-number and field angles drive the sensor's camera equation), or None for
        a synthetic image (the sensor then uses the configured lens).
    white_reference
        Boolean (H, W) mask of the scene's white reference (the ColorChecker preset's white
        patch interior), the region ``exposure.time_s = "auto"`` exposes for; None where the
        scene has none (the sensor then exposes for the 99th percentile).

    An image rendered through a lens widened by a crop margin
    (:meth:`~spectral_cam.optics.ThinLens.widened`) holds the configured frame and a ring of
    real pixels around it: :attr:`frame_window` locates the frame, :meth:`framed` crops it.
    ``frame`` states that window for a synthetic image (e.g. a chart with its surround).
    """

    data: np.ndarray
    wavelengths_nm: np.ndarray
    band_edges_nm: np.ndarray
    depth_m: np.ndarray | None = None
    meta: dict = field(default_factory=dict)
    channels: tuple[str, ...] | None = None
    lens: Any = None
    white_reference: np.ndarray | None = None
    frame: tuple[int, int, int, int] | None = None

    @property
    def frame_window(self) -> tuple[int, int, int, int] | None:
        """(top, left, height, width) of the configured frame in :attr:`data`; None when the
        image is the frame (no margin, or no lens to say)."""
        if self.frame is not None:
            return tuple(int(v) for v in self.frame)
        if self.lens is None or getattr(self.lens, "frame_lens", None) is None:
            return None
        top, left, height, width = self.lens.frame_window
        if (top, left) == (0, 0) and (height, width) == self.data.shape[:2]:
            return None
        return top, left, height, width

    def framed(self) -> "SpectralImage":
        """The configured frame alone (``self`` when there is no margin): data, depth and
        white reference cropped as views of this image's arrays (no copy: a 45 MP cube is
        5.6 GB), ``lens`` the frame's."""
        window = self.frame_window
        if window is None:
            return self
        top, left, height, width = window
        crop = (slice(top, top + height), slice(left, left + width))

        def cut(array):
            return None if array is None else array[crop]

        lens = self.lens.layout_lens if self.lens is not None else None
        return replace(self, data=cut(self.data), depth_m=cut(self.depth_m), white_reference=cut(self.white_reference),
                       lens=lens, meta=dict(self.meta), frame=None)

    @property
    def band_widths_nm(self) -> np.ndarray:
        return np.diff(self.band_edges_nm)

    @property
    def radiance_per_nm(self) -> np.ndarray:
        """Mean spectral radiance in each band, W·m⁻²·sr⁻¹·nm⁻¹."""
        return self.data / self.band_widths_nm.astype(np.float32)
