"""What each pixel of a render integrates: the Mitsuba films of box bands or of the camera's curves.

``band_film``: one box-shaped unit-sensitivity ``specfilm`` channel per band (each value a
band integral of radiance). ``camera_film``: the three photon-weighted camera curves and the
CIE 1931 CMFs in one 6-channel film (``render.bands = "camera"``).

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3, plugin ``specfilm``.
.. [2] CIE 015:2018, Colorimetry, 4th ed., §7 (CIE 1931 standard observer).
"""

from __future__ import annotations

import numpy as np

from .. import spectra
from ..scene import SceneConfig

#: Wavelength step (nm) of the camera film's tabulated curves.
CAMERA_FILM_STEP_NM = 5.0


# ----------------------------------------------------------------------------- scene dict
def band_film(bands: spectra.BandGrid, width: int, height: int) -> dict:
    """A ``specfilm`` with one box-shaped unit-sensitivity channel per band, so each channel
    is the band integral of radiance. Names sort in band order (EXR sorts channel names)."""
    film = {
        "type": "specfilm",
        "width": width,
        "height": height,
        "component_format": "float32",  # float16 overflows above 65504
        "rfilter": {"type": "box"},  # the default gaussian correlates neighbouring pixels
    }
    for index, (lo, hi) in enumerate(zip(bands.edges_nm[:-1], bands.edges_nm[1:])):
        film[f"band_{index:03d}"] = {"type": "spectrum", "value": [(lo, 1.0), (hi, 1.0)]}
    return film


def render_film(config: SceneConfig, camera: bool, width: int, height: int) -> dict:
    """The film a capture plan chose: :func:`camera_film` when ``camera``, else
    :func:`band_film` of ``render.spectral_bands``."""
    if camera:
        return camera_film(config, width, height)
    return band_film(spectra.parse_bands(config.render.spectral_bands), width, height)


def camera_film(config: SceneConfig, width: int, height: int, *, channels: tuple[str, ...] | None = None) -> dict:
    """A 6-channel ``specfilm``: the photon-weighted camera curves η_c(λ)·T(λ)·λ/λ_ref
    (:func:`spectral_cam.sensor.film_curves`) and the CIE 1931 2° CMFs, so one render
    integrates the camera's response exactly and gives the XYZ ground truth too. ``channels``:
    a subset of :data:`~spectral_cam.sensor.CAMERA_CHANNELS` (Mitsuba samples wavelengths in
    proportion to the channels' summed curves, so a film of one channel has the least noise in
    it)."""
    from ..cie import cmfs_1931
    from ..sensor import CAMERA_CHANNELS, film_curves

    lo, hi = spectra.MITSUBA_RANGE_NM
    wl = np.arange(lo, hi + 0.5, CAMERA_FILM_STEP_NM)
    cmfs = spectra.sample(cmfs_1931(), wl, outside=0.0)
    curves = np.concatenate([film_curves(config, wl), cmfs], axis=1)
    chosen = [CAMERA_CHANNELS.index(name) for name in (CAMERA_CHANNELS if channels is None else channels)]
    film = {"type": "specfilm", "width": width, "height": height, "component_format": "float32",
            "rfilter": {"type": "box"}}
    for index in chosen:  # names sort in channel order
        film[f"ch{index}_{CAMERA_CHANNELS[index]}"] = {
            "type": "spectrum", "value": [(float(w), float(v)) for w, v in zip(wl, curves[:, index])]}
    return film
