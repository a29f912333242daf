"""A Mitsuba camera through a real lens prescription (``lens.model = "prescription"``): rays
leave the sensor, are traced through every surface (spheres and the stop, Snell's law at each
ray's own wavelength) and enter the scene where they leave the front element, as pbrt's
``realistic`` camera does (Kolb et al. 1995).

Frames. The lens is traced from the image side (:meth:`Prescription.reversed`, its rear
vertex at z = 0, +z towards the object), which is already oriented as Mitsuba's camera space
(+z the view); the camera's origin is put at the entrance pupil, the projection centre of the
chief rays, so the pinhole depth render sees the scene from where the lens sees it. The sensor
stands where the lens focuses ``focus_distance_m`` best (smallest RMS spot of an axial point,
:meth:`Prescription.focus_image_distance_m`): focus by moving the sensor.

Sampling. For a sensor point at radius r, the rays that pass lie within bounds on the rear
element's vertex plane, precomputed (per radial bin, for a point on +x, rotated to the point's
azimuth) by tracing a grid with NumPy; each ray samples that box uniformly, so few are wasted.
Its weight is the box area × cos⁴θ / d² (the irradiance integral, d the sensor-to-rear-vertex
distance) × (1 + 4N_w²)/π, so the film holds the radiance the sensor's camera equation expects
and the image carries the lens's own vignetting (the sensor adds no cos⁴ of its own).

Dispersion: a prescription whose glasses disperse traces one wavelength per ray (the others
terminated, ×4 on the first); one that gives only nd keeps all four. The stop is closed to
``lens.f_number`` (traced; never opened past the design's). Aperture blades (``lens.blades``,
rotation, rounding) shape the stop itself: a ray passes it inside the regular polygon (blended
with the circle by the rounding) inscribed in the stop's clear aperture, so the image's
brightness and bokeh follow the opening.

References
----------
.. [1] Kolb, C., Mitchell, D., & Hanrahan, P. (1995). A realistic camera model for computer
   graphics. SIGGRAPH '95, 317–324.
.. [2] Pharr, M., Jakob, W., & Humphreys, G. (2023). Physically Based Rendering, 4th ed., §5.3
   (RealisticCamera: exit-pupil bounds, the cos⁴θ·A/d² weight).
"""

from __future__ import annotations

import numpy as np

from ..optics.glass import LINES_NM
from ..optics.aperture import rounded_boundary
from ..optics.prescription import Prescription, sag_and_slope
from .plugins import register_once
from .python_sensor import film_uv, one_wavelength, with_ray_differential

__all__ = ["PLUGIN", "register", "plugin_dict", "pupil_bounds", "trace_surfaces"]

PLUGIN = "prescription_lens"
TABLE_NM = np.arange(360.0, 831.0, 5.0)
#: Radial bins of the exit-pupil bounds, and the rear-plane grid traced per bin.
BINS, GRID = 64, 96


def _disperses(lens: Prescription) -> bool:
    return any(np.ptp(s.medium.index(TABLE_NM)) > 0 for s in lens.surfaces)


def pupil_bounds(rear: Prescription, sensor_z: float, max_radius: float) -> np.ndarray:
    """(BINS, 4) bounds (x0, x1, y0, y1) on the rear vertex plane (z = 0) of the rays from a
    sensor point at radius r on +x (r within each bin) that pass the whole lens (d line),
    grown by one grid cell; zeros where none pass."""
    extent = rear.surfaces[0].semi_diameter_m
    grid = np.linspace(-extent, extent, GRID)
    gx, gy = (a.ravel() for a in np.meshgrid(grid, grid))
    cell = grid[1] - grid[0]
    bounds = np.zeros((BINS, 4))
    for b in range(BINS):
        passed = np.zeros(gx.size, bool)
        for r in np.linspace(b, b + 1, 4) / BINS * max_radius:
            origins = np.tile([r, 0.0, sensor_z], (gx.size, 1))
            directions = np.stack([gx - r, gy, np.full(gx.size, -sensor_z)], axis=1)
            passed |= rear.trace(origins, directions, LINES_NM["d"])[2]
        if passed.any():
            bounds[b] = (gx[passed].min() - cell, gx[passed].max() + cell, gy[passed].min() - cell,
                         gy[passed].max() + cell)
    return bounds


