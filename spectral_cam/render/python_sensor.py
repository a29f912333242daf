"""What our Mitsuba cameras written in Python share (:mod:`.spectral_lens`,
:mod:`.prescription_lens`; registered by :func:`.plugins.register_once`): the film position of a sample
(crop windows included), one wavelength per ray where the optics disperse, and the ray
differential Mitsuba's integrators ask for.

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3, "Custom plugins in Python" (``mi.Sensor``,
   ``mi.register_sensor``).
.. [2] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §4.5.4 (terminating secondary wavelengths).
"""

from __future__ import annotations

__all__ = ["film_uv", "one_wavelength", "with_ray_differential"]


def film_uv(sensor, position_sample):
    """(u, v) over the whole film (0 at the top-left corner) of a sample over the sensor film's
    crop window, which is what Mitsuba's integrators pass (tiles render crop windows)."""
    film = sensor.film()
    offset, crop, size = film.crop_offset(), film.crop_size(), film.size()
    return ((offset[0] + position_sample.x * crop[0]) / size[0], (offset[1] + position_sample.y * crop[1]) / size[1])


def one_wavelength(mi, dr, weight, scale):
    """The weight of a ray refracted for its first wavelength only: the three secondary
    wavelengths Mitsuba samples with it terminated, their weight moved to the first (×4), which
    keeps the estimate unbiased."""
    first = dr.zeros(mi.Spectrum)
    first[0] = weight[0] * scale * 4.0
    return first


def with_ray_differential(mi, cls):
    """Give ``cls`` the ``sample_ray_differential`` integrators call: its ``sample_ray`` as a ray
    without differentials."""
    def sample_ray_differential(self, time, wavelength_sample, position_sample, aperture_sample, active=True):
        ray, weight = self.sample_ray(time, wavelength_sample, position_sample, aperture_sample, active)
        return mi.RayDifferential3f(ray), weight

    cls.sample_ray_differential = sample_ray_differential
    return cls
