"""Why soil is darker when wet: light trapped in the water film (Ångström 1925; Lekner & Dorf 1988).

A rough, porous surface of diffuse albedo ``a`` wetted by a film of water of index ``n``: light
crosses the film's surface (diffuse transmittance 1 − r_e), is scattered by the grains (a), and of
what comes back up a share r_i is reflected back down by the film's underside — for diffuse light
inside water most of it by total internal reflection beyond the critical angle asin(1/n) ≈ 48.6° —
to be scattered again. Summing the bounces:

    R_wet = (1 − r_e)(1 − r_i)·a / (1 − r_i·a)

with r_e the water surface's diffuse (cosine-weighted hemispherical) Fresnel reflectance from air,
r_e = ∫₀^{π/2} F(θ; n)·2 sin θ cos θ dθ ≈ 0.0664 for n = 1.333, and r_i its internal one, which
energy conservation and reciprocity tie to r_e: r_i = 1 − (1 − r_e)/n² ≈ 0.4746 (the n² is the
étendue's change across the surface; :func:`diffuse_fresnel_reflectance` integrates both, and they
agree to 10⁻⁶). The film's own surface reflection r_e is specular (a glint in the mirror
direction), not part of the diffuse albedo returned here: a = 1 gives 1 − r_e, a → 0 gives 0,
and R_wet/a falls from 1 − r_e towards (1 − r_e)(1 − r_i) ≈ 0.49 as a → 0.

For typical soils (a = 0.1–0.5) the wet reflectance is 0.5–0.65 of the dry one, as measured: the
USGS sand DWO-3-DEL2 dry and wet (bundled, ``usgs_soils``) differ by 0.51–0.62 over 400–700 nm,
where this model applied to the dry sample gives 0.52–0.56 (tests/presets/test_ground.py), and
Lobell & Asner (2002) measure reflectance roughly halving from dry to saturated soils.

References
----------
.. [1] Lekner, J., & Dorf, M. C. (1988). Why some things are darker when wet. Applied Optics
   27(7), 1278–1280.
.. [2] Ångström, A. (1925). The albedo of various surfaces of ground. Geografiska Annaler 7,
   323–342.
.. [3] Lobell, D. B., & Asner, G. P. (2002). Moisture effects on soil reflectance. Soil Science
   Society of America Journal 66(3), 722–727.
.. [4] Born, M., & Wolf, E. (1999). Principles of Optics, 7th ed., §1.5.3 (Fresnel's formulae).
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = ["WATER_INDEX", "fresnel_unpolarised", "diffuse_fresnel_reflectance", "wet_reflectance", "wet_spectrum"]

#: Refractive index of water in the visible (about 1.333 at 589 nm, 20 °C).
WATER_INDEX = 1.333


def fresnel_unpolarised(cos_incident, relative_index: float) -> np.ndarray:
    """Fresnel reflectance of unpolarised light, (R_s + R_p)/2, at a smooth interface of
    relative index ``relative_index`` = n_t/n_i (1 beyond the critical angle)."""
    cos_i = np.clip(np.asarray(cos_incident, dtype=np.float64), 0.0, 1.0)
    n = float(relative_index)
    sin_t2 = (1.0 - cos_i ** 2) / n ** 2
    cos_t = np.sqrt(np.clip(1.0 - sin_t2, 0.0, 1.0))
    rs = ((cos_i - n * cos_t) / np.maximum(cos_i + n * cos_t, 1e-300)) ** 2
    rp = ((n * cos_i - cos_t) / np.maximum(n * cos_i + cos_t, 1e-300)) ** 2
    return np.where(sin_t2 >= 1.0, 1.0, 0.5 * (rs + rp))


@functools.lru_cache(maxsize=16)
def diffuse_fresnel_reflectance(relative_index: float, samples: int = 20001) -> float:
    """The Fresnel reflectance of an interface for diffuse (Lambertian) light,
    ∫₀^{π/2} F(θ)·2 sin θ cos θ dθ (the trapezoidal rule in θ: 20 001 samples put it within
    10⁻⁸ of Simpson's from air and 4·10⁻⁷ from inside, where F kinks at the critical angle,
    without importing SciPy into every render of a textured ground, 0.37 s);
    ``relative_index`` = n_t/n_i, so 1.333 is water seen from air (r_e ≈ 0.0664) and 1/1.333
    from inside it (r_i ≈ 0.4746)."""
    theta = np.linspace(0.0, np.pi / 2, int(samples) | 1)
    integrand = fresnel_unpolarised(np.cos(theta), relative_index) * 2.0 * np.sin(theta) * np.cos(theta)
    return float(np.trapezoid(integrand, theta))


def wet_reflectance(dry, n_water: float = WATER_INDEX) -> np.ndarray:
    """The diffuse reflectance of a surface of dry reflectance ``dry`` under a water film of
    index ``n_water`` (Lekner & Dorf 1988): (1 − r_e)(1 − r_i)·a / (1 − r_i·a), r_e the water
    surface's diffuse external reflectance (:func:`diffuse_fresnel_reflectance`), r_i =
    1 − (1 − r_e)/n² its internal one (the module's notes derive and check it).

    Examples
    --------
    >>> float(wet_reflectance(0.0)), round(float(wet_reflectance(1.0)), 4)
    (0.0, 0.9336)
    >>> round(float(wet_reflectance(0.3) / 0.3), 2)
    0.57
    """
    a = np.clip(np.asarray(dry, dtype=np.float64), 0.0, 1.0)
    r_e = diffuse_fresnel_reflectance(float(n_water))
    r_i = 1.0 - (1.0 - r_e) / float(n_water) ** 2
    return (1.0 - r_e) * (1.0 - r_i) * a / (1.0 - r_i * a)


def wet_spectrum(sd, n_water: float = WATER_INDEX):
    """A measured dry reflectance spectrum (:class:`~spectral_cam.spectrum.Spectrum` or
    colour-science's) wetted by :func:`wet_reflectance` at every wavelength; named ``<name>_wet``."""
    from .spectrum import Spectrum

    wavelengths = np.asarray(sd.wavelengths, dtype=np.float64)
    return Spectrum(wavelengths, wet_reflectance(np.asarray(sd.values, dtype=np.float64), n_water),
                    f"{getattr(sd, 'name', '')}_wet")
