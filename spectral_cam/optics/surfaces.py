"""One surface of a lens prescription and a ray's meeting with it: the medium after it (a
catalogue glass or a :class:`ModelGlass` known by n_d and ν_d), a sphere or an even asphere
(:func:`sag_and_slope`), where rays meet it and how they refract there (Snell's law in vector
form, d′ = μd + (μ cos θᵢ − cos θₜ)·n̂ with μ = n/n′). The lens built of them is
:class:`spectral_cam.optics.sequential_lens.Prescription`.

Conventions: the optical axis is +z, light travels towards +z; a radius is positive when the
centre of curvature lies on the image side; lengths in metres.

References
----------
.. [1] Hecht, E. (2017). Optics, 5th ed., §4.4 (Snell's law), §6.3 (aspheric surfaces).
.. [2] Pharr, M., Jakob, W., & Humphreys, G. (2023). Physically Based Rendering, 4th ed., §5.3
   (intersecting and refracting at lens elements).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .glass import LINES_NM

__all__ = ["ModelGlass", "AIR", "Surface", "sag_and_slope", "asphere_sag", "intersect_sphere", "intersect_asphere",
           "refract"]


@dataclass(frozen=True)
class ModelGlass:
    """A glass known by nd and νd only: a two-term Cauchy law n(λ) = a + b/λ² through n_d with
    n_F − n_C = (n_d − 1)/ν_d (νd None: no dispersion)."""

    nd: float
    vd: float | None = None

    def index(self, wavelength_nm) -> np.ndarray:
        wl = np.asarray(wavelength_nm, dtype=np.float64)
        if self.vd is None or self.nd == 1.0:
            return np.full(wl.shape, self.nd)
        b = (self.nd - 1.0) / self.vd / (LINES_NM["F"] ** -2 - LINES_NM["C"] ** -2)
        return self.nd + b * (wl ** -2 - LINES_NM["d"] ** -2)


#: Air (n = 1, no dispersion).
AIR = ModelGlass(1.0)


@dataclass(frozen=True)
class Surface:
    """One surface: signed radius (m; 0 = flat), gap to the next surface (m), the medium after
    it (a catalogue :class:`~spectral_cam.optics.glass.Glass` or a :class:`ModelGlass`), clear
    semi-diameter (m), whether it is the aperture stop, and for an even asphere its conic
    constant k and coefficients (A₄, A₆, A₈, A₁₀ in m⁻³, m⁻⁵, …): the sag
    z(ρ) = cρ/(1 + √(1 − (1 + k)c²ρ)) + A₄ρ² + A₆ρ³ + …, ρ = x² + y², c = 1/R."""

    radius_m: float
    thickness_m: float
    medium: object
    semi_diameter_m: float
    stop: bool = False
    conic: float = 0.0
    aspheric: tuple[float, ...] = ()

    @property
    def is_asphere(self) -> bool:
        return self.conic != 0.0 or any(self.aspheric)


def intersect_sphere(o, d, radius, z0):
    """Where rays meet a surface (vertex at z0): points, unit normals facing the incoming side
    (−z), and whether they hit."""
    if radius == 0:
        t = (z0 - o[:, 2]) / d[:, 2]
        points = o + t[:, None] * d
        normal = np.tile([0.0, 0.0, -1.0], (len(o), 1))
        return points, normal, t >= 0
    centre = np.array([0.0, 0.0, z0 + radius])
    oc = o - centre
    b = np.einsum("ij,ij->i", oc, d)
    c = np.einsum("ij,ij->i", oc, oc) - radius * radius
    disc = b * b - c
    root = np.sqrt(np.clip(disc, 0.0, None))
    # the intersection nearer the vertex: for R > 0 the first crossing, for R < 0 the second
    t = -b - root if radius > 0 else -b + root
    points = o + t[:, None] * d
    normal = (points - centre) / radius  # points towards −z at the vertex for either sign
    normal = -normal if radius < 0 else normal
    normal = np.where((normal[:, 2] > 0)[:, None], -normal, normal)
    return points, normal, (disc >= 0) & (t >= 0)


def sag_and_slope(rho, radius_m: float, conic: float, aspheric, xp=np):
    """Sag z(ρ) of an even asphere and dz/dρ, ρ = x² + y² (m²): one formula for the NumPy tracer
    and the drjit camera (``xp``: ``numpy`` or ``drjit``). Where the conic's root vanishes (its rim)
    the slope is that of a root of 10⁻³⁰: vertical."""
    c = 0.0 if radius_m == 0 else 1.0 / radius_m
    root = xp.sqrt(xp.maximum(1.0 - (1.0 + conic) * c * c * rho, 0.0))
    sag = c * rho / (1.0 + root)
    slope = c / (2.0 * xp.maximum(root, 1e-30))
    for i, a in enumerate(aspheric):
        power = i + 2
        sag = sag + a * rho ** power
        slope = slope + power * a * rho ** (power - 1)
    return sag, slope


def asphere_sag(surface: Surface, rho):
    """Sag and slope of ``surface`` (NumPy arrays of ρ)."""
    return sag_and_slope(np.asarray(rho, dtype=np.float64), surface.radius_m, surface.conic, surface.aspheric)


def intersect_asphere(o, d, surface: Surface, z0):
    """Rays against an even asphere: Newton's method on F = sag(x² + y²) − (z − z0) along each
    ray from its meeting with the vertex plane; normals ∇F facing the incoming side."""
    t = (z0 - o[:, 2]) / d[:, 2]
    for _ in range(12):
        p = o + t[:, None] * d
        rho = p[:, 0] ** 2 + p[:, 1] ** 2
        sag, slope = asphere_sag(surface, rho)
        f = sag - (p[:, 2] - z0)
        gradient = np.stack([2 * p[:, 0] * slope, 2 * p[:, 1] * slope, -np.ones_like(rho)], axis=1)
        t = t - f / np.einsum("ij,ij->i", gradient, d)
    p = o + t[:, None] * d
    rho = p[:, 0] ** 2 + p[:, 1] ** 2
    sag, slope = asphere_sag(surface, rho)
    c = 0.0 if surface.radius_m == 0 else 1.0 / surface.radius_m
    inside = 1.0 - (1.0 + surface.conic) * c * c * rho >= 0
    hit = inside & (np.abs(sag - (p[:, 2] - z0)) < 1e-12) & (t >= 0) & np.isfinite(t)
    normal = np.stack([2 * p[:, 0] * slope, 2 * p[:, 1] * slope, -np.ones_like(rho)], axis=1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.where((np.einsum("ij,ij->i", normal, d) > 0)[:, None], -normal, normal)
    return p, normal, hit


def refract(d, normal, mu):
    """Snell's law in vector form; ``normal`` faces the incoming ray."""
    cos_i = -np.einsum("ij,ij->i", d, normal)
    sin2_t = mu * mu * (1.0 - cos_i * cos_i)
    ok = sin2_t <= 1.0
    cos_t = np.sqrt(np.clip(1.0 - sin2_t, 0.0, None))
    out = mu * d + (mu * cos_i - cos_t)[:, None] * normal
    return out / np.linalg.norm(out, axis=1, keepdims=True), ok
