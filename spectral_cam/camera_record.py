"""``camera.json``: the camera of a capture as 3-D vision tools take it: intrinsics K, distortion,
pose (world → camera) in OpenCV's and OpenGL's axis conventions, focus, aperture and exposure.

Conventions (written into the file too):

- pixels of the frame (after the sensor's crop margin), pixel centres at integer coordinates,
  (0, 0) the top-left pixel's centre: fx = fy = v / p (v the image distance at the focus
  distance, p the pixel pitch), cx = W/2 − ½, cy = H/2 − ½;
- OpenCV camera axes: +x right, +y down, +z forward (the view); OpenGL: +x right, +y up, +z
  backward. Mitsuba's camera frame (``look_at``) has +x to the image's left, +y up, +z forward;
- distortion (k1, k2, p1, p2, k3) in OpenCV's Brown–Conrady convention
  (:mod:`spectral_cam.optics.distortion`): zero for the ideal thin lens and the pinhole.

References
----------
.. [1] OpenCV, "Camera calibration and 3D reconstruction" (pinhole model, ``projectPoints``,
   distortion coefficients k1, k2, p1, p2, k3).
.. [2] Hartley, R., & Zisserman, A. (2004). Multiple View Geometry, 2nd ed., §6.1 (K, [R | t]).
.. [3] Jakob, W., et al. (2022). Mitsuba 3, ``look_at`` (camera frame: +x left, +y up, +z view).
"""

from __future__ import annotations

import numpy as np

from .optics import ThinLens

__all__ = ["camera_record", "capture_camera_record", "illuminant_record", "intrinsics_matrix", "MITSUBA_TO_OPENCV", "MITSUBA_TO_OPENGL"]

#: Camera-frame axes of OpenCV from Mitsuba's (x left → right, y up → down, z forward kept).
MITSUBA_TO_OPENCV = np.diag([-1.0, -1.0, 1.0, 1.0])
#: Camera-frame axes of OpenGL from Mitsuba's (x left → right, y up kept, z forward → backward).
MITSUBA_TO_OPENGL = np.diag([-1.0, 1.0, -1.0, 1.0])


def intrinsics_matrix(lens: ThinLens, focal_length_m: float | None = None) -> np.ndarray:
    """K (3 × 3) of the frame's lens in pixels, pixel centres at integers: fx = fy = v/p (or
    ``focal_length_m``/p: a prescription's traced scale), (cx, cy) = (W/2 − ½, H/2 − ½)."""
    frame = lens.layout_lens
    focal_px = (frame.image_distance_m if focal_length_m is None else focal_length_m) / frame.pixel_pitch_m
    return np.array([[focal_px, 0.0, frame.width_px / 2 - 0.5],
                     [0.0, focal_px, frame.height_px / 2 - 0.5],
                     [0.0, 0.0, 1.0]])


def camera_record(lens: ThinLens, camera_to_world, *, distortion=(0.0, 0.0, 0.0, 0.0, 0.0),
                  lens_model: str = "thin", exposure_s: float | None = None, iso: float | None = None,
                  fitted: dict | None = None, intrinsics: dict | None = None) -> dict:
    """The content of ``camera.json``.

    Parameters
    ----------
    lens
        The frame's lens (the crop margin is not part of the frame).
    camera_to_world
        4 × 4 Mitsuba camera-to-world transform of the render (``meta["camera_to_world"]``).
    distortion
        (k1, k2, p1, p2, k3), OpenCV's convention.
    lens_model
        The lens model the render used.
    fitted
        A prescription's fit (:meth:`spectral_cam.optics.prescription.Prescription.opencv_distortion`):
        its traced focal scale sets K, its coefficients the distortion, its residual (in pixels)
        is recorded.
    intrinsics
        A lens model's own optics (its entry's ``intrinsics``,
        :data:`spectral_cam.render.lens_models.LENS_MODELS`): ``focal_length_m`` (None: the image
        distance) sets K; ``coefficients``, ``source`` and ``residual_m`` the distortion. Overrides
        ``distortion`` and ``fitted``.
    exposure_s, iso
        The exposure the sensor used.

    Returns
    -------
    dict
        ``K``, ``image_size`` [W, H], ``distortion``, ``world_to_camera_opencv`` and
        ``world_to_camera_opengl`` (4 × 4), ``camera_to_world_opencv``, ``conventions`` and the
        optics (focal length, f-number, aperture, focus distance, pixel pitch, exposure).
    """
    frame = lens.layout_lens
    optics = intrinsics if intrinsics is not None else _given_optics(distortion, fitted)
    to_world = np.asarray(camera_to_world, dtype=np.float64).reshape(4, 4)
    world_to_mitsuba = np.linalg.inv(to_world)
    opencv = MITSUBA_TO_OPENCV @ world_to_mitsuba
    opengl = MITSUBA_TO_OPENGL @ world_to_mitsuba
    return {
        "K": intrinsics_matrix(frame, optics["focal_length_m"]).tolist(),
        "image_size": [int(frame.width_px), int(frame.height_px)],
        "distortion": [float(c) for c in optics["coefficients"]],
        "distortion_model": "opencv (k1, k2, p1, p2, k3)",
        "distortion_source": optics["source"],
        "distortion_residual_px": None if optics["residual_m"] is None else optics["residual_m"] / frame.pixel_pitch_m,
        "world_to_camera_opencv": opencv.tolist(),
        "world_to_camera_opengl": opengl.tolist(),
        "camera_to_world_opencv": np.linalg.inv(opencv).tolist(),
        "conventions": {
            "pixels": "frame pixels (crop margin excluded); pixel centres at integers, (0, 0) the top-left centre",
            "opencv": "+x right, +y down, +z forward",
            "opengl": "+x right, +y up, +z backward",
            "world": "the scene's (Mitsuba) world frame, metres"},
        "lens_model": lens_model,
        "focal_length_mm": frame.focal_length_m * 1e3,
        "image_distance_mm": frame.image_distance_m * 1e3,
        "f_number": frame.f_number,
        "aperture_diameter_mm": 2e3 * frame.aperture_radius_m,
        "focus_distance_m": frame.focus_distance_m,
        "pixel_pitch_um": frame.pixel_pitch_m * 1e6,
        "exposure_s": exposure_s,
        "iso": iso,
    }


