"""A sequential lens (:class:`Prescription`): spherical or aspheric surfaces with a glass after
each and an aperture stop; its paraxial properties from ray-transfer (ABCD) matrices, real rays
traced through it with Snell's law, and what the trace tells: pupils, f-numbers, best focus,
spots, field of view, distortion. The surfaces are :mod:`spectral_cam.optics.surfaces`; the
bundled prescriptions and their CSV files :mod:`spectral_cam.optics.prescription`.

Conventions: the optical axis is +z, light travels from the object (z < 0) towards the image;
the first surface's vertex is at z = 0; a radius is positive when the centre of curvature lies
on the image side; lengths are metres in code (millimetres in the table files).

Paraxial optics in reduced form: a ray is (y, n·u); refraction at a surface of power
φ = (n′ − n)/R is [[1, 0], [−φ, 1]], a gap t in a medium n is [[1, t/n], [0, 1]]. The system
matrix from the first vertex to the last, [[A, B], [C, D]], gives the effective focal length
f = −1/C and the back focal distance (last vertex to the rear focal point) −A/C.

Real rays: each surface is intersected as a sphere (a plane for R = 0), a ray outside the clear
semi-diameter or totally internally reflected is vignetted, and refraction follows the vector
form of Snell's law, d′ = μd + (μ cos θᵢ − cos θₜ)·n̂ with μ = n/n′.

References
----------
.. [1] Hecht, E. (2017). Optics, 5th ed., §6.2 (matrix methods) and §6.3 (aberrations).
.. [2] Kolb, C., Mitchell, D., & Hanrahan, P. (1995). A realistic camera model for computer
   graphics. SIGGRAPH '95, 317–324.
.. [3] Pharr, M., Jakob, W., & Humphreys, G. (2023). Physically Based Rendering, 4th ed., §5.3
   (the realistic camera: tracing rays through lens elements).
"""


from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ConfigError
from .glass import LINES_NM
from .surfaces import AIR, Surface, intersect_asphere, intersect_sphere, refract

__all__ = ["Prescription"]


