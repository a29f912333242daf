"""DNG hue/saturation/value maps (ProfileHueSatMap): the map's data model, its DNG encoding and
decoding, and the colour space and interpolation that define what its table means.

A map is part of a DNG camera profile, so it lives with the format (``raw/``): the sensor fits and
writes one, the RAW reader decodes one, and the ISP applies it
(:func:`spectral_cam.isp.hue_sat_map.apply_hue_sat_map`) — no module below the ISP imports the ISP.

The map works on linear ProPhoto RGB (ROMM primaries, D50 white) in the DNG SDK's HSV (hue in
[0, 6), saturation and value in [0, 1] of the hexcone). Its table has ``hue_divisions`` ×
``sat_divisions`` × ``value_divisions`` entries of (hue shift in degrees, saturation scale, value
scale); a colour takes the (tri)linear interpolation of the entries around it, hue wrapping
round the circle, saturation spanning [0, 1] over its divisions (the first at 0, the last at 1).

References
----------
.. [1] Adobe (2023). Digital Negative (DNG) Specification 1.7.1.0, ch. 6, "Camera Profiles"
   (ProfileHueSatMapDims, ProfileHueSatMapData1/2: table order value, hue, saturation;
   interpolation of the two maps with the colour matrices' weight).
.. [2] ISO 22028-2:2013, ROMM RGB (ProPhoto RGB) primaries and white.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError

__all__ = ["HueSatMap", "rgb_to_hsv", "hsv_to_rgb", "interpolation_weights", "XYZ_D50_TO_PROPHOTO",
           "PROPHOTO_TO_XYZ_D50"]

#: Linear ProPhoto (ROMM) RGB → XYZ (D50), ISO 22028-2 (colour-science's "ProPhoto RGB";
#: tests/test_cie.py checks it).
PROPHOTO_TO_XYZ_D50 = np.array([[0.7977, 0.1352, 0.0313],
                                [0.2880, 0.7119, 0.0001],
                                [0.0000, 0.0000, 0.8249]])
XYZ_D50_TO_PROPHOTO = np.linalg.inv(PROPHOTO_TO_XYZ_D50)


@dataclass(frozen=True)
class HueSatMap:
    """A DNG ProfileHueSatMap.

    Attributes
    ----------
    table : numpy.ndarray
        (value_divisions, hue_divisions, sat_divisions, 3) float: hue shift (degrees), saturation
        scale and value scale per node; the identity is (0, 1, 1).
    """

    table: np.ndarray

    def __post_init__(self) -> None:
        table = np.asarray(self.table, dtype=np.float64)
        if table.ndim != 4 or table.shape[-1] != 3 or table.shape[1] < 1 or table.shape[2] < 2 \
                or table.shape[0] < 1 or not np.all(np.isfinite(table)):
            raise ConfigError(f"a hue/sat map table is (values >= 1, hues >= 1, sats >= 2, 3) finite numbers; "
                              f"got shape {table.shape}")
        if np.any(table[..., 1:] < 0):
            raise ConfigError("a hue/sat map's saturation and value scales must be >= 0")
        object.__setattr__(self, "table", table)

    @property
    def dims(self) -> tuple[int, int, int]:
        """(hue, saturation, value) divisions: the DNG ProfileHueSatMapDims order."""
        v, h, s, _ = self.table.shape
        return h, s, v

    @classmethod
    def identity(cls, hue_divisions: int, sat_divisions: int, value_divisions: int = 1) -> "HueSatMap":
        table = np.zeros((value_divisions, hue_divisions, sat_divisions, 3))
        table[..., 1:] = 1.0
        return cls(table)

    @classmethod
    def from_dng(cls, dims, data) -> "HueSatMap":
        """From ProfileHueSatMapDims (hues, sats, values) and a ProfileHueSatMapData array."""
        hues, sats, values = (int(d) for d in dims)
        data = np.asarray(data, dtype=np.float64)
        if data.size != hues * sats * values * 3:
            raise ConfigError(f"ProfileHueSatMapData has {data.size} numbers; dims {hues}×{sats}×{values} need "
                              f"{hues * sats * values * 3}")
        return cls(data.reshape(values, hues, sats, 3))

    def dng_data(self) -> np.ndarray:
        """The table flattened in the DNG's order (value, hue, saturation, then the 3 numbers)."""
        return self.table.astype(np.float32).ravel()

    @staticmethod
    def weighted(maps, weights) -> "HueSatMap":
        """Σ weightᵢ · mapᵢ (a DNG 1.6 reader's blend of three calibrations' maps)."""
        if len({m.table.shape for m in maps}) != 1:
            raise ConfigError("ProfileHueSatMapData1, 2 and 3 must share ProfileHueSatMapDims")
        return HueSatMap(sum(float(w) * m.table for w, m in zip(weights, maps)))

    def blend(self, other: "HueSatMap", weight: float) -> "HueSatMap":
        """weight · self + (1 − weight) · other (the DNG's interpolation of map 1 and map 2)."""
        if other.table.shape != self.table.shape:
            raise ConfigError("ProfileHueSatMapData1 and 2 must share ProfileHueSatMapDims")
        return HueSatMap(weight * self.table + (1.0 - weight) * other.table)