def plugin_dict(lens: Prescription, frame_lens, focus_distance_m: float, *, blades: int = 0,
                blade_rotation_deg: float = 0.0, blade_rounding: float = 0.0) -> dict:
    """The plugin's scene-dict entries (without film, sampler and pose): ``lens`` focused on
    ``focus_distance_m`` (from the entrance pupil) over the sensor of ``frame_lens`` (the
    frame's ThinLens: its size, f-number and working f-number), its stop closed to the frame's
    f-number (:meth:`Prescription.stopped_down`: ``lens.f_number``; a ConfigError for one faster
    than the design's)."""
    lens = lens.stopped_down(float(frame_lens.f_number))
    rear = lens.reversed()
    pupil_z, _ = lens.entrance_pupil()
    length = float(lens.vertices_m()[-1])  # first to last vertex
    object_to_vertex = focus_distance_m - pupil_z  # object plane to the first vertex
    sensor_z = -lens.focus_image_distance_m(object_to_vertex)  # best focus, behind the rear vertex (z < 0)
    half_w, half_h = frame_lens.sensor_width_m / 2, frame_lens.sensor_height_m / 2
    bounds = pupil_bounds(rear, sensor_z, float(np.hypot(half_w, half_h)))
    entry = {"type": PLUGIN, "sensor_z": sensor_z, "half_width": half_w, "half_height": half_h,
             "pupil_offset": length - pupil_z,  # camera origin (the entrance pupil) in rear coordinates
             "radiance_scale": (1.0 + 4.0 * frame_lens.working_f_number ** 2) / np.pi,
             "max_radius": float(np.hypot(half_w, half_h)), "disperses": _disperses(lens),
             "radii": _text(s.radius_m for s in rear.surfaces),
             "vertices": _text(rear.vertices_m()),
             "semi_diameters": _text(s.semi_diameter_m for s in rear.surfaces),
             "stops": _text(float(s.stop) for s in rear.surfaces),
             "conics": _text(s.conic for s in rear.surfaces),
             "aspheric": _text(v for s in rear.surfaces for v in (tuple(s.aspheric) + (0.0,) * 4)[:4]),
             "bounds": _text(bounds.ravel()), "blades": int(blades),
             "blade_rotation": float(np.radians(blade_rotation_deg)), "blade_rounding": float(blade_rounding)}
    for i, surface in enumerate(rear.surfaces):
        entry[f"index_{i}"] = {"type": "irregular", "wavelengths": _text(TABLE_NM),
                               "values": _text(surface.medium.index(TABLE_NM))}
    return entry


def _text(values) -> str:
    return ", ".join(f"{float(v):.12g}" for v in values)


def register(mi) -> None:
    """Register the plugin with Mitsuba's current variant (once per variant and process)."""
    register_once(mi, "sensor", PLUGIN, _sensor_class)


def _floats(props, key) -> list[float]:
    return [float(v) for v in props.get(key).split(",")]


