"""The shape of a bladed aperture: the boundary of a regular polygon of straight blades, rounded
towards the circle, as one formula for NumPy arrays and drjit variables alike (the thin-lens camera
tabulates it, the prescription camera tests each ray at the stop against it).

References
----------
.. [1] Merklinger, H. M. (1997). A technical view of bokeh. Photo Techniques 18(3) (polygonal
   openings and their bokeh).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["rounded_boundary"]


def rounded_boundary(phi, blades: int, rotation: float, rounding: float, xp=np):
    """Radius (fraction of the circle's) of the opening at angle ``phi`` (from +y towards +x): the
    regular ``blades``-gon inscribed in the circle, a vertex at ``rotation``, blended with the
    circle by ``rounding`` (0: straight blades, 1: the circle), r = (1 − ρ)·r_gon + ρ.
    ``xp``: the array module of ``phi`` (``numpy`` or ``drjit``)."""
    sector = 2 * math.pi / blades
    local = phi - rotation
    local = local - sector * xp.floor(local / sector) - sector / 2
    return (1.0 - rounding) * math.cos(math.pi / blades) / xp.cos(local) + rounding