def rgb_to_hsv(rgb: np.ndarray) -> np.ndarray:
    """(..., 3) RGB → the DNG SDK's HSV: hue in [0, 6), saturation (max − min)/max, value max."""
    rgb = np.asarray(rgb, dtype=np.float64)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    v = rgb.max(axis=-1)
    gap = v - rgb.min(axis=-1)
    safe = np.where(gap > 0, gap, 1.0)
    h = np.where(r == v, (g - b) / safe, np.where(g == v, 2.0 + (b - r) / safe, 4.0 + (r - g) / safe))
    h = np.where(h < 0, h + 6.0, h)
    s = np.where((gap > 0) & (v > 0), gap / np.where(v > 0, v, 1.0), 0.0)
    return np.stack([np.where(gap > 0, h, 0.0), s, v], axis=-1)


def hsv_to_rgb(hsv: np.ndarray) -> np.ndarray:
    """Inverse of :func:`rgb_to_hsv` (hue taken modulo 6)."""
    hsv = np.asarray(hsv, dtype=np.float64)
    h, s, v = np.mod(hsv[..., 0], 6.0), hsv[..., 1], hsv[..., 2]
    sector = np.floor(h).astype(int) % 6
    f = h - np.floor(h)
    p, q, t = v * (1 - s), v * (1 - s * f), v * (1 - s * (1 - f))
    choices = [np.stack(c, axis=-1) for c in ((v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q))]
    out = np.zeros(hsv.shape)
    for k, rgb in enumerate(choices):
        out = np.where((sector == k)[..., None], rgb, out)
    return out


def _corners(position: np.ndarray, divisions: int, *, wrap: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lower and upper node indices and the upper node's weight along one axis of the table."""
    if divisions < 2:
        zero = np.zeros(position.shape, dtype=int)
        return zero, zero, np.zeros(position.shape)
    if wrap:  # hue: nodes at k·6/divisions, the last one's upper neighbour is node 0
        scaled = position * (divisions / 6.0)
        lower = np.clip(np.floor(scaled).astype(int), 0, divisions - 1)
        return lower, (lower + 1) % divisions, scaled - lower
    scaled = np.clip(position, 0.0, 1.0) * (divisions - 1)
    lower = np.clip(np.floor(scaled).astype(int), 0, divisions - 2)
    return lower, lower + 1, scaled - lower


def interpolation_weights(hsv: np.ndarray, dims: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(indices, weights), each (..., 8): the table nodes (flat, in DNG order) around each colour
    and their (tri)linear weights — the map's output is linear in its table."""
    hues, sats, values = dims
    h0, h1, fh = _corners(hsv[..., 0], hues, wrap=True)
    s0, s1, fs = _corners(hsv[..., 1], sats, wrap=False)
    v0, v1, fv = _corners(hsv[..., 2], values, wrap=False)
    indices, weights = [], []
    for vi, wv in ((v0, 1 - fv), (v1, fv)):
        for hi, wh in ((h0, 1 - fh), (h1, fh)):
            for si, ws in ((s0, 1 - fs), (s1, fs)):
                indices.append((vi * hues + hi) * sats + si)
                weights.append(wv * wh * ws)
    return np.stack(indices, axis=-1), np.stack(weights, axis=-1)
