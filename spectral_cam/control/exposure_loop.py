"""Auto exposure as a controller: metering, an exposure program and a damped loop.

Metering is the camera meter of :mod:`spectral_cam.metering` (the one-shot auto exposure's):
``average``, ``centre_weighted``, ``spot``, ``highlight`` (the average, with the 99th percentile
kept at or below ``highlight_target``) or ``etr`` (the 99th percentile at ``highlight_target``).
Each reads a grey-equivalent value, and the target is mid grey's place in the RAW, 10/78 of
saturation (ISO 12232).

The loop works in exposure value (EV, log₂ of exposure time × ISO gain): the error
e = log₂(target / metered) of a frame taken at EV₀ is corrected by ``damping``·e for the next
frame unless |e| lies within ``dead_band`` (no correction: the loop rests), so after a step ΔEV
of scene brightness the residual is (1 − damping)ⁿ·ΔEV after n frames — it reaches the dead band
after ⌈ln(dead_band/|ΔEV|)/ln(1 − damping)⌉ frames and, with 0 < damping ≤ 1, never overshoots.
The program turns the EV into a shutter time and an ISO: ``shutter_priority`` keeps the time at
``max_shutter_s`` or less and raises ISO only when the time is at that limit; ``iso_priority``
keeps ISO at its base and changes the time (to ``max_shutter_s``); ``program`` does the same as
shutter priority.

References
----------
.. [1] ISO 2720:1974 (calibration of exposure meters, K = 12.5); ISO 12232:2019.
.. [2] Franklin, G. F., Powell, J. D., & Emami-Naeini, A. (2019). Feedback Control of Dynamic
   Systems, 8th ed., ch. 8 (first-order discrete loops, dead bands).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ConfigError
from ..metering import GREY_RAW, METERING, metered_grey

__all__ = ["METERING", "meter", "ExposureState", "AutoExposure", "MID_GREY"]

#: The metering target: mid grey's place in a RAW, ISO 12232's 10/78 of saturation (the one-shot
#: auto exposure's too: :mod:`spectral_cam.metering`).
MID_GREY = GREY_RAW


def meter(luminance: np.ndarray, mode: str = "average", *, highlight_target: float = 0.9,
          peak: np.ndarray | None = None) -> float:
    """The grey-equivalent value of a frame's linear luminance (1 = saturation): the shared
    camera meter (:func:`spectral_cam.metering.metered_grey`).

    Raises
    ------
    ConfigError
        For an unknown mode (listing the valid ones) or a frame without pixels.
    """
    return metered_grey(luminance, mode, peak=peak, fraction=highlight_target)


@dataclass(frozen=True)
class ExposureState:
    """What the loop holds between frames (recorded in each frame's meta).

    Attributes
    ----------
    time_s, iso : float
        The exposure the next frame is taken with.
    error_ev : float or None
        The last frame's metering error log₂(target/metered).
    adjusted : bool
        Whether the last step changed the exposure (False inside the dead band).
    """

    time_s: float
    iso: float
    error_ev: float | None = None
    adjusted: bool = False

    def ev(self, base_iso: float) -> float:
        """log₂ of the exposure (time × ISO gain over base)."""
        return math.log2(self.time_s * self.iso / base_iso)


@dataclass(frozen=True)
class AutoExposure:
    """The controller's settings (``mode = "locked"`` holds the first exposure).

    Attributes
    ----------
    metering : str
        One of :data:`METERING`.
    program : str
        ``"program"``, ``"shutter_priority"`` or ``"iso_priority"``.
    compensation_ev : float
        Added to the target (+1 EV: twice as bright).
    damping : float
        Fraction of the error corrected per frame, in (0, 1].
    dead_band_ev : float
        Errors smaller than this leave the exposure alone.
    base_iso, max_iso : float
    min_shutter_s, max_shutter_s : float
    highlight_target : float
        Target of ``highlight`` metering (fraction of saturation).
    mode : str
        ``"auto"`` or ``"locked"``.
    """

    metering: str = "average"
    program: str = "program"
    compensation_ev: float = 0.0
    damping: float = 0.5
    dead_band_ev: float = 1.0 / 6.0
    base_iso: float = 100.0
    max_iso: float = 6400.0
    min_shutter_s: float = 1.0 / 8000.0
    max_shutter_s: float = 1.0 / 30.0
    highlight_target: float = 0.9
    mode: str = "auto"

    def __post_init__(self) -> None:
        METERING.check(self.metering, key="metering")
        numbers = {"compensation_ev": (-10.0, 10.0), "damping": (0.0, 1.0), "dead_band_ev": (0.0, 10.0),
                   "base_iso": (1.0, 1e7), "max_iso": (1.0, 1e7), "min_shutter_s": (1e-9, 1e4),
                   "max_shutter_s": (1e-9, 1e4), "highlight_target": (0.0, 1.0)}
        for key, (low, high) in numbers.items():  # refused before any frame renders (issue 25 #9, #10)
            value = getattr(self, key)
            if key == "damping" and isinstance(value, (int, float)) and not isinstance(value, bool) \
                    and value == value:
                continue  # a number: its range is checked below, with why
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not low <= value <= high \
                    or (key in ("damping", "highlight_target") and value == 0):
                span = f"({low:g}, {high:g}]" if key in ("damping", "highlight_target") else f"[{low:g}, {high:g}]"
                raise ConfigError(f"[camera] {key} = {value!r}: give a number in {span}")
        if self.program not in ("program", "shutter_priority", "iso_priority"):
            raise ConfigError(f"exposure program {self.program!r}: valid: program, shutter_priority, iso_priority")
        if not 0 < self.damping <= 1:
            raise ConfigError(f"AE damping = {self.damping}: must lie in (0, 1] (1 corrects the whole error at once; "
                              "more would overshoot)")
        if not self.dead_band_ev >= 0:
            raise ConfigError(f"AE dead band = {self.dead_band_ev}: must be >= 0 EV")
        if not (0 < self.min_shutter_s <= self.max_shutter_s and 0 < self.base_iso <= self.max_iso):
            raise ConfigError("AE limits: need 0 < min_shutter_s <= max_shutter_s and 0 < base_iso <= max_iso")
        if self.mode not in ("auto", "locked"):
            raise ConfigError(f"AE mode {self.mode!r}: valid: auto, locked")

    @property
    def target(self) -> float:
        """Where the metered grey goes: :data:`MID_GREY` × 2^compensation (every mode's meter
        reads a grey-equivalent value; ``highlight`` and ``etr`` scale theirs by
        ``highlight_target``)."""
        return MID_GREY * 2.0 ** self.compensation_ev

    def split(self, ev: float) -> tuple[float, float]:
        """(time, ISO) for an exposure value by the program and its limits."""
        total = 2.0 ** ev  # time × gain, gain = ISO / base ISO
        if self.program == "iso_priority":
            time_s = min(max(total, self.min_shutter_s), self.max_shutter_s)
            return time_s, self.base_iso
        time_s = min(max(total, self.min_shutter_s), self.max_shutter_s)
        iso = min(max(total / time_s * self.base_iso, self.base_iso), self.max_iso)
        return time_s, iso

    def step(self, state: ExposureState, luminance: np.ndarray) -> ExposureState:
        """The exposure of the next frame from this frame's luminance (taken with ``state``,
        1 = saturation)."""
        metered = meter(luminance, self.metering, highlight_target=self.highlight_target)
        error = math.log2(self.target / metered) if metered > 0 else math.inf
        if self.mode == "locked" or abs(error) <= self.dead_band_ev:
            return replace(state, error_ev=error, adjusted=False)
        correction = self.damping * error if math.isfinite(error) else 4.0
        time_s, iso = self.split(state.ev(self.base_iso) + correction)
        return ExposureState(time_s, iso, error, True)

    def frames_to_settle(self, step_ev: float) -> int:
        """Frames after a brightness step of ``step_ev`` until the error lies within the dead
        band: ⌈ln(dead_band/|ΔEV|)/ln(1 − damping)⌉ (1 when damping is 1; 0 inside it)."""
        if abs(step_ev) <= self.dead_band_ev:
            return 0
        if self.damping >= 1.0:
            return 1
        return math.ceil(math.log(self.dead_band_ev / abs(step_ev)) / math.log(1.0 - self.damping))
