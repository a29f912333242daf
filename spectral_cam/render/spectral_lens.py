"""A Mitsuba camera through a dispersive thin lens: each ray carries its own wavelength and is
refracted with the focal length the lens has at that wavelength.

The sensor stays where the lens focuses ``focus_distance`` at the d line (587.56 nm). A ray of
wavelength λ leaves a point on the aperture disc towards the point of the chief ray (through
the lens centre, undeviated) on the plane that the lens focuses at λ, z_λ = f(λ)·v/(v − f(λ)):
every ray from one sensor point then meets at that point's conjugate, as a thin lens of focal
length f(λ) makes them. Blue (shorter f) focuses behind the d-line plane in object space, red in
front; the sensor sees the longitudinal chromatic aberration of the lens's glass. With the stop at
the lens the chief ray does not depend on λ, so a thin lens has no lateral colour.

A ray can carry one wavelength only, so the three secondary wavelengths Mitsuba samples with
each ray are terminated (their weight moved to the first, ×4 — unbiased, as pbrt-v4 does at a
dispersive interface).

References
----------
.. [1] Pharr, M., Jakob, W., & Humphreys, G. (2023). Physically Based Rendering, 4th ed., §5.2.3
   (the thin lens camera) and §4.5.4 (terminating secondary wavelengths).
.. [2] Jakob, W., et al. (2022). Mitsuba 3, "Custom plugins in Python" (``mi.Sensor``,
   ``mi.register_sensor``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["PLUGIN", "register", "plugin_dict"]

#: The plugin name registered with Mitsuba.
PLUGIN = "spectral_thinlens"
#: Wavelengths (nm) of the focal-length table handed to the plugin.
TABLE_NM = np.arange(360.0, 831.0, 5.0)
_REGISTERED: set[str] = set()


def register(mi) -> None:
    """Register the plugin with Mitsuba's current variant (once per variant and process)."""
    variant = mi.variant()
    if variant in _REGISTERED:
        return
    import drjit as dr

    class SpectralThinLens(mi.Sensor):
        """Thin lens whose focal length follows a spectrum ``focal_length`` (m per nm)."""

        def __init__(self, props):
            super().__init__(props)
            self.m_needs_sample_3 = True  # ask the integrator for aperture samples (else all 0.5: a pinhole)
            self.aperture_radius = props.get("aperture_radius", 0.0)
            self.image_distance = props.get("image_distance")
            self.half_width = props.get("half_width")  # tan of the half field of view along x
            self.focal = props.get("focal_length")  # a spectrum texture: f(λ) in metres
            size = self.film().size()
            self.aspect = float(size[1]) / float(size[0])

        def _film_uv(self, position_sample):
            film = self.film()
            offset, crop, size = film.crop_offset(), film.crop_size(), film.size()
            u = (offset[0] + position_sample.x * crop[0]) / size[0]
            v = (offset[1] + position_sample.y * crop[1]) / size[1]
            return u, v

        def sample_ray(self, time, wavelength_sample, position_sample, aperture_sample, active=True):
            wavelengths, weight = self.sample_wavelengths(dr.zeros(mi.SurfaceInteraction3f), wavelength_sample,
                                                          active)
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.wavelengths = wavelengths
            focal = self.focal.eval(si)[0]  # f at the ray's (first) wavelength
            focus = focal * self.image_distance / (self.image_distance - focal)
            u, v = self._film_uv(position_sample)
            # camera space: +x is the image's left, +y up, +z the view; (x, y, 1) along the chief ray
            x = (1.0 - 2.0 * u) * self.half_width
            y = (1.0 - 2.0 * v) * self.half_width * self.aspect
            disc = mi.warp.square_to_uniform_disk_concentric(aperture_sample) * self.aperture_radius
            origin = mi.Point3f(disc.x, disc.y, 0.0)
            target = mi.Point3f(x * focus, y * focus, focus)
            to_world = self.world_transform()
            ray = mi.Ray3f(to_world @ origin, dr.normalize(to_world @ (target - origin)), time, wavelengths)
            first = dr.zeros(mi.Spectrum)
            first[0] = weight[0] * 4.0  # secondary wavelengths terminated (see module docstring)
            return ray, first

        def sample_ray_differential(self, time, wavelength_sample, position_sample, aperture_sample, active=True):
            ray, weight = self.sample_ray(time, wavelength_sample, position_sample, aperture_sample, active)
            return mi.RayDifferential3f(ray), weight

        def to_string(self):
            return f"SpectralThinLens[aperture_radius={self.aperture_radius}, image_distance={self.image_distance}]"

    mi.register_sensor(PLUGIN, lambda props: SpectralThinLens(props))
    _REGISTERED.add(variant)


def plugin_dict(lens, glass_spec: str) -> dict:
    """The plugin's scene-dict entries (without film, sampler and pose) for ``lens`` (the frame's
    ThinLens: f and v at the d line) made of ``glass_spec`` (``lens.glass``)."""
    from ..lenses.glass import thin_lens_focal_length

    focal = thin_lens_focal_length(glass_spec, lens.focal_length_m, TABLE_NM)
    return {"type": PLUGIN, "aperture_radius": lens.aperture_radius_m, "image_distance": lens.image_distance_m,
            "half_width": lens.sensor_width_m / (2.0 * lens.image_distance_m),
            "focal_length": {"type": "irregular", "wavelengths": ", ".join(f"{w:g}" for w in TABLE_NM),
                             "values": ", ".join(f"{f:.12g}" for f in focal)}}