def _sensor_class(mi):
    """The ``mi.Sensor`` subclass for the current variant (Mitsuba's Python plugins subclass
    the variant's own ``mi.Sensor``); the optics it calls are the module's functions."""
    import drjit as dr

    # Mitsuba requires this class inside a function: a Python plugin subclasses the active variant's
    # mi.Sensor, which exists only once mi.set_variant has run and is another class in each variant
    # (so one class is made and registered per variant: mi.register_*)
    class PrescriptionLens(mi.Sensor):
        def __init__(self, props):
            super().__init__(props)
            self.m_needs_sample_3 = True
            self.sensor_z = props.get("sensor_z")
            self.half_width, self.half_height = props.get("half_width"), props.get("half_height")
            self.pupil_offset = props.get("pupil_offset")
            self.scale = props.get("radiance_scale")
            self.max_radius = props.get("max_radius")
            self.disperses = props.get("disperses")
            self.radii, self.vertices = _floats(props, "radii"), _floats(props, "vertices")
            self.semi_diameters, self.stops = _floats(props, "semi_diameters"), _floats(props, "stops")
            self.indices = [props.get(f"index_{i}") for i in range(len(self.radii))]
            self.conics = _floats(props, "conics")
            self.blades = props.get("blades", 0)
            self.blade_rotation = props.get("blade_rotation", 0.0)
            self.blade_rounding = props.get("blade_rounding", 0.0)
            self.aspheric = np.asarray(_floats(props, "aspheric")).reshape(-1, 4).tolist()
            bounds = np.asarray(_floats(props, "bounds")).reshape(-1, 4)
            self.bounds = [mi.Float(bounds[:, k].astype(np.float32)) for k in range(4)]
            self.bins = len(bounds)
            self.rear_distance = -self.sensor_z

        def sample_ray(self, time, wavelength_sample, position_sample, aperture_sample, active=True):
            wavelengths, weight = self.sample_wavelengths(dr.zeros(mi.SurfaceInteraction3f), wavelength_sample,
                                                          active)
            u, v = film_uv(self, position_sample)
            x, y = (2.0 * u - 1.0) * self.half_width, (2.0 * v - 1.0) * self.half_height
            radius = dr.sqrt(x * x + y * y)
            index = mi.UInt32(dr.minimum(radius / self.max_radius * self.bins, self.bins - 1))
            x0, x1, y0, y1 = (dr.gather(mi.Float, b, index) for b in self.bounds)
            px, py = dr.lerp(x0, x1, aperture_sample.x), dr.lerp(y0, y1, aperture_sample.y)
            cos_phi = dr.select(radius > 0.0, x / radius, 1.0)
            sin_phi = dr.select(radius > 0.0, y / radius, 0.0)
            rear = mi.Point3f(px * cos_phi - py * sin_phi, px * sin_phi + py * cos_phi, 0.0)
            origin = mi.Point3f(x, y, self.sensor_z)
            direction = dr.normalize(rear - origin)
            cos2 = direction.z * direction.z
            area = (x1 - x0) * (y1 - y0)
            geometry = area * cos2 * cos2 / (self.rear_distance * self.rear_distance) * self.scale
            o, d, passed = trace_surfaces(mi, dr, self, origin, direction, wavelengths, mi.Bool(active))
            o = mi.Point3f(o.x, o.y, o.z - self.pupil_offset)  # camera origin at the entrance pupil
            to_world = self.world_transform()
            # d as a direction (a Point3f would take the camera's translation: an XML camera off the origin)
            ray = mi.Ray3f(to_world @ o, dr.normalize(to_world @ mi.Vector3f(d)), time, wavelengths)
            scale = dr.select(passed, geometry, 0.0)
            if self.disperses:
                return ray, one_wavelength(mi, dr, weight, scale)
            return ray, weight * scale

        def to_string(self):
            return f"PrescriptionLens[surfaces={len(self.radii)}, sensor_z={self.sensor_z}]"

    return with_ray_differential(mi, PrescriptionLens)


