"""A sequence spec: a scene file whose keys may change from frame to frame, plus ``[sequence]``
(the frames and their clock times) and ``[camera]`` (the auto-exposure and auto-white-balance
controllers).

::

    [sequence]
    frames = 13
    start_hour = 7.0          # frame k's time: start + k·(end − start)/(frames − 1), hours
    end_hour = 19.0
    [sequence.vary]           # scene keys per frame: "hour" (the frame's time) or one value per frame
    "sky.hour" = "hour"
    "illuminant.illuminance_lux" = [100, 400, ...]

    [camera]
    exposure = "auto"         # or "locked": every frame at the first frame's exposure
    metering = "average"      # average, centre_weighted, spot, highlight, etr (spectral_cam.metering)
    program = "program"       # program, shutter_priority, iso_priority
    damping = 0.5
    dead_band_ev = 0.167
    compensation_ev = 0.0
    max_shutter_s = 0.0333
    max_iso = 6400
    white_balance = "auto"    # or "locked" (the first frame's white), "manual" (wb_white)
    awb_method = "grey_world" # grey_world, white_patch, grey_edge, locus
    awb_smoothing = 0.0

References
----------
.. [1] docs/design.md, "Sequences" (the spec's keys).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ...control import AutoExposure, AutoWhiteBalance
from ...errors import ConfigError
from ...scene import SceneConfig, read_toml, scene_from_dict

__all__ = ["SequenceSpec", "CameraControl", "load_sequence", "sequence_from_dict"]

_AE_KEYS = ("metering", "program", "damping", "dead_band_ev", "compensation_ev", "max_shutter_s", "max_iso",
            "min_shutter_s", "highlight_target")
_CAMERA_KEYS = ("exposure", "white_balance", "awb_method", "awb_smoothing", "wb_white", *_AE_KEYS)


@dataclass(frozen=True)
class CameraControl:
    """The controllers a sequence's camera runs (:mod:`spectral_cam.control`)."""

    exposure: AutoExposure = field(default_factory=AutoExposure)
    white_balance: AutoWhiteBalance = field(default_factory=AutoWhiteBalance)

    @classmethod
    def from_table(cls, table: Mapping[str, Any], camera: str, base_iso: float) -> "CameraControl":
        unknown = sorted(set(table) - set(_CAMERA_KEYS))
        if unknown:
            raise ConfigError(f"[camera]: unknown key(s) {', '.join(unknown)}; valid: {', '.join(_CAMERA_KEYS)}")
        ae = AutoExposure(mode=table.get("exposure", "auto"), base_iso=base_iso,
                          **{k: table[k] for k in _AE_KEYS if k in table})
        awb = AutoWhiteBalance(method=table.get("awb_method", "grey_world"),
                               smoothing=float(table.get("awb_smoothing", 0.0)),
                               mode=table.get("white_balance", "auto"),
                               manual_white=tuple(table.get("wb_white", (1.0, 1.0, 1.0))), camera=camera)
        return cls(ae, awb)

    def to_dict(self) -> dict:
        import dataclasses

        return {"exposure": dataclasses.asdict(self.exposure), "white_balance": dataclasses.asdict(self.white_balance)}


@dataclass(frozen=True)
class SequenceSpec:
    """Frames over time.

    Attributes
    ----------
    scene : dict
        The scene tables every frame starts from.
    hours : tuple of float
        Each frame's clock time.
    vary : dict
        Scene key → ``"hour"`` or a tuple of one value per frame.
    camera : dict
        The ``[camera]`` table.
    base_dir : Path
        Folder relative paths in the scene resolve against.
    """

    scene: dict
    hours: tuple[float, ...]
    vary: dict
    camera: dict
    base_dir: Path

    def __len__(self) -> int:
        return len(self.hours)

    def frame_config(self, index: int) -> SceneConfig:
        """The scene of frame ``index``."""
        overrides = {key: self.hours[index] if value == "hour" else value[index] for key, value in self.vary.items()}
        return scene_from_dict(self.scene, overrides=overrides, base_dir=self.base_dir)

    def control(self, **changes) -> CameraControl:
        """The camera's controllers (``changes``: ``[camera]`` keys overridden, e.g. locked modes)."""
        first = self.frame_config(0)
        return CameraControl.from_table({**self.camera, **changes}, first.sensor.model, first.sensor.base_iso)


def sequence_from_dict(data: Mapping[str, Any], *, base_dir: str | Path = ".") -> SequenceSpec:
    """Build and validate a :class:`SequenceSpec` (every frame's scene is checked).

    Raises
    ------
    ConfigError
        For a missing or bad ``[sequence]``, a ``vary`` list of the wrong length, an invalid
        frame scene or ``[camera]`` key.
    """
    data = dict(data)
    table = dict(data.pop("sequence", {}) or {})
    camera = dict(data.pop("camera", {}) or {})
    frames = table.get("frames")
    if not isinstance(frames, int) or isinstance(frames, bool) or not 1 <= frames <= 10000:
        raise ConfigError(f"[sequence] frames = {frames!r}: give the number of frames, 1..10000")
    start, end = table.get("start_hour", 12.0), table.get("end_hour", table.get("start_hour", 12.0))
    for key, value in (("start_hour", start), ("end_hour", end)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= 24.0:
            raise ConfigError(f"[sequence] {key} = {value!r}: give a local clock time in hours, 0..24")
    start, end = float(start), float(end)
    hours = tuple(float(h) for h in (np.linspace(start, end, frames) if frames > 1 else [start]))
    vary = {}
    for key, value in dict(table.get("vary", {}) or {}).items():
        if value == "hour":
            vary[key] = "hour"
        elif isinstance(value, list) and len(value) == frames:
            vary[key] = tuple(value)
        else:
            raise ConfigError(f"[sequence.vary] {key} = {value!r}: give \"hour\" (the frame's time) or a list of "
                              f"{frames} values, one per frame")
    extra = sorted(set(table) - {"frames", "start_hour", "end_hour", "vary"})
    if extra:
        raise ConfigError(f"[sequence]: unknown key(s) {', '.join(extra)}; valid: frames, start_hour, end_hour, vary")
    spec = SequenceSpec(data, hours, vary, camera, Path(base_dir))
    for index in range(frames):
        spec.frame_config(index)  # every frame's scene is valid before anything renders
    spec.control()
    return spec


def load_sequence(path: str | Path) -> SequenceSpec:
    """Read a sequence spec (TOML)."""
    path = Path(path)
    return sequence_from_dict(read_toml(path, "sequence spec"), base_dir=path.parent)
