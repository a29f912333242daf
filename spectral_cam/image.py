"""The spectral image: what the render hands the sensor (band radiance, depth, provenance).

A :class:`SpectralImage` holds (H, W, B) band integrals of radiance, W·m⁻²·sr⁻¹ per band
(each value the integral of L(λ) over its band, as Mitsuba's ``specfilm`` returns it), the
band centres and edges in nm, the camera-space depth in metres and a provenance record.
It lives apart from the renderer so that the sensor, the charts and the EXR reader use it
without importing Mitsuba (docs/design.md, "Units").
"""

from __future__ import annotations

from dataclasses import dataclass, field
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
    """

    data: np.ndarray
    wavelengths_nm: np.ndarray
    band_edges_nm: np.ndarray
    depth_m: np.ndarray | None = None
    meta: dict = field(default_factory=dict)
    channels: tuple[str, ...] | None = None
    lens: Any = None
    white_reference: np.ndarray | None = None

    @property
    def band_widths_nm(self) -> np.ndarray:
        return np.diff(self.band_edges_nm)

    @property
    def radiance_per_nm(self) -> np.ndarray:
        """Mean spectral radiance in each band, W·m⁻²·sr⁻¹·nm⁻¹."""
        return self.data / self.band_widths_nm.astype(np.float32)