def trace_surfaces(mi, dr, lens, o, d, wavelengths, active):
    """Real rays from the sensor through every surface of the rear-first prescription held by
    the plugin ``lens`` (``radii``, ``vertices``, ``semi_diameters``, ``stops``, ``indices``,
    ``conics``, ``aspheric``, blades): intersect, clip at the clear aperture (the stop's
    bladed opening), refract by Snell's law at the ray's wavelength. Returns the last
    surface's point, the outgoing direction and the rays still alive."""
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wavelengths = wavelengths
    n_before = mi.Float(1.0)
    for radius, z0, semi, stop, index, conic, aspheric in zip(
            lens.radii, lens.vertices, lens.semi_diameters, lens.stops, lens.indices, lens.conics, lens.aspheric):
        if conic != 0.0 or any(aspheric):
            p, normal, hit = _asphere_hit(mi, dr, o, d, radius, z0, conic, aspheric)
            active &= hit
            t = mi.Float(0.0)
        elif radius == 0.0:
            t = (z0 - o.z) / d.z
            p = o + t * d
            normal = mi.Vector3f(0.0, 0.0, 1.0)
        else:
            t, p, normal, hit = _sphere_hit(mi, dr, o, d, radius, z0)
            active &= hit
        if stop and lens.blades >= 3:  # the opening the blades leave (as the thin lens's)
            boundary = rounded_boundary(dr.atan2(p.x, p.y), lens.blades, lens.blade_rotation, lens.blade_rounding,
                                        xp=dr)
            active &= (t >= 0.0) & (dr.sqrt(p.x * p.x + p.y * p.y) <= semi * boundary)
        else:
            active &= (t >= 0.0) & (p.x * p.x + p.y * p.y <= semi * semi)
        o = p
        n_after = index.eval(si)[0]
        if not stop:
            d, refracted = _refract(dr, d, normal, n_before / n_after)
            active &= refracted
        n_before = n_after
    return o, d, active


def _sphere_hit(mi, dr, o, d, radius, z0):
    """The ray's intersection with the sphere of ``radius`` whose vertex is at ``z0``, on
    the side the surface faces: distance, point, outward normal, whether it hit."""
    centre = mi.Point3f(0.0, 0.0, z0 + radius)
    oc = o - centre
    b = dr.dot(oc, d)
    disc = b * b - (dr.dot(oc, oc) - radius * radius)
    root = dr.safe_sqrt(disc)
    closer = (d.z > 0.0) ^ (radius < 0.0)
    t = dr.select(closer, -b - root, -b + root)
    p = o + t * d
    return t, p, dr.normalize(p - centre), disc >= 0.0


def _refract(dr, d, normal, mu):
    """Snell's law for the direction ``d`` at a surface of ``normal`` with index ratio
    ``mu`` = n_before/n_after: the refracted direction and whether it escaped total internal
    reflection."""
    normal = dr.select(dr.dot(normal, d) > 0.0, -normal, normal)  # face the ray
    cos_i = -dr.dot(d, normal)
    sin2_t = mu * mu * (1.0 - cos_i * cos_i)
    cos_t = dr.safe_sqrt(1.0 - sin2_t)
    return dr.normalize(mu * d + (mu * cos_i - cos_t) * normal), sin2_t <= 1.0


def _asphere_hit(mi, dr, o, d, radius, z0, conic, aspheric):
    """Newton's method on F = sag(ρ) − (z − z0) along each ray (as the NumPy tracer):
    point, normal and whether it converged onto the surface."""
    c = 0.0 if radius == 0.0 else 1.0 / radius
    t = (z0 - o.z) / d.z
    for _ in range(12):
        p = o + t * d
        rho = p.x * p.x + p.y * p.y
        sag, slope = sag_and_slope(rho, radius, conic, aspheric, xp=dr)
        f = sag - (p.z - z0)
        dfdt = 2.0 * p.x * slope * d.x + 2.0 * p.y * slope * d.y - d.z
        t = t - f / dfdt
    p = o + t * d
    rho = p.x * p.x + p.y * p.y
    sag, slope = sag_and_slope(rho, radius, conic, aspheric, xp=dr)
    hit = (1.0 - (1.0 + conic) * c * c * rho >= 0.0) & (dr.abs(sag - (p.z - z0)) < 1e-7) & (t >= 0.0)
    normal = dr.normalize(mi.Vector3f(2.0 * p.x * slope, 2.0 * p.y * slope, -1.0))
    return p, normal, hit