def _given_optics(distortion, fitted: dict | None) -> dict:
    """:func:`camera_record`'s ``intrinsics`` from its ``distortion`` or a prescription's ``fitted``."""
    if fitted is None:
        return {"focal_length_m": None, "coefficients": distortion, "residual_m": None,
                "source": "the configured lens.distortion (exact: the renderer applies this model)"}
    return {"focal_length_m": fitted["focal_length_m"], "coefficients": fitted["coefficients"],
            "residual_m": fitted["residual_m"],
            "source": "fitted to the prescription's chief rays (least squares over the field to the sensor's corner)"}


def capture_camera_record(radiance, config, raw) -> dict | None:
    """:func:`camera_record` of a capture: the rendered image's lens and pose
    (``meta["camera_to_world"]``), the config's distortion, the RAW's exposure. None for an
    image rendered before poses were recorded."""
    if "camera_to_world" not in radiance.meta:
        return None
    from .render.lens_models import LENS_MODELS

    lens_model = radiance.meta.get("lens_model", config.lens.model)
    # the model's own optics: its focal scale and distortion (a prescription's fitted to its rays)
    optics = LENS_MODELS[lens_model].intrinsics(config, radiance.lens.layout_lens)
    record = camera_record(radiance.lens, radiance.meta["camera_to_world"], lens_model=lens_model,
                           exposure_s=raw.meta.get("exposure_s"), iso=raw.meta.get("iso"), intrinsics=optics)
    motion = config.motion
    record["pose_time"] = "the exposure's middle (a moving camera's motion blur spans ±exposure/2 about it)"
    if motion.moving:
        from .render.motion import relative_velocity

        flip = np.array([-1.0, -1.0, 1.0])  # the camera's own axes (x image-left, y up) to OpenCV's
        record["motion"] = {
            "velocity_mps_opencv": (relative_velocity(config) * flip).tolist(),
            "angular_velocity_dps": list(motion.camera_angular_velocity_dps),
            "angular_axes": "yaw about the camera's up, pitch about its left (> 0 tilts up), roll about the view",
            "object": motion.object or None,
            "object_velocity_mps_opencv": (np.asarray(motion.object_velocity_mps, dtype=float) * flip).tolist()
            if motion.object else None}
    return record


def illuminant_record(spd: str, neutral, *, sensor_model: str, emitter: str = "",
                      illuminance_lux: float | None = None) -> dict:
    """The content of ``illuminant.json``: the scene light's ground truth as colour-constancy
    datasets publish it (NUS 8-camera, Gehler–Shi, Cube+: the light's camera RGB).

    Parameters
    ----------
    spd
        The light (``illuminant.spd`` resolved: a name, ``blackbody:<K>``, or a CSV).
    neutral
        The camera's response to the light's white (the RAW's AsShotNeutral: the measured curves,
        lens transmission and IR cut integrated against the SPD), any scale.
    sensor_model, emitter, illuminance_lux
        Recorded as given.

    Returns
    -------
    dict
        ``camera_rgb`` (max 1), ``camera_rgb_g1`` (green 1), ``camera_rgb_unit`` (unit length),
        ``xy`` (CIE 1931 2°), ``cct_k`` and ``duv`` (Robertson 1968, CIE 1960 uv).

    References
    ----------
    .. [1] Cheng, D., Prasad, D. K., & Brown, M. S. (2014). Illuminant estimation for colour
       constancy: why spatial-domain methods work and the role of the colour distribution.
       JOSA A 31(5) (NUS 8-camera: ground truth as the light's camera RGB).
    .. [2] Robertson, A. R. (1968). Computation of correlated color temperature and distribution
       temperature. JOSA 58(11), 1528–1535.
    """
    from .cie import cct_robertson1968, xy_to_uv_1960, xyz_to_xy
    from .colour_ground_truth import illuminant_white_xyz

    rgb = np.asarray(neutral, dtype=float)
    xy = xyz_to_xy(illuminant_white_xyz(spd))
    # Robertson's isotemperature lines: Ohno's method builds a Planckian table of 55 MB for a
    # 0.6 K difference at D65
    cct, duv = cct_robertson1968(xy_to_uv_1960(xy))
    return {"spd": spd, "emitter": emitter or None, "illuminance_lux": illuminance_lux, "sensor_model": sensor_model,
            "camera_rgb": (rgb / rgb.max()).tolist(), "camera_rgb_g1": (rgb / rgb[1]).tolist(),
            "camera_rgb_unit": (rgb / np.linalg.norm(rgb)).tolist(), "xy": [float(v) for v in xy],
            "cct_k": float(cct), "duv": float(duv),
            "conventions": {"camera_rgb": "raw camera channels R, G, B (the mosaic's colours, black-subtracted, "
                                          "linear) of a perfect white diffuser under the light",
                            "xy": "CIE 1931 2° chromaticity of the light", "cct": "Robertson 1968 on CIE 1960 uv"}}
