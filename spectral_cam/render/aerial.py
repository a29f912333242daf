"""Aerial perspective: the air between the camera and far ground dims it and veils it with the
sky's light, so distant hills are paler and bluer than the same hills near.

Light from a surface s metres along a camera ray reaches the camera as

    L(λ) = L₀(λ)·T(λ) + L_s(λ)·(1 − T(λ))/(1 − T∞(λ)),

T the path's transmittance and ``L_s`` the sky's radiance along the ray (at least 1° above the
horizon): what the whole path to space sends (the sky model holds the sun's angle and the haze),
of which the path to the surface holds the share (1 − T)/(1 − T∞), T∞ the whole path's
transmittance. A level ray (the far ground) has T = exp(−β(λ)·s) and T∞ = 0, so its light tends
to the horizon's; the air thins upwards with the molecules' and the haze's scale heights H, so a
ray climbing at elevation e (to a cloud) crosses Σ β·H·(1 − exp(−s·sin e/H))/sin e. Rays that meet
no surface see the sky model, which holds its own atmosphere, and are left alone. The extinction at sea level is Rayleigh's,
β_R(550 nm) = 1.149·10⁻⁵ m⁻¹ ∝ λ^−4.09 (colour-science's Bodhaine et al. 1999 within 1 % over
400–700 nm), plus the haze's, set by the sky's ``turbidity`` T (Preetham et al. 1999: the ratio
of the whole vertical optical depth to the molecules'), with the molecules' and the haze's
scale heights 8 km and 1.2 km: β_M(550) = β_R(550)·(T − 1)·8/1.2, ∝ λ^−1.3 (Ångström). At T = 3
the meteorological range (Koschmieder, 3.912/β at 550 nm) is 24 km.

It is applied per camera sample by an integrator wrapping the path tracer
(:func:`aerial_integrator`): the distance is the sample's own ray's (depth of field, motion and
tiles included) and the wavelengths its own. :func:`decide_aerial` turns it on where it changes
the farthest ground by at least :data:`MIN_VEIL` (a view that sees the horizon always; a
tabletop 2 m away never).

References
----------
.. [1] Preetham, A. J., Shirley, P., & Smits, B. (1999). A practical analytic model for daylight.
   SIGGRAPH 99, 91–100 (turbidity, scale heights, aerial perspective).
.. [2] Bodhaine, B. A., Wood, N. B., Dutton, E. G., & Slusser, J. R. (1999). On Rayleigh optical
   depth calculations. J. Atmos. Oceanic Technol. 16, 1854–1861 (as colour-science computes it).
.. [3] Koschmieder, H. (1924). Theorie der horizontalen Sichtweite. Beitr. Phys. freien Atm. 12.
.. [4] Ångström, A. (1929). On the atmospheric transmission of sun radiation and on dust in the
   air. Geografiska Annaler 11, 156–166.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

__all__ = ["extinction_per_m", "meteorological_range_m", "decide_aerial", "aerial_integrator", "PLUGIN",
           "RAYLEIGH_550_PER_M", "MIN_VEIL"]

#: Rayleigh extinction of dry air at sea level (15 °C, 1013.25 hPa) at 550 nm, m⁻¹, and the power
#: of its fall with wavelength over the visible (colour-science, Bodhaine et al. 1999).
RAYLEIGH_550_PER_M, RAYLEIGH_POWER = 1.149e-5, 4.09
#: The molecules' and the haze's scale heights (m; Preetham et al. 1999) and the haze's Ångström
#: exponent.
RAYLEIGH_HEIGHT_M, HAZE_HEIGHT_M, ANGSTROM_POWER = 8000.0, 1200.0, 1.3
#: Koschmieder's constant: the distance at which a black target's contrast falls to 2 %.
KOSCHMIEDER = -math.log(0.02)
#: Elevation (degrees) of the sky point read as the horizon's light: just above the ground's edge.
HORIZON_ELEVATION_DEG = 1.0
#: The least veil 1 − T(550 nm) at the farthest ground in view for which ``auto`` applies it.
MIN_VEIL = 0.005
#: The integrator plugin's name.
PLUGIN = "spectral_cam_aerial"


def extinction_per_m(wavelength_nm, turbidity: float):
    """Extinction coefficient β(λ) of the air at sea level, m⁻¹: Rayleigh's plus the haze's for
    the sky's ``turbidity`` (1: molecules only).

    Parameters
    ----------
    wavelength_nm : array_like
        Wavelengths, nm.
    turbidity : float
        Preetham's turbidity, ≥ 1.

    Returns
    -------
    numpy.ndarray
        β, m⁻¹.
    """
    if not (isinstance(turbidity, (int, float)) and turbidity >= 1.0):
        raise ValueError(f"turbidity = {turbidity!r}: give Preetham's turbidity, a number >= 1 (1: clean air)")
    ratio = 550.0 / np.asarray(wavelength_nm, dtype=float)
    haze = RAYLEIGH_550_PER_M * (turbidity - 1.0) * RAYLEIGH_HEIGHT_M / HAZE_HEIGHT_M
    return RAYLEIGH_550_PER_M * ratio ** RAYLEIGH_POWER + haze * ratio ** ANGSTROM_POWER


def meteorological_range_m(turbidity: float) -> float:
    """Koschmieder's visibility 3.912/β(550 nm), m."""
    return float(KOSCHMIEDER / extinction_per_m(550.0, turbidity))