@dataclass(frozen=True)
class Prescription:
    """A sequential lens, object side first.

    Attributes
    ----------
    name, title, source : str
    surfaces : tuple of Surface
    stated_focal_length_m, stated_f_number : float or None
        What the source states (for checking).
    """

    name: str
    title: str
    source: str
    surfaces: tuple[Surface, ...]
    stated_focal_length_m: float | None = None
    stated_f_number: float | None = None

    # ---------------------------------------------------------------- paraxial
    def indices(self, wavelength_nm: float) -> np.ndarray:
        """Refractive index before the first surface (air) and after each surface."""
        return np.array([1.0] + [float(s.medium.index(wavelength_nm)) for s in self.surfaces])

    def vertices_m(self) -> np.ndarray:
        """z of each surface's vertex (the first at 0)."""
        return np.concatenate([[0.0], np.cumsum([s.thickness_m for s in self.surfaces[:-1]])])

    def system_matrix(self, wavelength_nm: float = LINES_NM["d"]) -> np.ndarray:
        """The reduced ABCD matrix from the first vertex to the last."""
        n = self.indices(wavelength_nm)
        matrix = np.eye(2)
        for i, surface in enumerate(self.surfaces):
            power = 0.0 if surface.radius_m == 0 else (n[i + 1] - n[i]) / surface.radius_m
            matrix = np.array([[1.0, 0.0], [-power, 1.0]]) @ matrix
            if i < len(self.surfaces) - 1:
                matrix = np.array([[1.0, surface.thickness_m / n[i + 1]], [0.0, 1.0]]) @ matrix
        return matrix

    def focal_length_m(self, wavelength_nm: float = LINES_NM["d"]) -> float:
        """Effective focal length (paraxial)."""
        return -1.0 / self.system_matrix(wavelength_nm)[1, 0]

    def back_focal_distance_m(self, wavelength_nm: float = LINES_NM["d"]) -> float:
        """Last vertex to the rear focal point (paraxial)."""
        m = self.system_matrix(wavelength_nm)
        return -m[0, 0] / m[1, 0]

    def entrance_pupil(self, wavelength_nm: float = LINES_NM["d"]) -> tuple[float, float]:
        """(z of the entrance pupil behind the first vertex, its semi-diameter): the stop as
        seen from object space through the surfaces in front of it (paraxial). With [[A, B],
        [C, D]] the matrix from the first vertex to the stop, the chief ray (through the stop's
        centre) crosses the axis at z = B/A, and a ray parallel to the axis at height r/A
        grazes the stop's edge r."""
        index = self.stop_index()
        n = self.indices(wavelength_nm)
        matrix = np.eye(2)
        for i in range(index):
            surface = self.surfaces[i]
            power = 0.0 if surface.radius_m == 0 else (n[i + 1] - n[i]) / surface.radius_m
            matrix = np.array([[1.0, surface.thickness_m / n[i + 1]], [0.0, 1.0]]) @ (
                np.array([[1.0, 0.0], [-power, 1.0]]) @ matrix)
        a, b = matrix[0]
        return b / a, abs(self.surfaces[index].semi_diameter_m / a)

    def exit_pupil(self, wavelength_nm: float = LINES_NM["d"]) -> tuple[float, float]:
        """(distance of the exit pupil in front of the last vertex, its semi-diameter): the stop
        seen from image space, the entrance pupil of the lens turned round."""
        return self.reversed().entrance_pupil(wavelength_nm)

    def f_number(self, wavelength_nm: float = LINES_NM["d"]) -> float:
        """Paraxial f-number f / (entrance pupil diameter)."""
        return self.focal_length_m(wavelength_nm) / (2.0 * self.entrance_pupil(wavelength_nm)[1])

    def marginal_height_m(self, wavelength_nm: float = LINES_NM["d"]) -> float:
        """Height of the highest ray parallel to the axis that passes every clear aperture: the
        real entrance pupil's radius for an object at infinity, whichever surface limits the
        axial bundle. Five rounds of 33 rays traced at once, each narrowing the bracket to one
        step above the last height of the passing run from the axis (to ~3·10⁻⁸ of the front
        semi-diameter)."""
        low, high = 0.0, self.surfaces[0].semi_diameter_m
        if self.trace([[0.0, high, -1.0]], [[0.0, 0.0, 1.0]], wavelength_nm)[2][0]:
            return high
        for _ in range(5):
            heights = np.linspace(low, high, 33)
            rays = np.stack([np.zeros(33), heights, np.full(33, -1.0)], axis=1)
            passed = self.trace(rays, np.tile([0.0, 0.0, 1.0], (33, 1)), wavelength_nm)[2]
            run = int(np.argmin(passed)) if not passed.all() else 32  # the first that fails
            if run == 0:  # even ``low`` failed: the axis itself is blocked
                return low if low > 0 else 0.0
            low, high = heights[run - 1], heights[min(run, 32)]
        return float(low)

    def traced_f_number(self, wavelength_nm: float = LINES_NM["d"]) -> float:
        """f-number from the trace: the focal length over the diameter of the widest axial
        bundle that passes (:meth:`marginal_height_m`)."""
        return self.focal_length_m(wavelength_nm) / (2.0 * self.marginal_height_m(wavelength_nm))

    def stop_index(self) -> int:
        stops = [i for i, s in enumerate(self.surfaces) if s.stop]
        return stops[0] if stops else int(np.argmin([s.semi_diameter_m for s in self.surfaces]))

    def stopped_down(self, f_number: float) -> "Prescription":
        """The same lens with its stop closed to ``f_number`` (traced: f over the diameter of the
        widest passing axial bundle, the convention the scene's f-number and the camera equation
        use), never opened beyond its own; the lens itself when it is already there (10⁻⁴).

        The stop's semi-diameter is scaled, starting from the paraxial estimate (the entrance
        pupil is the stop times the pupil magnification, so EPD ∝ stop radius), then refined by
        Brent's method on the traced f-number.

        Raises
        ------
        ConfigError
            For an f-number faster than the lens (or not a positive number).

        References
        ----------
        .. [1] Smith, W. J. (2008). Modern Optical Engineering, 4th ed., §6.2 (stops, pupils,
           f-number).
        """
        own = self.traced_f_number()
        if not (isinstance(f_number, (int, float)) and math.isfinite(f_number) and f_number > 0):
            raise ConfigError(f"{self.name}: f-number {f_number!r} must be a positive number")
        if f_number < own * (1 - 1e-4):
            raise ConfigError(f"{self.name} opens to f/{own:.3g} at most; f/{f_number:g} asks for more "
                              f"(valid: lens.f_number >= {own:.4g}, or leave it unset for the design's)")
        if f_number <= own * (1 + 1e-4):
            return self
        from scipy.optimize import brentq

        def excess(fraction: float) -> float:  # > 0 while the stop is closed too far
            return self._with_stop(fraction).traced_f_number() - f_number

        low = own / f_number  # paraxial: EPD, hence N, scales with the stop radius
        while excess(low) < 0:  # an element other than the stop still clips: close further
            low *= 0.5
        fraction = brentq(excess, low, 1.0, xtol=1e-10, rtol=1e-10)
        return self._with_stop(fraction)

    def _with_stop(self, fraction: float) -> "Prescription":
        """This lens with its stop's semi-diameter times ``fraction``."""
        surfaces = list(self.surfaces)
        index = self.stop_index()
        surfaces[index] = replace(surfaces[index], semi_diameter_m=surfaces[index].semi_diameter_m * fraction)
        return replace(self, surfaces=tuple(surfaces))

    def working_f_numbers(self, focus_distance_m: float, wavelength_nm: float = LINES_NM["d"]) -> dict:
        """The f-numbers at which the lens forms the image of an axial point ``focus_distance_m``
        in front of the entrance pupil (what sets the image's irradiance and diffraction there).

        Returns
        -------
        dict
            ``paraxial``: 1/(2|u′|), u′ the image-space slope of the paraxial marginal ray from
            that point through the entrance pupil's edge (ABCD); ``traced``: 1/(2 sin θ′), θ′ the
            widest angle to the axis, behind the lens, of the real rays from that point that pass
            every aperture; ``magnification``: the paraxial lateral magnification (negative: a real,
            inverted image); ``pupil_magnification``: exit over entrance pupil diameter. Far away,
            both approach the f-number; the thin-lens limit is N·(1 + |m|/m_p).

        References
        ----------
        .. [1] Smith, W. J. (2008). Modern Optical Engineering, 4th ed., §6.2 (working f-number,
           pupil magnification).
        """
        pupil_z, pupil_r = self.entrance_pupil(wavelength_nm)
        distance = focus_distance_m - pupil_z  # object to the first vertex
        slope = pupil_r / focus_distance_m
        matrix = self.system_matrix(wavelength_nm)
        _, slope_out = matrix @ np.array([slope * distance, slope])  # at the first vertex: height s·u, slope u
        image = self.image_distance_m(distance, wavelength_nm)
        # A of T(image)·S·T(object): the object plane to the image plane's magnification
        magnification = float(matrix[0, 0] + image * matrix[1, 0])
        _, exit_r = self.exit_pupil(wavelength_nm)
        tilt = np.linspace(0.0, 1.3, 2001) * np.arctan(pupil_r / focus_distance_m)
        directions = np.stack([np.zeros_like(tilt), np.sin(tilt), np.cos(tilt)], axis=1)
        origins = np.tile([0.0, 0.0, -distance], (len(tilt), 1))
        _, d, passed = self.trace(origins, directions, wavelength_nm)
        sine = float(np.max(np.abs(d[passed, 1]))) if passed.any() else float("nan")
        return {"paraxial": 1.0 / (2.0 * abs(slope_out)), "traced": 1.0 / (2.0 * sine),
                "magnification": magnification, "pupil_magnification": exit_r / pupil_r}

    def _bundle(self, field_deg: float, object_distance_m: float, wavelength_nm: float, grid: int):
        """Rays from a point at ``field_deg`` off axis and ``object_distance_m`` in front of the
        first vertex (inf: a parallel bundle) over a ``grid`` × ``grid`` square on the entrance
        pupil's plane (1.3 × its radius, so off-axis bundles that pass elsewhere are kept),
        traced: (origins, directions, passed) after the last surface."""
        pupil_z, radius = self.entrance_pupil(wavelength_nm)
        extent = 1.3 * radius
        axis = np.linspace(-extent, extent, grid)
        gx, gy = (a.ravel() for a in np.meshgrid(axis, axis))
        keep = gx * gx + gy * gy <= extent * extent
        targets = np.stack([gx[keep], gy[keep], np.full(keep.sum(), pupil_z)], axis=1)
        tilt = np.radians(field_deg)
        if np.isinf(object_distance_m):
            direction = np.tile([0.0, np.sin(tilt), np.cos(tilt)], (len(targets), 1))
            origins = targets - direction * (pupil_z + 1.0)  # start in front of the first vertex
        else:
            source = np.array([0.0, -np.tan(tilt) * object_distance_m, -object_distance_m])
            origins = np.tile(source, (len(targets), 1))
            direction = targets - source
        return self.trace(origins, direction, wavelength_nm)

    @staticmethod
    def _rms_on_planes(o, d, planes):
        """RMS radius about the centroid of rays (o, d) on each plane z in ``planes``."""
        t = (np.asarray(planes)[:, None] - o[None, :, 2]) / d[None, :, 2]
        x, y = o[None, :, 0] + t * d[None, :, 0], o[None, :, 1] + t * d[None, :, 1]
        return np.sqrt(x.var(axis=1) + y.var(axis=1))

    def focus_image_distance_m(self, object_distance_m: float = float("inf"),
                               wavelength_nm: float = LINES_NM["d"]) -> float:
        """Last vertex to the plane of smallest RMS spot of an axial point (best focus), the
        paraxial image refined over ±5 % of the focal length: where a photographer's focusing
        puts the sensor. Aberrations move it (the telephoto: 0.8 mm in front of paraxial)."""
        paraxial = (self.back_focal_distance_m(wavelength_nm) if np.isinf(object_distance_m)
                    else self.image_distance_m(object_distance_m, wavelength_nm))
        o, d, passed = self._bundle(0.0, object_distance_m, wavelength_nm, 61)
        if passed.sum() < 3:
            return paraxial
        o, d = o[passed], d[passed]
        z_last = self.vertices_m()[-1]
        span = 0.05 * abs(self.focal_length_m(wavelength_nm))
        centre = paraxial
        for width in (span, span / 20, span / 400):
            planes = z_last + centre + np.linspace(-width, width, 41)
            centre = planes[np.argmin(self._rms_on_planes(o, d, planes))] - z_last
        return float(centre)

    def spot_rms_m(self, field_deg: float = 0.0, object_distance_m: float = float("inf"),
                   wavelength_nm: float = LINES_NM["d"], grid: int = 101) -> tuple[float, float]:
        """(RMS spot radius about its centroid on the axial best-focus plane — a flat sensor,
        so field curvature counts — and the fraction of the entrance-pupil bundle that passes)
        for a point ``field_deg`` off axis, ``object_distance_m`` in front of the first vertex."""
        o, d, passed = self._bundle(field_deg, object_distance_m, wavelength_nm, grid)
        if not passed.any():
            return float("nan"), 0.0
        plane = self.vertices_m()[-1] + self.focus_image_distance_m(object_distance_m, wavelength_nm)
        return float(self._rms_on_planes(o[passed], d[passed], [plane])[0]), float(passed.mean())

    def image_height_m(self, field_deg: float, sensor_distance_m: float, wavelength_nm: float = LINES_NM["d"]) -> float:
        """Where the chief ray (through the entrance pupil's centre) of a distant point
        ``field_deg`` off axis meets a sensor ``sensor_distance_m`` behind the last vertex (nan
        when it does not pass)."""
        pupil_z, _ = self.entrance_pupil(wavelength_nm)
        tilt = np.radians(field_deg)
        direction = np.array([[0.0, np.sin(tilt), np.cos(tilt)]])
        origin = np.array([[0.0, 0.0, pupil_z]]) - direction * (pupil_z + 1.0)
        o, d, passed = self.trace(origin, direction, wavelength_nm)
        if not passed[0]:
            return float("nan")
        plane = self.vertices_m()[-1] + sensor_distance_m
        return float(abs(o[0, 1] + (plane - o[0, 2]) / d[0, 2] * d[0, 1]))

    def field_of_view_deg(self, half_width_m: float, sensor_distance_m: float,
                          wavelength_nm: float = LINES_NM["d"]) -> float:
        """Full field of view across a sensor ``2·half_width_m`` wide, from the trace: twice the
        field angle whose chief ray lands at the sensor's edge (bisection; distortion included)."""
        low, high = 0.0, 89.0
        for _ in range(60):
            middle = 0.5 * (low + high)
            height = self.image_height_m(middle, sensor_distance_m, wavelength_nm)
            if np.isfinite(height) and height < half_width_m:
                low = middle
            else:
                high = middle
        return 2.0 * low

    def sensor_distance_m(self, focus_distance_m: float, wavelength_nm: float = LINES_NM["d"]) -> float:
        """Where the sensor sits behind the last vertex when the lens is focused on an object
        ``focus_distance_m`` in front of the entrance pupil (best focus, as the render places it)."""
        return self.focus_image_distance_m(focus_distance_m - self.entrance_pupil(wavelength_nm)[0], wavelength_nm)

    def opencv_distortion(self, focus_distance_m: float, half_diagonal_m: float, *, samples: int = 48,
                          wavelength_nm: float = LINES_NM["d"]) -> dict:
        """The lens's distortion as OpenCV's radial model, fitted to the real chief rays.

        A distant point at angle θ from the axis, seen from the entrance pupil (the camera's
        origin), lands at h(θ) on the sensor (:meth:`image_height_m`). OpenCV maps the
        undistorted normalised radius r_u = tan θ to r_d = r_u·(1 + k1·r_u² + k2·r_u⁴ + k3·r_u⁶) and
        scales it by the focal length f_px: so f = h/tan θ as θ → 0 (the chief rays' paraxial
        scale, traced at 0.01°), and k1, k2, k3 are the least-squares fit of h/(f·tan θ) − 1 over
        ``samples`` fields up to the sensor's corner (``half_diagonal_m``); p1 = p2 = 0 (the lens
        is rotationally symmetric). The chief ray of a near point through the pupil's centre is
        the same ray, so the fit holds at any object distance.

        Returns
        -------
        dict
            ``focal_length_m`` (the scale f, m per unit tan θ), ``coefficients`` (k1, k2, p1, p2,
            k3), ``residual_m`` (largest |h − fitted h| over the fields), ``max_field_deg``.

        References
        ----------
        .. [1] Brown, D. C. (1966). Decentering distortion of lenses. Photogrammetric
           Engineering 32(3), 444–462 (the radial polynomial OpenCV uses).
        .. [2] OpenCV, "Camera Calibration and 3D Reconstruction" (``projectPoints``' model).
        """
        sensor = self.sensor_distance_m(focus_distance_m, wavelength_nm)
        small = 0.01
        scale = self.image_height_m(small, sensor, wavelength_nm) / np.tan(np.radians(small))
        corner = 0.5 * self.field_of_view_deg(half_diagonal_m, sensor, wavelength_nm)
        fields = np.linspace(corner / samples, corner, samples)
        heights = np.array([self.image_height_m(f, sensor, wavelength_nm) for f in fields])
        keep = np.isfinite(heights)
        r_u = np.tan(np.radians(fields[keep]))
        design = np.stack([r_u ** 2, r_u ** 4, r_u ** 6], axis=1)
        (k1, k2, k3), *_ = np.linalg.lstsq(design, heights[keep] / (scale * r_u) - 1.0, rcond=None)
        fitted = scale * r_u * (1.0 + design @ np.array([k1, k2, k3]))
        return {"focal_length_m": float(scale), "coefficients": [float(k1), float(k2), 0.0, 0.0, float(k3)],
                "residual_m": float(np.max(np.abs(fitted - heights[keep]))), "max_field_deg": float(corner)}

    def describe(self, focus_distance_m: float, sensor_width_m: float) -> dict:
        """What a render through this lens records (meta.json): focal length, f-numbers (traced
        and paraxial, at infinity and working at ``focus_distance_m``: :meth:`working_f_numbers`),
        the stop's semi-diameter, the sensor's place and the field of view from the trace, next to
        the thin lens's."""
        object_to_vertex = focus_distance_m - self.entrance_pupil()[0]
        sensor = self.focus_image_distance_m(object_to_vertex)
        focal = self.focal_length_m()
        thin_v = focal * focus_distance_m / (focus_distance_m - focal)
        working = self.working_f_numbers(focus_distance_m)
        return {"name": self.name, "title": self.title, "source": self.source,
                "focal_length_mm": focal * 1e3, "traced_f_number": self.traced_f_number(),
                "paraxial_f_number": self.f_number(), "working_f_number": working["traced"],
                "paraxial_working_f_number": working["paraxial"],
                "stop_semi_diameter_mm": self.surfaces[self.stop_index()].semi_diameter_m * 1e3,
                "stated_focal_length_mm":
                    None if self.stated_focal_length_m is None else self.stated_focal_length_m * 1e3,
                "stated_f_number": self.stated_f_number, "back_focal_distance_mm": self.back_focal_distance_m() * 1e3,
                "sensor_behind_last_vertex_mm": sensor * 1e3,
                "paraxial_image_behind_last_vertex_mm": self.image_distance_m(object_to_vertex) * 1e3,
                "fov_x_deg_traced": self.field_of_view_deg(sensor_width_m / 2, sensor),
                "fov_x_deg_thin_lens": float(np.degrees(2 * np.arctan(sensor_width_m / 2 / thin_v)))}

    def scaled(self, factor: float) -> "Prescription":
        """The same design with every length multiplied by ``factor``."""
        surfaces = tuple(Surface(s.radius_m * factor, s.thickness_m * factor, s.medium, s.semi_diameter_m * factor,
                                 s.stop, s.conic, tuple(a * factor ** (1 - 2 * (i + 2)) for i, a in enumerate(s.aspheric)))
                         for s in self.surfaces)
        stated = self.stated_focal_length_m * factor if self.stated_focal_length_m else None
        return Prescription(self.name, self.title, self.source, surfaces, stated, self.stated_f_number)

    def reversed(self) -> "Prescription":
        """The same lens seen from the image side: surfaces in reverse order with their radii's
        signs flipped, each followed by the medium that was before it (air before the first)."""
        before = [AIR] + [s.medium for s in self.surfaces[:-1]]
        gaps = [s.thickness_m for s in self.surfaces[:-1]][::-1] + [0.0]
        surfaces = tuple(Surface(-s.radius_m, gap, medium, s.semi_diameter_m, s.stop, s.conic,
                                 tuple(-a for a in s.aspheric))  # mirrored in z: the sag changes sign
                         for s, medium, gap in zip(self.surfaces[::-1], before[::-1], gaps))
        return Prescription(self.name + " (reversed)", self.title, self.source, surfaces)

    def image_distance_m(self, object_distance_m: float, wavelength_nm: float = LINES_NM["d"]) -> float:
        """Last vertex to the paraxial image of an axial point ``object_distance_m`` in front of
        the first vertex: with M = S·T(s), the image is where B of T(q)·M vanishes, q = −B/D."""
        matrix = self.system_matrix(wavelength_nm) @ np.array([[1.0, object_distance_m], [0.0, 1.0]])
        return -matrix[0, 1] / matrix[1, 1]

    # ---------------------------------------------------------------- real rays
    def trace(self, origins, directions, wavelength_nm: float = LINES_NM["d"], *, heights: list | None = None):
        """Trace rays (N, 3) from object space through every surface (``heights``: a list that
        receives each surface's radial ray heights, for sizing clear apertures).

        Returns
        -------
        origins, directions : numpy.ndarray
            (N, 3) each ray after the last surface (on it, unit direction).
        passed : numpy.ndarray
            (N,) bool: False where a ray missed a surface, left its clear aperture or was
            totally internally reflected.
        """
        o = np.array(origins, dtype=np.float64, copy=True)
        d = np.array(directions, dtype=np.float64, copy=True)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        n = self.indices(wavelength_nm)
        passed = np.ones(len(o), bool)
        for i, (surface, z0) in enumerate(zip(self.surfaces, self.vertices_m())):
            o, normal, hit = (intersect_asphere(o, d, surface, z0) if surface.is_asphere
                              else intersect_sphere(o, d, surface.radius_m, z0))
            if heights is not None:
                heights.append(np.hypot(o[:, 0], o[:, 1]))
            passed &= hit & (np.hypot(o[:, 0], o[:, 1]) <= surface.semi_diameter_m)
            if surface.stop or n[i + 1] == n[i]:
                continue
            d, ok = refract(d, normal, n[i] / n[i + 1])
            passed &= ok
        return o, d, passed
