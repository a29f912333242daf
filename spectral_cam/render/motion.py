"""Motion blur by time-stratified sub-frames: the exposure is split into K equal time slices;
slice k renders the camera at its pose at the slice's middle, t_k = ((k + ½)/K − ½)·T (0 is the
exposure's middle), with 1/K of the samples, and the slices are averaged before the sensor —
the stratified estimate of the time integral ∫L(t)dt/T. Mitsuba 3 has no animated transforms,
so each slice moves the sensor, and a named object (``motion.object``) by updating its
``to_world`` (spheres, rectangles, discs, cylinders) or its vertices (meshes) through
``mi.traverse``; with no object named, ``motion.object_velocity_mps`` moves the whole scene
rigidly, which is the camera moving the other way.

A rolling shutter (``sensor.shutter = "rolling"``) exposes row r over [r·t_row, r·t_row + T]: the
sub-frames then span the whole readout, S = T + (H − 1)·t_row (t = 0 its middle, the middle row's
exposure middle), and each row averages the sub-frames inside its own window, each weighted by its
overlap with it (:func:`rolling_row_weights`): a vertical edge moving across the frame shears by
v·t_row·H·m/p pixels. Each row then gets T/S of the samples.

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

__all__ = ["motion_blur_px", "plan_subframes", "subframe_transform", "ObjectMotion", "camera_move_matrix",
           "relative_velocity", "motion_flow_px", "pose_flow_px", "is_object_part", "exposure_span_s",
           "subframe_time_s", "rolling_row_weights", "is_rolling"]

#: Largest image motion (px) one sub-frame stands for.
PX_PER_SUBFRAME = 0.5
MAX_AUTO_SUBFRAMES = 256


def relative_velocity(config: SceneConfig) -> np.ndarray:
    """The camera's velocity relative to the scene (the whole scene's motion folded in when no
    single object moves)."""
    m = config.motion
    camera = np.asarray(m.camera_velocity_mps, dtype=float)
    return camera if m.object else camera - np.asarray(m.object_velocity_mps, dtype=float)


def motion_blur_px(config: SceneConfig, lens: ThinLens, depth_m: np.ndarray | None) -> float:
    """Largest image motion over the exposure (px), from the nearest depth in view."""
    exposure = float(config.exposure.time_s)
    finite = depth_m[np.isfinite(depth_m)] if depth_m is not None else np.array([])
    near = float(finite.min()) if finite.size else lens.focus_distance_m
    scale = lens.image_distance_m / lens.pixel_pitch_m  # px per radian (small angles)
    corner = 0.5 * math.hypot(lens.width_px, lens.height_px)
    vx, vy, vz = relative_velocity(config)
    yaw, pitch, roll = (math.radians(w) for w in config.motion.camera_angular_velocity_dps)
    if config.motion.object:  # the object's own motion, over the camera's
        ox, oy, oz = config.motion.object_velocity_mps
        vx, vy, vz = abs(vx) + abs(ox), abs(vy) + abs(oy), abs(vz) + abs(oz)
    across = math.hypot(vx, vy) * exposure / near * scale
    along = abs(vz) * exposure / near * corner
    turning = math.hypot(yaw, pitch) * exposure * scale + abs(roll) * exposure * corner
    return across + along + turning


#: Sub-frames at least in each row's exposure window under a rolling shutter.
MIN_SUBFRAMES_PER_ROW = 4


def is_rolling(config: SceneConfig) -> bool:
    """Whether the sensor reads row by row (``sensor.shutter = "rolling"``)."""
    return getattr(config.sensor, "shutter", "global") == "rolling"


def exposure_span_s(config: SceneConfig, rows: int) -> float:
    """From the first row's exposure start to the last row's end (s): T for a global shutter,
    T + (rows − 1)·t_row for a rolling one."""
    exposure = float(config.exposure.time_s)
    return exposure + (rows - 1) * float(config.sensor.row_time_s) if is_rolling(config) else exposure


def subframe_time_s(config: SceneConfig, index: int, count: int, span_s: float | None = None) -> float:
    """The middle of sub-frame ``index`` of ``count`` (s from the span's middle), delayed by
    ``exposure.start_s`` (a frame of a longer capture: an event sensor's frames are renders at
    successive start times)."""
    span = float(config.exposure.time_s) if span_s is None else span_s
    return float(getattr(config.exposure, "start_s", 0.0)) + ((index + 0.5) / count - 0.5) * span


def rolling_row_weights(config: SceneConfig, rows: int, first: int, last: int, index: int, count: int) -> np.ndarray:
    """(last − first,) weight of sub-frame ``index`` in rows ``first``..``last`` − 1 of a rolling-shutter
    frame of ``rows`` rows: the sub-frame's overlap with each row's exposure window over T, times
    ``count`` (the sub-frames are averaged with equal samples, so the weights of a row sum to count)."""
    exposure, span = float(config.exposure.time_s), exposure_span_s(config, rows)
    width = span / count
    centre = subframe_time_s(config, index, count, span)
    start = np.arange(first, last, dtype=np.float64) * float(config.sensor.row_time_s) - span / 2.0
    overlap = np.clip(np.minimum(centre + width / 2, start + exposure) - np.maximum(centre - width / 2, start), 0, None)
    return (overlap / exposure * count).astype(np.float32)


def plan_subframes(config: SceneConfig, lens: ThinLens, depth_m: np.ndarray | None, spp: int) -> tuple[int, dict]:
    """(K, record): the number of sub-frames and the decision record for meta.json.

    ``motion.subframes = "auto"``: one sub-frame per :data:`PX_PER_SUBFRAME` px of motion (at most
    :data:`MAX_AUTO_SUBFRAMES`); under a rolling shutter at least :data:`MIN_SUBFRAMES_PER_ROW` (and the
    motion's count) in each row's window T, so K ≥ that × S/T over the readout span S — the readout sets
    K, whatever the motion cap. K is rounded up to a divisor of ``spp`` (equal samples a sub-frame); a
    global shutter whose motion asks more than ``spp`` gets ``spp`` (and says so), a rolling shutter that
    needs more than ``spp`` is refused with what it needs. The record states the sub-frames each row's
    window holds, K·T/S, as they are.

    Raises
    ------
    ConfigError
        A rolling shutter whose readout needs more sub-frames than ``render.spp`` (or 4096) allows.
    """
    from ..errors import ConfigError

    blur = motion_blur_px(config, lens, depth_m)
    asked = config.motion.subframes
    exposure = float(config.exposure.time_s)
    span = exposure_span_s(config, lens.height_px)
    per_window = max(1, math.ceil(blur / PX_PER_SUBFRAME))
    if asked == "auto" and is_rolling(config):  # enough in every row's own window, which is T of the span S
        needed = math.ceil(max(min(per_window, MAX_AUTO_SUBFRAMES), MIN_SUBFRAMES_PER_ROW) * span / exposure
                           - 1e-9)
        if needed > min(spp, 4096):
            spp_key = "render.max_spp" if config.render.spp == "auto" else "render.spp"
            raise ConfigError(
                f"the rolling shutter's readout spans {span * 1e3:.4g} ms (sensor.row_time_s = "
                f"{config.sensor.row_time_s:g} s over {lens.height_px} rows) around a {exposure * 1e3:.4g} ms "
                f"exposure: {MIN_SUBFRAMES_PER_ROW} sub-frames in each row's window need {needed} over the span, and "
                f"{spp_key} = {spp} allows at most {spp} (one sample each); "
                + (f"give {spp_key} ≥ {needed}, " if needed <= 4096 else "")
                + "or a longer exposure.time_s, a shorter sensor.row_time_s, fewer rows, or motion.subframes "
                  "(fewer, stated as such in meta.json)")
        wanted = needed
    else:
        wanted = min(per_window, MAX_AUTO_SUBFRAMES) if asked == "auto" else int(asked)
    capped = wanted > spp
    wanted = min(wanted, spp)
    count = next(k for k in range(wanted, spp + 1) if spp % k == 0)  # equal samples per slice
    if asked == "auto":
        reason = f"{blur:.2f} px of motion, one sub-frame per {PX_PER_SUBFRAME} px"
    else:
        reason = "motion.subframes"
    if capped:
        reason += f", capped at render.spp = {spp} (one sample each: {blur / count:.3g} px a sub-frame)"
    record = {"choice": count, "motion_px": blur, "spp_per_subframe": spp // count}
    if is_rolling(config):
        in_window = count * exposure / span
        reason += (f", {count} over the rolling shutter's {span * 1e3:.3g} ms span: {in_window:.3g} in each row's "
                   f"{exposure * 1e3:.3g} ms window")
        if asked == "auto":
            reason += f" (at least {MIN_SUBFRAMES_PER_ROW})"
        record["subframes_per_row_window"] = in_window
    record["reason"] = f"{reason}, rounded up to a divisor of {spp} spp"
    return count, {"choice": record.pop("choice"), "reason": record.pop("reason"), **record}


def subframe_transform(mi, config: SceneConfig, index: int, count: int, span_s: float | None = None):
    """The camera's move (in its own frame) at the middle of sub-frame ``index`` of ``count`` (over
    ``span_s``, default the exposure time)."""
    t = subframe_time_s(config, index, count, span_s)
    yaw, pitch, roll = (float(w) * t for w in config.motion.camera_angular_velocity_dps)
    offset = [float(v) for v in relative_velocity(config) * t]
    return (mi.ScalarTransform4f().translate(offset).rotate([0, 1, 0], yaw).rotate([1, 0, 0], -pitch)
            .rotate([0, 0, 1], roll))


def is_object_part(shape: str, name: str) -> bool:
    """Whether ``shape`` is ``motion.object`` = ``name`` or one of its parts (``<name>_*``)."""
    return shape == name or shape.startswith(name + "_")


def _rotation(axis, degrees: float) -> np.ndarray:
    """4 × 4 right-handed rotation about a unit axis (Rodrigues), as Mitsuba's ``rotate``."""
    x, y, z = axis
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    out = np.eye(4)
    out[:3, :3] = np.eye(3) + s * k + (1.0 - c) * (k @ k)
    return out


def camera_move_matrix(config: SceneConfig, t: float) -> np.ndarray:
    """:func:`subframe_transform` at time ``t`` (s from the exposure's middle) as a NumPy 4 × 4
    in the camera's own frame (Mitsuba's axes)."""
    yaw, pitch, roll = (float(w) * t for w in config.motion.camera_angular_velocity_dps)
    move = np.eye(4)
    move[:3, 3] = relative_velocity(config) * t
    return move @ _rotation((0, 1, 0), yaw) @ _rotation((1, 0, 0), -pitch) @ _rotation((0, 0, 1), roll)


def motion_flow_px(config: SceneConfig, lens: ThinLens, depth_m: np.ndarray, moving: np.ndarray | None = None,
                   *, exposure_s: float | None = None) -> np.ndarray:
    """Forward optical flow over the exposure (px): where the point seen at each pixel centre at
    the exposure's middle is imaged at the exposure's end, minus where it was at its start.

    The point is the pixel's ray at its depth (``depth_m``, camera-space z at the middle; a
    point at infinity moves with the rotation only); its camera-space position at time t is
    M(t)⁻¹·(P + v_o·t), M(t) the camera's move (:func:`camera_move_matrix`), v_o the object's
    velocity where ``moving`` marks the pixels of ``motion.object`` (zero elsewhere: the world is
    static). Projected through the frame's pinhole (fx = v/p, pixel centres at integers). A
    camera translating across the view at v past a plane at z moves its image by v·T·(v_img/z)/p.
    T is ``exposure_s`` (default ``exposure.time_s``; a scene without motion has no flow, whatever
    its exposure).

    Returns
    -------
    numpy.ndarray
        (H, W, 2) float32: (dx, dy) in pixels, x to the image's right, y down (OpenCV's).

    References
    ----------
    .. [1] Baker, S., et al. (2011). A database and evaluation methodology for optical flow.
       IJCV 92(1), 1–31 (forward flow, pixels).
    """
    frame = lens.layout_lens
    height, width = depth_m.shape
    if not config.motion.moving:
        return np.zeros((height, width, 2), np.float32)
    focal = frame.image_distance_m / frame.pixel_pitch_m
    cx, cy = frame.width_px / 2 - 0.5, frame.height_px / 2 - 0.5
    columns, rows = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
    depth = np.where(np.isfinite(depth_m), depth_m, 1e9).astype(np.float64)  # infinity: rotation only
    # Mitsuba's camera axes: +x image-left, +y up, +z the view
    points = np.stack([-(columns - cx) / focal * depth, -(rows - cy) / focal * depth, depth, np.ones_like(depth)],
                      axis=-1)
    half = 0.5 * float(config.exposure.time_s if exposure_s is None else exposure_s)
    object_velocity = np.asarray(config.motion.object_velocity_mps, dtype=float) if config.motion.object else np.zeros(3)
    if moving is None:
        moving = np.zeros(depth.shape, dtype=bool)

    def image_at(t: float) -> np.ndarray:
        shifted = points.copy()
        shifted[moving, :3] += object_velocity * t
        seen = shifted @ np.linalg.inv(camera_move_matrix(config, t)).T
        return np.stack([cx - focal * seen[..., 0] / seen[..., 2], cy - focal * seen[..., 1] / seen[..., 2]], axis=-1)

    return (image_at(half) - image_at(-half)).astype(np.float32)


def pose_flow_px(depth_m: np.ndarray, camera_from, camera_to) -> np.ndarray:
    """Forward optical flow (px) between two views of a static world: where the point seen at
    each pixel of the first view is imaged in the second, minus its pixel.

    Each view is a ``camera.json`` record (:func:`spectral_cam.camera_record.camera_record`):
    ``K`` and ``world_to_camera_opencv``. The point is the pixel's ray at its depth (``depth_m``:
    camera-space z of the first view; a point at infinity moves with the rotation only). A point
    behind the second camera gets NaN. A sequence's frames k → k+1 (the camera moved, zoomed or
    turned between them; objects that move between frames are not followed).

    Returns
    -------
    numpy.ndarray
        (H, W, 2) float32: (dx, dy) in pixels of the second view, x right, y down.

    References
    ----------
    .. [1] Baker, S., et al. (2011). A database and evaluation methodology for optical flow.
       IJCV 92(1), 1–31 (forward flow, pixels).
    .. [2] Hartley, R., & Zisserman, A. (2004). Multiple View Geometry, 2nd ed., §6.1 (the
       projective camera x = K[R | t]X).
    """
    k_a, k_b = (np.asarray(c["K"], dtype=np.float64) for c in (camera_from, camera_to))
    w2c_a, w2c_b = (np.asarray(c["world_to_camera_opencv"], dtype=np.float64) for c in (camera_from, camera_to))
    height, width = depth_m.shape
    columns, rows = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
    rays = np.stack([columns, rows, np.ones_like(columns)], axis=-1) @ np.linalg.inv(k_a).T  # z = 1
    finite = np.isfinite(depth_m)
    depth = np.where(finite, depth_m, 1.0).astype(np.float64)
    points = np.concatenate([rays * depth[..., None], finite[..., None].astype(np.float64)], axis=-1)  # w = 0: a direction
    seen = points @ (w2c_b @ np.linalg.inv(w2c_a)).T
    with np.errstate(invalid="ignore", divide="ignore"):
        pixels = seen[..., :3] @ k_b.T
        uv = pixels[..., :2] / pixels[..., 2:3]
    uv[seen[..., 2] <= 0] = np.nan
    return (uv - np.stack([columns, rows], axis=-1)).astype(np.float32)


class ObjectMotion:
    """Moves the shape ``motion.object`` (and its parts ``<name>_*``) of a loaded scene to its place
    at each sub-frame's time, and back when done: ``to_world`` parameters are translated, mesh
    vertices offset, by the velocity (camera frame, turned into the world by the sensor's pose) ×
    the sub-frame's time."""

    def __init__(self, mi, scene, sensor, config: SceneConfig):
        from ..errors import ConfigError

        self.mi, self.config = mi, config
        self.params = mi.traverse(scene)
        name = config.motion.object
        owners = {key.rsplit(".", 1)[0] for key in self.params.keys()
                  if key.endswith((".to_world", ".vertex_positions"))}
        moving = sorted(o for o in owners if is_object_part(o, name))
        if not moving:
            listed = ", ".join(sorted(owners)[:30])
            raise ConfigError(f"motion.object = {name!r} is no movable shape of the scene (shapes with a "
                              f"to_world or vertices: {listed})")
        self.keys = [f"{o}.to_world" if f"{o}.to_world" in self.params else f"{o}.vertex_positions" for o in moving]
        # a translated mesh keeps its normals: given back with the vertices, or Mitsuba recomputes them
        # with a scatter-add whose order follows its threads (issue 39 #17: last bits move under load)
        self.normals = [f"{k[:-len('.vertex_positions')]}.vertex_normals" for k in self.keys
                        if k.endswith(".vertex_positions")]
        self.normals = [k for k in self.normals if k in self.params and len(self.params[k]) > 0]
        self.original = {k: type(self.params[k])(self.params[k]) for k in self.keys}
        # as NumPy: handed back as a new buffer each time (the same buffer would not mark the key changed)
        self.original_normals = {k: np.array(self.params[k], dtype=np.float32) for k in self.normals}
        pose = np.asarray(sensor.world_transform().matrix, dtype=np.float64).reshape(4, 4, -1)[..., 0]
        self.velocity = pose[:3, :3] @ np.asarray(config.motion.object_velocity_mps, dtype=float)

    def place(self, index: int, count: int, span_s: float | None = None) -> None:
        t = subframe_time_s(self.config, index, count, span_s)
        offset = self.velocity * t
        for key in self.keys:
            if key.endswith(".to_world"):
                self.params[key] = type(self.original[key])().translate([float(v) for v in offset]) @ \
                    self.original[key]
            else:
                vertices = np.asarray(self.original[key], dtype=np.float64).reshape(-1, 3) + offset
                self.params[key] = self.mi.Float(vertices.astype(np.float32).ravel())
        for key, normals in self.original_normals.items():
            self.params[key] = type(self.params[key])(normals)
        self.params.update()

    def restore(self) -> None:
        for key, value in self.original.items():
            self.params[key] = value
        self.params.update()
