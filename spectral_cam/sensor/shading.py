"""Pixel angular response: lens shading and colour shading from the chief-ray angle.

A pixel's microlens and stack accept light best at normal incidence; off axis the chief ray
arrives at the chief-ray angle (CRA) θ and the pixel collects a fraction A_c(θ) of it, smaller for
the channels whose light spreads more into the neighbours. Over the frame this is lens shading
(luminance falling towards the corners, on top of the cos⁴ law) and colour shading (the corners'
tint where the channels' responses differ), which a phone ISP corrects from a flat-field
calibration (:mod:`spectral_cam.isp.shading`).

The acceptance is the stated one: A_c(θ) = 2^(−(θ/θ½,c)²), a Gaussian in angle falling to half at
θ½,c (``sensor.angular_response_deg``: one θ½, or one per channel R, G, B).

The CRA at image height r: through the thin lens's centre, θ = atan(r / v) (v the image distance,
the angle of the cos⁴ law); behind a prescription, the angle of the real chief ray (through the
entrance pupil's centre) traced to height r, interpolated over 64 fields.

References
----------
.. [1] Catrysse, P. B., & Wandell, B. A. (2002). Optical efficiency of image sensor pixels. JOSA A
   19(8), 1610–1620 (pixel acceptance against incidence angle).
.. [2] Catrysse, P. B., Liu, X., & El Gamal, A. (2000). QE reduction due to pixel vignetting in
   CMOS image sensors. Proc. SPIE 3965 (pixel vignetting, colour shading).
.. [3] Smith, W. J. (2008). Modern Optical Engineering, 4th ed., §6 (chief ray, exit pupil).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["parse_angular_response", "acceptance", "chief_ray_angles_deg", "channel_gains"]


def parse_angular_response(value, channels: int = 3) -> tuple[float, ...] | None:
    """``sensor.angular_response_deg`` as θ½ per channel (degrees), or None for "off"."""
    if isinstance(value, str) and value.strip().lower() == "off":
        return None
    values = list(value) if isinstance(value, (list, tuple)) else [value]
    if not values or any(isinstance(v, bool) or not isinstance(v, (int, float)) or not (0 < v <= 90)
                         for v in values) or len(values) not in (1, 3):
        raise ConfigError(f"sensor.angular_response_deg = {value!r}; valid: 'off', or the angle of half response "
                          "in degrees (0 < θ½ <= 90), one for every channel or three (R, G, B), e.g. [18, 20, 22]")
    halves = tuple(float(v) for v in values) * (channels if len(values) == 1 else 1)
    if channels == 4 and len(halves) == 3:  # RGBW: the white pixels take green's acceptance
        halves += (halves[1],)
    return halves


def acceptance(theta_deg, half_deg: float) -> np.ndarray:
    """A(θ) = 2^(−(θ/θ½)²): 1 on axis, ½ at θ½."""
    return np.exp2(-(np.asarray(theta_deg, dtype=float) / half_deg) ** 2)


def _radius_m(lens) -> np.ndarray:
    pitch = lens.pixel_pitch_m
    x = (np.arange(lens.width_px) + 0.5 - lens.width_px / 2) * pitch
    y = (np.arange(lens.height_px) + 0.5 - lens.height_px / 2) * pitch
    return np.hypot(x[None, :], y[:, None])


def chief_ray_angles_deg(lens, *, prescription: str | None = None) -> np.ndarray:
    """(H, W) chief-ray angle of every pixel centre (degrees) for the render's lens: the thin lens
    through its centre, or, given a ``prescription`` (a bundled lens or a CSV), its real chief rays
    with the sensor where ``lens`` focuses."""
    radius = _radius_m(lens)
    if prescription is not None:
        heights, angles = _traced_chief_rays(prescription, float(lens.focus_distance_m), float(radius.max()))
        return np.interp(radius, heights, angles)
    return np.degrees(np.arctan(radius / lens.image_distance_m))


def _traced_chief_rays(name: str, focus_distance_m: float, max_height_m: float, samples: int = 64):
    """(image heights, chief-ray angles in degrees) of a prescription's real chief rays (through the
    entrance pupil's centre, traced to the sensor), from the axis out past ``max_height_m``: the exit
    pupil's paraxial position misses by 1° at a 20° field of the double Gauss (pupil aberration)."""
    from ..optics.prescription import load_prescription

    prescription = load_prescription(name)
    back = prescription.sensor_distance_m(focus_distance_m)
    pupil_z, _ = prescription.entrance_pupil()
    top = prescription.field_of_view_deg(max_height_m * 1.02, back) / 2.0
    fields = np.radians(np.linspace(0.0, max(top, 1e-3), samples))
    directions = np.stack([np.zeros_like(fields), np.sin(fields), np.cos(fields)], axis=1)
    origins = np.array([0.0, 0.0, pupil_z]) - directions * (pupil_z + 1.0)
    o, d, passed = prescription.trace(origins, directions)
    plane = prescription.vertices_m()[-1] + back
    heights = np.abs(o[:, 1] + (plane - o[:, 2]) / d[:, 2] * d[:, 1])
    angles = np.degrees(np.arctan(np.abs(d[:, 1]) / d[:, 2]))
    keep = passed & np.isfinite(heights)
    if keep.sum() < 2:
        raise ConfigError(f"{name}: no chief ray reaches the sensor; the chief-ray angle is undefined")
    order = np.argsort(heights[keep])
    return heights[keep][order], angles[keep][order]


def channel_gains(lens, halves, *, prescription: str | None = None) -> np.ndarray:
    """(H, W, C) float32 acceptance of every pixel for each channel's half-response angle in ``halves``
    (:func:`parse_angular_response`), at the chief-ray angle of :func:`chief_ray_angles_deg`."""
    theta = chief_ray_angles_deg(lens, prescription=prescription)
    return np.stack([acceptance(theta, half) for half in halves], axis=-1).astype(np.float32)
