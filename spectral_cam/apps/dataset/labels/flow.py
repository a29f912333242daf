"""The ``flow`` label: forward optical flow over the exposure, pixels.

References
----------
.. [1] Baker, S., et al. (2011). A database and evaluation methodology for optical flow. IJCV 92, 1–31.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ....exr import write_exr_channels
from .files import stack
from .item import Item
from .registry import LABELS


@LABELS.register("flow", options=("flow",),
                 description="flow.exr: forward optical flow over the exposure, pixels (channels dx, dy; x right, "
                             "y down): where each pixel's point at mid-exposure is imaged at the exposure's end "
                             "minus at its start; meta.json holds the camera's and the object's velocities",
                 files=("flow.exr",), reader=lambda p: {"flow": stack(p, ("dx", "dy"))}, bytes_per_pixel=8.0)
def _flow(item: Item, folder: Path) -> list[Path]:
    from ....render.motion import is_object_part, motion_flow_px

    t0 = time.perf_counter()
    config, motion = item.config, item.config.motion
    moving = None
    if motion.object and any(motion.object_velocity_mps):
        index, shapes = item.shape_map
        ids = [k for k, shape in enumerate(shapes) if is_object_part(shape["name"], motion.object)]
        moving = np.isin(index, ids)
    flow = motion_flow_px(config, item.sim.lens, np.asarray(item.sim.radiance.depth_m), moving,
                          exposure_s=item.exposure_s)
    path = write_exr_channels({"dx": flow[..., 0], "dy": flow[..., 1]}, folder / "flow.exr",
                              {"spectral_cam_units": "pixels, exposure start to end; x right, y down"})
    to_opencv = np.array([-1.0, -1.0, 1.0])  # Mitsuba's camera axes (x left, y up) to OpenCV's
    item.records["flow"] = {
        "file": "flow.exr", "channels": ["dx", "dy"], "units": "px over the whole exposure, x right, y down",
        "exposure_s": item.exposure_s, "pose_of_points": "the exposure's middle (the depth label's)",
        "camera_velocity_mps_opencv": (np.asarray(motion.camera_velocity_mps) * to_opencv).tolist(),
        "camera_angular_velocity_dps": list(motion.camera_angular_velocity_dps),
        "object": motion.object or None,
        "object_velocity_mps_opencv": (np.asarray(motion.object_velocity_mps) * to_opencv).tolist(),
        "object_pixels": None if moving is None else int(moving.sum()),
        "largest_px": float(np.hypot(flow[..., 0], flow[..., 1]).max()) if flow.size else 0.0}
    item.timings["flow"] = time.perf_counter() - t0
    return [path]