def farthest_ground_m(config: "SceneConfig", lens: "ThinLens") -> float:
    """The farthest the frame's rays meet the ground plane (m; inf where one reaches the
    horizon), from the camera's height and the frame's corner rays."""
    from ..presets.outdoor import GroundView

    view = GroundView.from_config(config)
    half_x = lens.sensor_width_m / (2 * lens.image_distance_m)
    half_y = lens.sensor_height_m / (2 * lens.image_distance_m)
    farthest = 0.0
    for x in (-half_x, 0.0, half_x):
        for y in (-half_y, 0.0, half_y):
            direction = view.rotation.T @ np.array([x, y, 1.0])
            if direction[2] >= 0:
                return math.inf
            farthest = max(farthest, view.height_m / -direction[2] * float(np.linalg.norm(direction)))
    return farthest


def decide_aerial(config: "SceneConfig", lens: "ThinLens") -> tuple[bool, dict]:
    """Whether the render veils far ground (``sky.aerial_perspective``: ``auto``, ``on``, ``off``),
    and the record for ``model_decisions``. ``auto``: for a preset under the sky (the sun and sky
    or the overcast sky) where the farthest ground in view is veiled by at least :data:`MIN_VEIL`
    at 550 nm; never for an XML scene (its up is its own) or under a lamp."""
    from ..presets.outdoor import lit_by_sky

    mode = config.sky.aerial_perspective
    record = {"turbidity": config.sky.turbidity,
              "meteorological_range_km": meteorological_range_m(config.sky.turbidity) / 1000.0}
    if mode == "off" or not lit_by_sky(config):
        why = "sky.aerial_perspective = 'off'" if mode == "off" else "no sky to veil the ground with"
        return False, {"choice": "off", "reason": why, **record}
    far = farthest_ground_m(config, lens)
    veil = 1.0 - math.exp(-float(extinction_per_m(550.0, config.sky.turbidity)) * far)
    record["farthest_ground_m"] = far if math.isfinite(far) else "horizon"
    if mode == "on" or veil >= MIN_VEIL:
        why = ("sky.aerial_perspective = 'on'" if mode == "on" else "the view reaches the horizon" if math.isinf(far)
               else f"the farthest ground in view is veiled by {100 * veil:.2g} % at 550 nm (>= {100 * MIN_VEIL:g} %)")
        return True, {"choice": "on", "reason": why, **record}
    return False, {"choice": "off", "reason": f"the farthest ground in view ({far:.3g} m) is veiled by "
                                              f"{100 * veil:.2g} % at 550 nm (< {100 * MIN_VEIL:g} %)", **record}


def aerial_integrator(config: "SceneConfig", inner: dict) -> dict:
    """The integrator dict that veils ``inner``'s (a path tracer's) radiance with the air of
    ``config``'s sky, its up the ground's (:class:`~spectral_cam.presets.outdoor.GroundView`)."""
    from ..presets.outdoor import GroundView

    up = GroundView.from_config(config).rotation @ np.array([0.0, 0.0, 1.0])
    haze = RAYLEIGH_550_PER_M * (config.sky.turbidity - 1.0) * RAYLEIGH_HEIGHT_M / HAZE_HEIGHT_M
    return {"type": PLUGIN, "integrator": inner, "rayleigh_550": RAYLEIGH_550_PER_M, "haze_550": float(haze),
            "up_x": float(up[0]), "up_y": float(up[1]), "up_z": float(up[2])}


