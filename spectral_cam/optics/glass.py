"""Optical glasses: refractive index n(λ) from SCHOTT's Sellmeier coefficients, Abbe numbers and
partial dispersions, and the focal length of a thin lens of one glass (a singlet) or two (a
cemented achromat) at every wavelength.

A singlet's power scales with n(λ) − 1 (the lensmaker's equation), so its focal length is
f(λ) = f_d·(n_d − 1)/(n(λ) − 1): blue focuses nearer than red, f_C − f_F ≈ f_d/ν_d. A thin
achromat of a crown and a flint in contact splits the power as φ₁ = φ·ν₁/(ν₁ − ν₂),
φ₂ = −φ·ν₂/(ν₁ − ν₂), which brings F and C to one focus; the d line then focuses apart by the
secondary spectrum, Δφ = φ·(P₁ − P₂)/(ν₁ − ν₂) with P = (n_F − n_d)/(n_F − n_C).

References
----------
.. [1] SCHOTT AG, Optical Glass datasheets (Sellmeier formula, νd = (nd − 1)/(nF − nC)).
.. [2] Hecht, E. (2017). Optics, 5th ed., §6.3.2 (chromatic aberration, the thin achromatic
   doublet).
.. [3] Kingslake, R., & Johnson, R. B. (2010). Lens Design Fundamentals, 2nd ed., ch. 5
   (secondary spectrum, partial dispersion).
"""

from __future__ import annotations

import csv
import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ConfigError

__all__ = ["Glass", "glass", "GLASS_NAMES", "LINES_NM", "singlet_focal_length", "achromat_focal_length",
           "thin_lens_focal_length"]

#: Fraunhofer lines (nm): F (hydrogen, blue), d (helium, yellow), C (hydrogen, red).
LINES_NM = {"F": 486.1327, "d": 587.5618, "C": 656.2725}
CATALOGUE = Path(__file__).resolve().parent.parent / "data" / "glasses" / "schott.csv"


@dataclass(frozen=True)
class Glass:
    """A catalogue glass: Sellmeier B (dimensionless) and C (µm²) terms, and the catalogue's
    nd and νd."""

    name: str
    b: tuple[float, float, float]
    c_um2: tuple[float, float, float]
    nd_catalogue: float
    vd_catalogue: float

    def index(self, wavelength_nm) -> np.ndarray:
        """n(λ) (λ in nm, any shape)."""
        l2 = (np.asarray(wavelength_nm, dtype=np.float64) * 1e-3) ** 2
        return np.sqrt(1.0 + sum(b * l2 / (l2 - c) for b, c in zip(self.b, self.c_um2)))

    @property
    def abbe_number(self) -> float:
        """νd = (n_d − 1)/(n_F − n_C) from the Sellmeier terms."""
        f, d, c = (float(self.index(LINES_NM[k])) for k in "FdC")
        return (d - 1.0) / (f - c)

    @property
    def partial_dispersion(self) -> float:
        """P_F,d = (n_F − n_d)/(n_F − n_C)."""
        f, d, c = (float(self.index(LINES_NM[k])) for k in "FdC")
        return (f - d) / (f - c)


@functools.lru_cache(maxsize=1)
def _catalogue() -> dict[str, Glass]:
    with CATALOGUE.open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    return {r["name"]: Glass(r["name"], (float(r["B1"]), float(r["B2"]), float(r["B3"])),
                             (float(r["C1_um2"]), float(r["C2_um2"]), float(r["C3_um2"])),
                             float(r["nd"]), float(r["vd"])) for r in rows}


def _names() -> tuple[str, ...]:
    with CATALOGUE.open(newline="") as handle:
        return tuple(row["name"] for row in csv.DictReader(handle))


#: The catalogue's glasses (read without building them, for scene validation).
GLASS_NAMES = _names()


def glass(name: str) -> Glass:
    """A catalogue glass by name (``"N-BK7"``, ``"F2"``, …).

    Raises
    ------
    ConfigError
        For a name not in the catalogue (the message lists it).
    """
    found = _catalogue().get(str(name))
    if found is None:
        raise ConfigError(f"unknown glass {name!r}; valid: {', '.join(GLASS_NAMES)}")
    return found


def singlet_focal_length(focal_length_d, crown: Glass, wavelength_nm) -> np.ndarray:
    """f(λ) = f_d·(n_d − 1)/(n(λ) − 1) of a thin singlet whose focal length at the d line is
    ``focal_length_d``."""
    nd = float(crown.index(LINES_NM["d"]))
    return focal_length_d * (nd - 1.0) / (crown.index(wavelength_nm) - 1.0)


def achromat_focal_length(focal_length_d, crown: Glass, flint: Glass, wavelength_nm) -> np.ndarray:
    """f(λ) of a thin cemented achromat (crown + flint in contact) of focal length
    ``focal_length_d`` at the d line, its F and C foci made to coincide."""
    v1, v2 = crown.abbe_number, flint.abbe_number
    if not v1 > v2:
        raise ConfigError(f"an achromat pairs a crown with a flint of lower Abbe number; {crown.name} "
                          f"(νd {v1:.1f}) + {flint.name} (νd {v2:.1f}) does not: give the crown first")
    power = 1.0 / focal_length_d
    p1, p2 = power * v1 / (v1 - v2), -power * v2 / (v1 - v2)
    n1d, n2d = (float(g.index(LINES_NM["d"])) for g in (crown, flint))
    total = p1 * (crown.index(wavelength_nm) - 1.0) / (n1d - 1.0) + p2 * (flint.index(wavelength_nm) - 1.0) / (n2d - 1.0)
    return 1.0 / total


def thin_lens_focal_length(spec: str, focal_length_d, wavelength_nm) -> np.ndarray:
    """f(λ) of ``lens.glass``: ``"N-BK7"`` (a singlet) or ``"N-BK7+F2"`` (crown + flint achromat)."""
    names = [part.strip() for part in str(spec).split("+")]
    if len(names) == 1:
        return singlet_focal_length(focal_length_d, glass(names[0]), wavelength_nm)
    if len(names) == 2:
        return achromat_focal_length(focal_length_d, glass(names[0]), glass(names[1]), wavelength_nm)
    raise ConfigError(f"lens.glass = {spec!r}: give one glass (a singlet, e.g. \"N-BK7\") or a crown and a flint "
                      "(an achromat, e.g. \"N-BK7+F2\")")
