"""A Mitsuba camera through a thin lens with what real lenses add: dispersion (each ray carries
its own wavelength and is refracted with the focal length the lens has at that wavelength), an
aperture of n straight blades, and Brown–Conrady distortion.

The sensor stays where the lens focuses ``focus_distance`` at the d line (587.56 nm). A ray of
wavelength λ leaves a point on the aperture disc towards the point of the chief ray (through
the lens centre, undeviated) on the plane that the lens focuses at λ, z_λ = f(λ)·v/(v − f(λ)):
every ray from one sensor point then meets at that point's conjugate, as a thin lens of focal
length f(λ) makes them. Blue (shorter f) focuses behind the d-line plane in object space, red in
front; the sensor sees the longitudinal chromatic aberration of the lens's glass. With the stop at
the lens the chief ray does not depend on λ, so a thin lens has no lateral colour.

A ray can carry one wavelength only, so the three secondary wavelengths Mitsuba samples with
each ray are terminated (their weight moved to the first, ×4 — unbiased, as pbrt-v4 does at a
dispersive interface); an ``"ideal"`` glass does not disperse and keeps all four.

Aperture blades: a regular n-gon inscribed in the circle of radius f/(2N), one vertex at
``blade_rotation`` from camera +y (up) towards +x (image-left); rays are drawn uniformly over
it (a triangle of the fan, then uniformly inside it) and weighted by its area over the circle's,
so the image is as bright as the opening's area, not its outer radius, while the sensor's
camera equation keeps the nominal f-number. Rounded blades (``blade_rounding`` ρ) blend the
polygon's boundary with the circle, r(φ) = (1 − ρ)·r_gon(φ) + ρ; rays take an angle with
density ∝ r(φ)² (2048 tabulated bins) and a radius r(φ)·√u, uniform over the opening.

Distortion (Brown–Conrady, OpenCV's convention: normalised coordinates x = X/Z to the image's
right, y = Y/Z down): a film point is the distorted image of the chief ray through the
undistorted point (x_u, y_u), x_d = x_u(1 + k₁r² + k₂r⁴ + k₃r⁶) + 2p₁x_u y_u + p₂(r² + 2x_u²),
y_d = y_u(1 + k₁r² + k₂r⁴ + k₃r⁶) + p₁(r² + 2y_u²) + 2p₂x_u y_u; the plugin inverts it by fixed-
point iteration (20 steps, far below a pixel for |k₁| ≤ 0.3 in the frame).

References
----------
.. [1] Pharr, M., Jakob, W., & Humphreys, G. (2023). Physically Based Rendering, 4th ed., §5.2.3
   (the thin lens camera) and §4.5.4 (terminating secondary wavelengths).
.. [2] Jakob, W., et al. (2022). Mitsuba 3, "Custom plugins in Python" (``mi.Sensor``,
   ``mi.register_sensor``).
.. [3] Brown, D. C. (1966). Decentering distortion of lenses. Photogrammetric Engineering 32(3),
   444–462; OpenCV, "Camera calibration and 3D reconstruction" (the same model).
.. [4] Turk, G. (1990). Generating random points in triangles. Graphics Gems, 24–28.
"""

from __future__ import annotations

import numpy as np

from ..optics.aperture import rounded_boundary
from .plugins import register_once
from .python_sensor import film_uv, one_wavelength, with_ray_differential

__all__ = ["PLUGIN", "register", "plugin_dict"]

#: The plugin name registered with Mitsuba.
PLUGIN = "spectral_thinlens"
#: Wavelengths (nm) of the focal-length table handed to the plugin.
TABLE_NM = np.arange(360.0, 831.0, 5.0)


def register(mi) -> None:
    """Register the plugin with Mitsuba's current variant (once per variant and process)."""
    register_once(mi, "sensor", PLUGIN, _sensor_class)


