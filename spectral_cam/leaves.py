"""Leaves from a leaf model: reflectance and transmittance from PROSPECT-D, and the biochemistry
of healthy, stressed and dry (senescent) plants.

PROSPECT-D (Féret et al. 2017) models a leaf as N stacked absorbing plates whose absorption is
the sum of its pigments' and constituents' specific absorption: chlorophylls a + b (``cab``,
µg·cm⁻²), carotenoids (``car``, µg·cm⁻²), anthocyanins (``ant``, µg·cm⁻²), brown pigments
(``brown``, arbitrary units), water (``cw``, equivalent water thickness, cm) and dry matter
(``cm``, g·cm⁻²). It gives directional-hemispherical reflectance R(λ) and transmittance T(λ),
400–2500 nm; ``prosail`` (PyPI) computes it, and this module samples it on any grid (held at
its 400-nm value below 400 nm, where the model has no data and the camera curves little).

A leaf both reflects and transmits diffusely (a Lambertian reflector and transmitter, the same
R on both faces: the model is symmetric): in the near infrared it transmits 40–50 % and in the
green 5–15 %, which makes a canopy glow against the sun.

The trait distributions (:data:`HEALTH_STATES`) follow the ranges of the leaves PROSPECT-D was
calibrated on (ANGERS, Féret et al. 2017, table 2) and of chlorosis studies: healthy leaves
40–60 µg·cm⁻² of chlorophyll, stressed (chlorotic) 10–30 with more carotenoid per chlorophyll
and some anthocyanin (yellow-green: D65 sRGB ≈ 0.39, 0.33, 0.22 in reflectance), dry leaves little
chlorophyll, brown pigments and a tenth of the water (tan: ≈ 0.50, 0.42, 0.31).

References
----------
.. [1] Féret, J.-B., Gitelson, A. A., Noble, S. D., & Jacquemoud, S. (2017). PROSPECT-D: Towards
   modeling leaf optical properties through a complete lifecycle. Remote Sensing of Environment
   193, 204–215.
.. [2] Jacquemoud, S., & Baret, F. (1990). PROSPECT: A model of leaf optical properties spectra.
   Remote Sensing of Environment 34(2), 75–91.
.. [3] Gómez-Dans, J. L. prosail: PROSPECT and SAIL in Python (PyPI ``prosail`` 2.0.5).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from .errors import ConfigError

__all__ = ["LeafTraits", "prospect_d", "prospect_layers", "HEALTH_STATES", "draw_traits", "vein_traits",
           "aged_traits", "PROSPECT_RANGE_NM", "LEAF_PLUGIN", "CUTICLE_INDEX", "CUTICLE_ROUGHNESS"]

#: Wavelengths PROSPECT-D covers (nm).
PROSPECT_RANGE_NM = (400.0, 2500.0)
#: The Mitsuba plugin of a reflecting and transmitting leaf (``render/leaf_bsdf.py`` registers
#: it; presets name it in their scene dicts).
LEAF_PLUGIN = "spectral_cam_leaf"
#: Refractive index of the cuticle's specular lobe: PROSPECT-D's tabulated n(λ) (prosail's ``nr``,
#: 1.51 at 400 nm to 1.44 at 720 nm) averaged over 400–720 nm; leaf wax measures 1.45–1.5 (Grant
#: 1987; Vanderbilt & Grant 1985).
CUTICLE_INDEX = 1.47
#: Range of the cuticle's GGX roughness α over species (Bousquet et al. 2005, σ ≈ 0.1–0.5 for laurel,
#: beech and hazel; Comar et al. 2014, wheat 0.18–0.46): each species draws its own within it.
CUTICLE_ROUGHNESS = (0.1, 0.5)
#: PROSPECT's cone of incidence for its first interface (degrees; its ``alpha``).
PROSPECT_ALPHA_DEG = 40.0


@dataclass(frozen=True)
class LeafTraits:
    """A leaf's structure and biochemistry (PROSPECT-D inputs).

    Attributes
    ----------
    n : float
        Structure parameter (number of plates), 1–3.
    cab, car, ant : float
        Chlorophyll a + b, carotenoids, anthocyanins (µg·cm⁻²).
    brown : float
        Brown pigments (arbitrary units, 0–1).
    cw : float
        Equivalent water thickness (cm).
    cm : float
        Dry matter per area (g·cm⁻²).
    """

    n: float = 1.5
    cab: float = 45.0
    car: float = 10.0
    ant: float = 1.0
    brown: float = 0.0
    cw: float = 0.012
    cm: float = 0.006

    def __post_init__(self) -> None:
        limits = {"n": (1.0, 4.0), "cab": (0.0, 150.0), "car": (0.0, 40.0), "ant": (0.0, 40.0), "brown": (0.0, 2.0),
                  "cw": (0.0, 0.1), "cm": (0.0, 0.05)}
        for key, (low, high) in limits.items():
            value = getattr(self, key)
            if not (isinstance(value, (int, float)) and low <= value <= high):
                raise ConfigError(f"leaf trait {key} = {value!r}: valid {low}..{high}")

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


@functools.lru_cache(maxsize=256)
def _prospect(traits: LeafTraits) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    import prosail

    wl, r, t = prosail.run_prospect(traits.n, traits.cab, traits.car, traits.brown, traits.cw, traits.cm,
                                    ant=traits.ant, prospect_version="D")
    return np.asarray(wl, float), np.asarray(r, float), np.asarray(t, float)


def prospect_d(traits: LeafTraits, wavelengths_nm) -> tuple[np.ndarray, np.ndarray]:
    """Reflectance and transmittance of a leaf at ``wavelengths_nm`` (PROSPECT-D, 1-nm model
    output interpolated linearly; held at the 400-nm value below 400 nm).

    Parameters
    ----------
    traits : LeafTraits
        The leaf.
    wavelengths_nm : array_like
        Where to sample (nm), up to 2500.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        R(λ) and T(λ), fractions.

    References
    ----------
    .. [1] Féret, J.-B., et al. (2017). Remote Sensing of Environment 193, 204–215.

    Examples
    --------
    A healthy leaf reflects little green and much near infrared, and transmits about as much:

    >>> r, t = prospect_d(LeafTraits(), [550.0, 800.0])
    >>> bool(r[0] < 0.15 and r[1] > 0.4 and t[1] > 0.4)
    True
    """
    wl, r, t = _prospect(traits)
    at = np.asarray(wavelengths_nm, dtype=float)
    if at.size and at.max() > PROSPECT_RANGE_NM[1]:
        raise ConfigError(f"PROSPECT-D covers {PROSPECT_RANGE_NM[0]:g}–{PROSPECT_RANGE_NM[1]:g} nm; "
                          f"asked for {at.max():g} nm")
    return np.interp(at, wl, r), np.interp(at, wl, t)


def prospect_layers(traits: LeafTraits, wavelengths_nm) -> tuple[np.ndarray, np.ndarray]:
    """The leaf body's reflectance ρ(λ) and transmittance τ(λ) per unit of light that crossed its
    surface: PROSPECT-D's R = r_α + t_α·(…) and T = t_α·(…) (r_α = 1 − t_α the first interface's
    reflectance averaged over incidences within 40°, with PROSPECT's own n(λ)), so
    ρ = (R − r_α)/t_α and τ = T/t_α; ρ + τ ≤ 1. The cuticle's lobe takes the place of r_α
    (``render/leaf_bsdf.py``).

    Examples
    --------
    >>> rho, tau = prospect_layers(LeafTraits(), [550.0, 800.0])
    >>> bool(rho[0] < prospect_d(LeafTraits(), [550.0])[0][0] and (rho + tau).max() <= 1.0)
    True
    """
    import prosail
    from prosail.prospect_d import calctav

    at = np.asarray(wavelengths_nm, dtype=float)
    r, t = prospect_d(traits, at)
    wl = np.arange(400, 2501, dtype=float)
    nr = np.interp(at, wl, prosail.spectral_lib.prospectd.nr)
    t_alpha = calctav(PROSPECT_ALPHA_DEG, nr)
    rho = np.clip((r - (1.0 - t_alpha)) / t_alpha, 0.0, 1.0)
    return rho, np.clip(np.minimum(t / t_alpha, 1.0 - rho), 0.0, 1.0)


def vein_traits(traits: LeafTraits) -> LeafTraits:
    """A leaf's veins, midrib and base: paler and thicker than its lamina (a third of its
    chlorophyll, half its carotenoids, more structure, dry matter and water: vascular and
    supporting tissue, little mesophyll; Esau 1977, Plant Anatomy, ch. 19)."""
    return dataclasses.replace(traits, n=min(traits.n + 0.8, 3.5), cab=traits.cab * 0.35, car=traits.car * 0.5,
                               ant=traits.ant * 0.5, cm=min(traits.cm * 1.5, 0.05), cw=min(traits.cw * 1.3, 0.1))


def aged_traits(traits: LeafTraits) -> LeafTraits:
    """The oldest (lowest) leaf of a plant whose young leaves have ``traits``: senescence
    breaks chlorophyll down first (60 %), keeps carotenoids longer, browns and dries the
    leaf (Merzlyak et al. 1999, Physiologia Plantarum 106, 135–141; Féret et al. 2017's
    senescent ANGERS leaves)."""
    return dataclasses.replace(traits, n=min(traits.n + 0.2, 3.5), cab=traits.cab * 0.4, car=traits.car * 0.8,
                               brown=min(traits.brown + 0.3, 2.0), cw=traits.cw * 0.8)


#: Trait distributions per health state: (low, high) of a uniform draw, or a fixed value;
#: carotenoids follow chlorophyll (car = cab × ratio).
HEALTH_STATES: dict[str, dict] = {
    "healthy": {"n": (1.4, 1.9), "cab": (40.0, 60.0), "car_ratio": (0.18, 0.26), "ant": (0.0, 2.0),
                "brown": 0.0, "cw": (0.010, 0.018), "cm": (0.004, 0.008)},
    "stressed": {"n": (1.4, 1.9), "cab": (10.0, 30.0), "car_ratio": (0.25, 0.35), "ant": (0.5, 3.0),
                 "brown": (0.0, 0.2), "cw": (0.006, 0.014), "cm": (0.004, 0.008)},
    "dry": {"n": (1.8, 2.5), "cab": (0.0, 5.0), "car_ratio": (0.3, 0.6), "ant": (0.0, 0.5),
            "brown": (1.0, 2.0), "cw": (0.0005, 0.002), "cm": (0.005, 0.01)},
}


def draw_traits(rng: np.random.Generator, state: str) -> LeafTraits:
    """A leaf of a health state (:data:`HEALTH_STATES`), drawn uniformly within its ranges.

    Raises
    ------
    ConfigError
        For an unknown state (listing the valid ones).
    """
    if state not in HEALTH_STATES:
        raise ConfigError(f"leaf health state {state!r}: valid: {', '.join(HEALTH_STATES)}")
    spec = HEALTH_STATES[state]

    def draw(key):
        value = spec[key]
        return float(rng.uniform(*value)) if isinstance(value, tuple) else float(value)

    cab = draw("cab")
    return LeafTraits(n=draw("n"), cab=cab, car=cab * draw("car_ratio"), ant=draw("ant"), brown=draw("brown"),
                      cw=draw("cw"), cm=draw("cm"))
