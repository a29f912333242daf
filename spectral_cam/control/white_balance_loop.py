"""Auto white balance as a controller: estimate the illuminant's camera-RGB white from a frame,
smooth it over time, or hold it.

Estimators (on linear, demosaiced camera RGB; clipped pixels left out):

- ``grey_world``: the mean of each channel (Buchsbaum 1980) — fails when one colour dominates
  the view (foliage turns it magenta-ward);
- ``white_patch``: the 99th percentile of each channel (max-RGB, Land & McCann 1971);
- ``grey_edge``: the Minkowski p-norm (p = 1) of each channel's gradient magnitude after a
  Gaussian of σ = 1 px (van de Weijer, Gevers & Gijsenij 2007): edges, not surfaces, average to
  grey;
- ``locus``: the grey-edge estimate moved to the nearest point of the camera's own illuminant
  locus — the whites of blackbodies from 2000 to 10 000 K and CIE daylights from 4000 to
  25 000 K through the camera's measured curves — in log-chromaticity (log R/G, log B/G), so only
  plausible lights come out.

The controller's white is a chromaticity (r, b) = (R/G, B/G); ``smoothing`` (0–1) is the weight
of the previous white in an exponential average of log r and log b from frame to frame;
``mode = "locked"`` keeps the first frame's white, ``"manual"`` a given one.

References
----------
.. [1] Buchsbaum, G. (1980). A spatial processor model for object colour perception. J. Franklin
   Inst. 310(1), 1–26.
.. [2] Land, E. H., & McCann, J. J. (1971). Lightness and retinex theory. JOSA 61(1), 1–11.
.. [3] van de Weijer, J., Gevers, T., & Gijsenij, A. (2007). Edge-based color constancy. IEEE
   Transactions on Image Processing 16(9), 2207–2214.
.. [4] Finlayson, G. D., & Schaefer, G. (2001). Solving for colour constancy using a constrained
   dichromatic reflection model. IJCV 42(3), 127–144 (constraining estimates to the Planckian
   locus).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ConfigError
from ..registry import Registry

__all__ = ["AWB_METHODS", "estimate_white", "illuminant_locus", "AutoWhiteBalance", "WhiteState", "angular_error_deg"]

AWB_METHODS = Registry("auto white balance method")
#: Pixels at or above this fraction of saturation are left out of every estimate.
CLIP = 0.98


def _valid(rgb: np.ndarray) -> np.ndarray:
    return np.all(rgb < CLIP, axis=-1) & np.all(rgb > 0, axis=-1)


def _grey_world(rgb, camera=None):
    return rgb[_valid(rgb)].mean(axis=0)


def _white_patch(rgb, camera=None):
    return np.percentile(rgb[_valid(rgb)], 99.0, axis=0)


def _grey_edge(rgb, camera=None):
    from scipy import ndimage

    ok = ndimage.binary_erosion(_valid(rgb), iterations=2)
    out = []
    for c in range(3):
        smooth = ndimage.gaussian_filter(rgb[..., c].astype(np.float64), 1.0)
        gy, gx = np.gradient(smooth)
        out.append(np.mean(np.hypot(gx, gy)[ok]))
    return np.array(out)


@functools.lru_cache(maxsize=8)
def illuminant_locus(camera: str) -> np.ndarray:
    """(N, 2) log(R/G), log(B/G) of the camera's whites under blackbodies 2000–10 000 K and
    CIE daylights 4000–25 000 K (colour-science), from its measured curves."""
    import colour

    from ..sensor.colour_calibration import camera_responses

    whites = []
    for kelvin in np.geomspace(2000.0, 10000.0, 40):
        whites.append(camera_responses(camera, f"blackbody:{kelvin:.0f}", [1.0])[0])
    for kelvin in np.geomspace(4000.0, 25000.0, 30):
        xy = colour.temperature.CCT_to_xy_CIE_D(kelvin)
        sd = colour.sd_CIE_illuminant_D_series(xy)
        whites.append(camera_responses(camera, sd, [1.0])[0])
    whites = np.asarray(whites)
    return np.stack([np.log(whites[:, 0] / whites[:, 1]), np.log(whites[:, 2] / whites[:, 1])], axis=1)


def _locus(rgb, camera=None):
    if camera is None:
        raise ConfigError("AWB method 'locus' needs the camera's name (its measured curves give the locus)")
    estimate = _grey_edge(rgb)
    point = np.log([estimate[0] / estimate[1], estimate[2] / estimate[1]])
    locus = illuminant_locus(camera)
    # nearest point on the polyline of each branch, by dense resampling of the locus
    dense = np.concatenate([np.linspace(a, b, 20, endpoint=False) for a, b in zip(locus[:-1], locus[1:])
                            if np.linalg.norm(b - a) < 0.3])
    nearest = dense[np.argmin(np.linalg.norm(dense - point, axis=1))]
    return np.array([math.exp(nearest[0]), 1.0, math.exp(nearest[1])])


AWB_METHODS.add("grey_world", _grey_world, description="channel means (Buchsbaum 1980)")
AWB_METHODS.add("white_patch", _white_patch, description="99th percentile per channel (Land & McCann 1971)")
AWB_METHODS.add("grey_edge", _grey_edge, description="mean gradient magnitude, σ = 1 (van de Weijer et al. 2007)")
AWB_METHODS.add("locus", _locus, description="grey edge moved onto the camera's blackbody/daylight locus")


def estimate_white(rgb: np.ndarray, method: str = "grey_world", *, camera: str | None = None) -> np.ndarray:
    """The illuminant's camera RGB (G = 1) estimated from a frame's linear camera RGB.

    Raises
    ------
    ConfigError
        For an unknown method or a frame without usable pixels.
    """
    image = np.asarray(rgb, dtype=np.float64)
    if image.ndim != 3 or image.shape[-1] != 3 or not _valid(image).any():
        raise ConfigError("auto white balance needs an (H, W, 3) linear camera RGB frame with unclipped pixels")
    white = AWB_METHODS[method](image, camera=camera)
    if not np.all(np.isfinite(white)) or np.any(white <= 0):
        raise ConfigError(f"AWB method {method!r} found no neutral in this frame (estimate {white.tolist()})")
    return white / white[1]


def angular_error_deg(estimate, truth) -> float:
    """The angle between two RGB whites (the colour-constancy literature's error measure)."""
    a, b = np.asarray(estimate, float), np.asarray(truth, float)
    return math.degrees(math.acos(min(1.0, float(a @ b / np.linalg.norm(a) / np.linalg.norm(b)))))


@dataclass(frozen=True)
class WhiteState:
    """The white the ISP balances the next frame for (G = 1), and the last raw estimate."""

    white: tuple[float, float, float]
    estimate: tuple[float, float, float] | None = None

    @property
    def gains(self) -> tuple[float, float, float]:
        return tuple(1.0 / w for w in self.white)


@dataclass(frozen=True)
class AutoWhiteBalance:
    """The controller's settings: ``method`` (:data:`AWB_METHODS`), ``smoothing`` in [0, 1)
    (weight of the previous white), ``mode`` (``"auto"``, ``"locked"``: the first frame's white,
    ``"manual"``: ``manual_white``), and the camera (for ``locus``)."""

    method: str = "grey_world"
    smoothing: float = 0.0
    mode: str = "auto"
    manual_white: tuple[float, float, float] = (1.0, 1.0, 1.0)
    camera: str | None = None

    def __post_init__(self) -> None:
        AWB_METHODS.check(self.method, key="method")
        white = tuple(self.manual_white)
        if len(white) != 3 or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                      and np.isfinite(v) and v > 0 for v in white):
            raise ConfigError(f"[camera] wb_white = {list(white)!r}: give the white's camera R, G, B, three positive "
                              "numbers (G = 1), e.g. [0.5, 1.0, 0.7]")
        if not (isinstance(self.smoothing, (int, float)) and 0 <= self.smoothing < 1):
            raise ConfigError(f"AWB smoothing = {self.smoothing}: must lie in [0, 1)")
        if self.mode not in ("auto", "locked", "manual"):
            raise ConfigError(f"AWB mode {self.mode!r}: valid: auto, locked, manual")

    def step(self, state: WhiteState | None, rgb: np.ndarray) -> WhiteState:
        """The white after this frame (``state`` None: the first frame). A frame with nothing to
        estimate from (all clipped or black) keeps the previous white, as a camera does."""
        if self.mode == "manual":
            return WhiteState(tuple(float(v) for v in self.manual_white))
        try:
            estimate = estimate_white(rgb, self.method, camera=self.camera)
        except ConfigError:
            if state is None:
                raise
            return replace(state, estimate=None)  # a blown or black frame: keep the last white
        if state is None:
            return WhiteState(tuple(estimate), tuple(estimate))
        if self.mode == "locked":
            return replace(state, estimate=tuple(estimate))
        mix = self.smoothing
        white = np.exp(mix * np.log(np.asarray(state.white)) + (1 - mix) * np.log(estimate))
        return WhiteState(tuple(white / white[1]), tuple(estimate))
