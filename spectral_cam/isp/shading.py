"""Lens-shading correction from a flat-field calibration, as phone ISPs do it.

Calibration: a RAW of a uniform field (an integrating sphere, a diffuser over the lens) gives, per
CFA channel, the level at every pixel of that channel; a smooth surface — a polynomial of degree 8 in
the normalised coordinates fitted by least squares to the logarithm of the levels (45 terms, so the
noise of a single frame averages out) — stands for the channel's shading, and the gain at a pixel
is the channel's level at the frame's centre over the surface there. The corrected flat field is
flat in every channel: luminance shading (cos⁴ and the pixels' angular response) and colour shading
(the channels' different responses) alike. A coarse grid of cell means, bilinearly interpolated (the
Android map's form), left 8 % where the shading is steep (a 27° corner at 0.3 of the centre), so the
surface is stored instead. Applied to the black-subtracted mosaic, each pixel times its channel's
gain, before white balance. The table is the camera's, independent of the scene: calibrate once per
lens setting (focal length, aperture), as a phone stores one table per module.

References
----------
.. [1] Android camera2 API, CaptureResult.STATISTICS_LENS_SHADING_CORRECTION_MAP (per-channel gain
   maps over the frame); Adobe (2023), DNG Specification 1.7.1.0, ch. 7, opcodes GainMap and
   FixVignetteRadial (a polynomial gain surface).
.. [2] EMVA Standard 1288, Release 4.0 (2021), §8 (flat-field non-uniformity).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ConfigError

__all__ = ["ShadingTable", "calibrate_flat_field", "correct_shading", "load_shading_table"]

#: Degree of the fitted shading surface (all terms x^i·y^j with i + j <= degree).
DEFAULT_DEGREE = 8


@dataclass(frozen=True)
class ShadingTable:
    """Per-channel shading surfaces of a flat-field calibration.

    Attributes
    ----------
    coefficients : numpy.ndarray
        (channels, terms) of log(level) as a polynomial in x, y ∈ [−1, 1] (the frame's edges).
    degree : int
        The polynomial's degree.
    shape : tuple
        (H, W) of the mosaic it was calibrated on.
    cfa : str
        The mosaic's CFA (``"none"``: one channel).
    """

    coefficients: np.ndarray
    degree: int
    shape: tuple[int, int]
    cfa: str

    def gains(self) -> np.ndarray:
        """(H, W, channels) gains: the centre's level over each pixel's."""
        surface = _terms(self.shape, self.degree) @ np.asarray(self.coefficients, dtype=np.float64).T
        centre = _terms(self.shape, self.degree, centre=True) @ np.asarray(self.coefficients, dtype=np.float64).T
        return np.exp(centre - surface).reshape(*self.shape, -1)

    def to_dict(self) -> dict:
        return {"coefficients": np.asarray(self.coefficients).tolist(), "degree": self.degree,
                "shape": list(self.shape), "cfa": self.cfa, "kind": "spectral_cam lens shading table"}

    def save(self, path) -> Path:
        from ..io import atomic_path

        path = Path(path)
        with atomic_path(path) as tmp:
            tmp.write_text(json.dumps(self.to_dict()), encoding="utf-8")
        return path


def load_shading_table(path) -> ShadingTable:
    """A table written by :meth:`ShadingTable.save`."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
        table = ShadingTable(np.asarray(data["coefficients"], dtype=np.float64), int(data["degree"]),
                             tuple(int(v) for v in data["shape"]), str(data["cfa"]))
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ConfigError(f"isp.shading = {str(path)!r}: not a lens shading table ({exc}); make one with "
                          "spectral_cam.isp.shading.calibrate_flat_field(raw).save(path)") from None
    terms = (table.degree + 1) * (table.degree + 2) // 2
    if table.coefficients.ndim != 2 or table.coefficients.shape[1] != terms \
            or not np.all(np.isfinite(table.coefficients)):
        raise ConfigError(f"{path}: a shading table's coefficients are (channels, {terms}) finite numbers")
    return table


def _terms(shape, degree: int, *, centre: bool = False, rows=None, cols=None) -> np.ndarray:
    """x^i·y^j (i + j <= degree) at pixel centres (or the frame's centre), x, y ∈ [−1, 1]."""
    height, width = shape
    if centre:
        x, y = np.zeros(1), np.zeros(1)
    else:
        rr, cc = (np.indices(shape) if rows is None else (rows, cols))
        x = ((np.ravel(cc) + 0.5) / width) * 2.0 - 1.0
        y = ((np.ravel(rr) + 0.5) / height) * 2.0 - 1.0
    return np.stack([x ** i * y ** (total - i) for total in range(degree + 1) for i in range(total + 1)], axis=1)


def _channels(cfa: str, shape) -> tuple[np.ndarray, int]:
    from ..cfa import channel_count, channel_index

    if str(cfa).lower() == "none":
        return np.zeros(shape, dtype=np.intp), 1
    return channel_index(shape, cfa).astype(np.intp), channel_count(cfa)


def calibrate_flat_field(raw, *, degree: int = DEFAULT_DEGREE) -> ShadingTable:
    """A shading table from a RAW of a uniform field.

    Parameters
    ----------
    raw : RawImage
        A flat-field capture, unclipped and above the black level everywhere.
    degree : int
        Degree of the per-channel surface (2–12).

    Returns
    -------
    ShadingTable

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §8; Adobe DNG 1.7.1.0 ch. 7 (GainMap, FixVignetteRadial).
    """
    from .normalise import normalise

    if not (isinstance(degree, int) and 2 <= degree <= 12):
        raise ConfigError(f"shading surface degree {degree!r}: give a whole number in 2..12")
    mosaic = normalise(raw.mosaic, black_level=raw.black_level, white_level=raw.white_level)
    if mosaic.ndim != 2:
        raise ConfigError("lens-shading calibration needs a raw mosaic; this RAW is linear (three colours per pixel)")
    if np.any(mosaic >= 0.999):
        raise ConfigError("the flat field is clipped: calibrate on an exposure below saturation")
    if np.any(mosaic <= 0):
        raise ConfigError("the flat field reaches the black level somewhere: expose it brighter")
    index, channels = _channels(raw.cfa, mosaic.shape)
    coefficients = []
    for c in range(channels):
        rows, cols = np.nonzero(index == c)
        design = _terms(mosaic.shape, degree, rows=rows, cols=cols)
        coefficients.append(np.linalg.lstsq(design, np.log(mosaic[rows, cols].astype(np.float64)), rcond=None)[0])
    return ShadingTable(np.array(coefficients), degree, tuple(mosaic.shape), str(raw.cfa))


def correct_shading(mosaic: np.ndarray, cfa: str, table: ShadingTable) -> np.ndarray:
    """The black-subtracted, normalised mosaic with each pixel times its channel's gain.

    Raises
    ------
    ConfigError
        If the table was calibrated on a mosaic of another size or CFA.
    """
    if tuple(mosaic.shape[:2]) != tuple(table.shape) or str(cfa) != table.cfa:
        raise ConfigError(f"the shading table was calibrated on a {table.shape[1]} × {table.shape[0]} {table.cfa} "
                          f"mosaic; this RAW is {mosaic.shape[1]} × {mosaic.shape[0]} {cfa}: calibrate on a flat field "
                          "of this camera")
    index, channels = _channels(cfa, mosaic.shape[:2])
    gains = table.gains()
    per_pixel = np.take_along_axis(gains, index[..., None], axis=2)[..., 0] if channels > 1 else gains[..., 0]
    return (mosaic * per_pixel).astype(mosaic.dtype, copy=False)
