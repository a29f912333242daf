"""Motion blur by time-stratified sub-frames: the exposure is split into K equal time slices;
slice k renders the camera at its pose at the slice's middle, t_k = ((k + ½)/K − ½)·T (0 is the
exposure's middle), with 1/K of the samples, and the slices are averaged before the sensor —
the stratified estimate of the time integral ∫L(t)dt/T. Mitsuba 3 has no animated transforms,
so only the sensor moves: the scene's objects moving rigidly (``motion.object_velocity_mps``)
are the camera moving the other way.

K (``motion.subframes = "auto"``) is one sub-frame per half pixel of the largest image motion:
translation across the view |v_xy|·T/z_near·(v/p), along it |v_z|·T/z_near·r_corner, rotation
|ω_yaw,pitch|·T·(v/p) + |ω_roll|·T·r_corner (v the image distance, p the pixel pitch, r_corner
the frame's half diagonal in pixels), then rounded up to a divisor of ``render.spp`` so the
slices have equal samples.

References
----------
.. [1] Cook, R. L., Porter, T., & Carpenter, L. (1984). Distributed ray tracing. SIGGRAPH '84
   (sampling time within the shutter interval).
.. [2] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §5.1 (camera shutter and ray times).
"""

from __future__ import annotations

import math

import numpy as np

from ..optics import ThinLens
from ..scene import SceneConfig

__all__ = ["motion_blur_px", "plan_subframes", "subframe_transform"]

#: Largest image motion (px) one sub-frame stands for.
PX_PER_SUBFRAME = 0.5
MAX_AUTO_SUBFRAMES = 256


def _relative_velocity(config: SceneConfig) -> np.ndarray:
    m = config.motion
    return np.asarray(m.camera_velocity_mps, dtype=float) - np.asarray(m.object_velocity_mps, dtype=float)


def motion_blur_px(config: SceneConfig, lens: ThinLens, depth_m: np.ndarray | None) -> float:
    """Largest image motion over the exposure (px), from the nearest depth in view."""
    exposure = float(config.exposure.time_s)
    finite = depth_m[np.isfinite(depth_m)] if depth_m is not None else np.array([])
    near = float(finite.min()) if finite.size else lens.focus_distance_m
    scale = lens.image_distance_m / lens.pixel_pitch_m  # px per radian (small angles)
    corner = 0.5 * math.hypot(lens.width_px, lens.height_px)
    vx, vy, vz = _relative_velocity(config)
    yaw, pitch, roll = (math.radians(w) for w in config.motion.camera_angular_velocity_dps)
    across = math.hypot(vx, vy) * exposure / near * scale
    along = abs(vz) * exposure / near * corner
    turning = math.hypot(yaw, pitch) * exposure * scale + abs(roll) * exposure * corner
    return across + along + turning


def plan_subframes(config: SceneConfig, lens: ThinLens, depth_m: np.ndarray | None, spp: int) -> tuple[int, dict]:
    """(K, record): the number of sub-frames and the decision record for meta.json."""
    blur = motion_blur_px(config, lens, depth_m)
    asked = config.motion.subframes
    wanted = min(max(1, math.ceil(blur / PX_PER_SUBFRAME)), MAX_AUTO_SUBFRAMES) if asked == "auto" else int(asked)
    wanted = min(wanted, spp)
    count = next(k for k in range(wanted, spp + 1) if spp % k == 0)  # equal samples per slice
    reason = (f"{blur:.2f} px of motion, one sub-frame per {PX_PER_SUBFRAME} px" if asked == "auto"
              else "motion.subframes")
    return count, {"choice": count, "reason": f"{reason}, rounded up to a divisor of {spp} spp",
                   "motion_px": blur, "spp_per_subframe": spp // count}


def subframe_transform(mi, config: SceneConfig, index: int, count: int):
    """The camera's move (in its own frame) at the middle of sub-frame ``index`` of ``count``."""
    t = ((index + 0.5) / count - 0.5) * float(config.exposure.time_s)
    yaw, pitch, roll = (float(w) * t for w in config.motion.camera_angular_velocity_dps)
    offset = [float(v) for v in _relative_velocity(config) * t]
    return (mi.ScalarTransform4f().translate(offset).rotate([0, 1, 0], yaw).rotate([1, 0, 0], -pitch)
            .rotate([0, 0, 1], roll))