def _integrator_class(mi):
    """The ``mi.SamplingIntegrator`` subclass for the active variant."""
    import drjit as dr

    # Mitsuba requires this class inside a function: a Python integrator must subclass the active
    # variant's mi.SamplingIntegrator, which exists only once mi.set_variant has run
    class AerialPerspective(mi.SamplingIntegrator):
        """The inner integrator's radiance, veiled along the camera ray (see the module)."""

        def __init__(self, props):
            super().__init__(props)
            self.inner = props.get("integrator")
            self.rayleigh = float(props.get("rayleigh_550"))
            self.haze = float(props.get("haze_550"))
            self.up = mi.ScalarVector3f(props.get("up_x"), props.get("up_y"), props.get("up_z"))
            elevation = math.radians(HORIZON_ELEVATION_DEG)
            self.lift = (math.cos(elevation), math.sin(elevation))

        def sample(self, scene, sampler, ray, medium=None, active=True):
            first = scene.ray_intersect(ray, active)
            radiance, valid, aovs = self.inner.sample(scene, sampler, ray, medium, active)
            hit = active & first.is_valid()
            ratio = 550.0 / ray.wavelengths
            rayleigh = self.rayleigh * dr.power(ratio, RAYLEIGH_POWER)
            haze = self.haze * dr.power(ratio, ANGSTROM_POWER)
            up = mi.Vector3f(self.up)
            rise = dr.dot(ray.d, up)  # sine of the ray's elevation
            distance = dr.select(hit, first.t, 0.0)
            transmittance = dr.exp(-rayleigh * _thinning(dr, distance, rise, RAYLEIGH_HEIGHT_M)
                                   - haze * _thinning(dr, distance, rise, HAZE_HEIGHT_M))
            # the in-scattered light: the sky's along the ray (at least 1° up), of which the path to
            # the surface holds the share (1 − T)/(1 − T∞) of the whole path's to space
            level = ray.d - rise * up
            level = dr.select(dr.norm(level) > 1e-6, dr.normalize(level), mi.Vector3f(1, 0, 0))
            low = rise < self.lift[1]
            toward = dr.select(low, level * self.lift[0] + up * self.lift[1], ray.d)
            # a level ray's path to space never ends (T∞ = 0); the sky is read 1° up all the same
            endless = dr.select(rise > 1e-6, dr.exp(-(rayleigh * RAYLEIGH_HEIGHT_M + haze * HAZE_HEIGHT_M)
                                                    / dr.maximum(rise, 1e-6)), 0.0)
            sky = scene.environment()
            light = dr.zeros(mi.Spectrum)
            if sky is not None:
                point = dr.zeros(mi.SurfaceInteraction3f)
                point.wi = -toward
                point.wavelengths = ray.wavelengths
                light = sky.eval(point, hit) / (1.0 - endless)
            veiled = radiance * transmittance + light * (1.0 - transmittance)
            return dr.select(hit, veiled, radiance), valid, aovs

        def aov_names(self):
            return self.inner.aov_names()

        def to_string(self):
            return f"AerialPerspective[inner={self.inner}]"

    return AerialPerspective


def _thinning(dr, distance, rise, height_m: float):
    """∫₀ˢ exp(−z/H) ds along a ray climbing at sine ``rise`` from the ground (z = s·rise): the
    path's optical depth over the sea-level coefficient's, m; a level or falling ray keeps the
    ground's density (the camera stands within metres of it)."""
    x = distance * dr.maximum(rise, 0.0) / height_m
    return dr.select(x > 1e-4, distance * (1.0 - dr.exp(-x)) / dr.maximum(x, 1e-4), distance * (1.0 - 0.5 * x))


def register(mi) -> None:
    """Register the aerial-perspective integrator for the current variant, once."""
    from .plugins import register_once

    register_once(mi, "integrator", PLUGIN, _integrator_class)