def _sensor_class(mi):
    import drjit as dr

    # Mitsuba requires this class inside a function: a Python plugin subclasses the active variant's
    # mi.Sensor, which exists only once mi.set_variant has run and is another class in each variant
    # (so one class is made and registered per variant: mi.register_*)
    class SpectralThinLens(mi.Sensor):
        """Thin lens whose focal length follows a spectrum ``focal_length`` (m per nm)."""

        def __init__(self, props):
            super().__init__(props)
            self.m_needs_sample_3 = True  # ask the integrator for aperture samples (else all 0.5: a pinhole)
            self.aperture_radius = props.get("aperture_radius", 0.0)
            self.image_distance = props.get("image_distance")
            self.half_width = props.get("half_width")  # tan of the half field of view along x
            self.focal = props.get("focal_length")  # a spectrum texture: f(λ) in metres
            self.disperses = props.get("disperses", True)
            self.blades = props.get("blades", 0)
            self.blade_rotation = props.get("blade_rotation", 0.0)  # radians
            self.distortion = [props.get(k, 0.0) for k in ("k1", "k2", "p1", "p2", "k3")]
            size = self.film().size()
            self.aspect = float(size[1]) / float(size[0])
            n = self.blades
            self.rounding = props.get("blade_rounding", 0.0)
            self.area_ratio = n / (2 * np.pi) * np.sin(2 * np.pi / n) if n >= 3 else 1.0
            if n >= 3 and self.rounding > 0:  # the rounded opening: its boundary tabulated by angle
                phi = (np.arange(ROUNDED_BINS) + 0.5) * 2 * np.pi / ROUNDED_BINS
                boundary = rounded_boundary(phi, n, self.blade_rotation, self.rounding)
                self.boundary = mi.Float(boundary.astype(np.float32))
                self.angles = mi.DiscreteDistribution(mi.Float((boundary ** 2).astype(np.float32)))
                self.area_ratio = float(np.mean(boundary ** 2))  # ½∫r²dφ / π
        def _aperture_point(self, sample):
            """A point on the opening (camera x, y), uniform over its area."""
            if self.blades < 3:
                return mi.warp.square_to_uniform_disk_concentric(sample) * self.aperture_radius
            if self.rounding > 0:  # angle with density ∝ r(φ)², radius r(φ)·√u: uniform over the area
                index, reused = self.angles.sample_reuse(sample.x)
                phi = (mi.Float(index) + reused) * (2 * np.pi / ROUNDED_BINS)
                radius = dr.gather(mi.Float, self.boundary, index) * dr.sqrt(sample.y) * self.aperture_radius
                return mi.Point2f(radius * dr.sin(phi), radius * dr.cos(phi))
            n = self.blades
            scaled = sample.x * n
            k = dr.floor(scaled)
            u1 = scaled - k  # the fractional part is a fresh uniform number
            a0 = self.blade_rotation + 2 * np.pi * k / n
            a1 = a0 + 2 * np.pi / n
            root = dr.sqrt(u1)
            # vertices at angle a from +y towards +x: (sin a, cos a)
            x = root * ((1.0 - sample.y) * dr.sin(a0) + sample.y * dr.sin(a1))
            y = root * ((1.0 - sample.y) * dr.cos(a0) + sample.y * dr.cos(a1))
            return mi.Point2f(x, y) * self.aperture_radius

        def _undistort(self, x, y):
            """Undistorted tan-coordinates of the chief ray for film tan-coordinates (camera axes)."""
            k1, k2, p1, p2, k3 = self.distortion
            if not any(self.distortion):
                return x, y
            xd, yd = -x, -y  # OpenCV's axes: x to the image's right, y down
            xu, yu = xd, yd
            for _ in range(20):
                r2 = xu * xu + yu * yu
                radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
                dx = 2.0 * p1 * xu * yu + p2 * (r2 + 2.0 * xu * xu)
                dy = p1 * (r2 + 2.0 * yu * yu) + 2.0 * p2 * xu * yu
                xu, yu = (xd - dx) / radial, (yd - dy) / radial
            return -xu, -yu

        def sample_ray(self, time, wavelength_sample, position_sample, aperture_sample, active=True):
            wavelengths, weight = self.sample_wavelengths(dr.zeros(mi.SurfaceInteraction3f), wavelength_sample,
                                                          active)
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.wavelengths = wavelengths
            focal = self.focal.eval(si)[0]  # f at the ray's (first) wavelength
            focus = focal * self.image_distance / (self.image_distance - focal)
            u, v = film_uv(self, position_sample)
            # camera space: +x is the image's left, +y up, +z the view; (x, y, 1) along the chief ray
            x, y = self._undistort((1.0 - 2.0 * u) * self.half_width, (1.0 - 2.0 * v) * self.half_width * self.aspect)
            disc = self._aperture_point(aperture_sample)
            origin = mi.Point3f(disc.x, disc.y, 0.0)
            target = mi.Point3f(x * focus, y * focus, focus)
            to_world = self.world_transform()
            # a direction, not a point: Point3f − Point3f stays a Point3f in Mitsuba's Python types, and
            # a transform would add the camera's translation to it (an XML camera away from the origin)
            ray = mi.Ray3f(to_world @ origin, dr.normalize(to_world @ mi.Vector3f(target - origin)), time, wavelengths)
            if not self.disperses:
                return ray, weight * self.area_ratio
            return ray, one_wavelength(mi, dr, weight, self.area_ratio)

        def to_string(self):
            return f"SpectralThinLens[aperture_radius={self.aperture_radius}, image_distance={self.image_distance}]"

    return with_ray_differential(mi, SpectralThinLens)


#: Angular bins of a rounded opening's tabulated boundary.
ROUNDED_BINS = 2048


def plugin_dict(lens, glass_spec: str, *, blades: int = 0, blade_rotation_deg: float = 0.0,
                blade_rounding: float = 0.0, distortion=(0.0, 0.0, 0.0, 0.0, 0.0)) -> dict:
    """The plugin's scene-dict entries (without film, sampler and pose) for ``lens`` (the frame's
    ThinLens: f and v at the d line) made of ``glass_spec`` (``lens.glass``; ``"ideal"``: no
    dispersion), with ``blades`` (0: a circular opening) and Brown–Conrady ``distortion``
    (k1, k2, p1, p2, k3)."""
    from ..optics.glass import thin_lens_focal_length

    ideal = glass_spec == "ideal"
    focal = (np.full(len(TABLE_NM), lens.focal_length_m) if ideal
             else thin_lens_focal_length(glass_spec, lens.focal_length_m, TABLE_NM))
    k1, k2, p1, p2, k3 = (float(v) for v in distortion)
    return {"type": PLUGIN, "aperture_radius": lens.aperture_radius_m, "image_distance": lens.image_distance_m,
            "disperses": not ideal, "blades": int(blades), "blade_rotation": float(np.radians(blade_rotation_deg)),
            "blade_rounding": float(blade_rounding),
            "k1": k1, "k2": k2, "p1": p1, "p2": p2, "k3": k3,
            "half_width": lens.sensor_width_m / (2.0 * lens.image_distance_m),
            "focal_length": {"type": "irregular", "wavelengths": ", ".join(f"{w:g}" for w in TABLE_NM),
                             "values": ", ".join(f"{f:.12g}" for f in focal)}}
