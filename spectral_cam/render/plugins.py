"""Our Mitsuba plugins written in Python (cameras, the leaf BSDF, integrators), registered with
Mitsuba once per variant and process.

A Python plugin subclasses the active variant's ``mi.Sensor``, ``mi.BSDF`` or
``mi.SamplingIntegrator``, which exist only once ``mi.set_variant`` has run and are other classes
in each variant, so each plugin's class is made by a function of ``mi`` and registered for every
variant it is used in.

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3, "Custom plugins in Python" (``mi.register_sensor``,
   ``mi.register_bsdf``, ``mi.register_integrator``).
"""

from __future__ import annotations

from typing import Callable

__all__ = ["register_once"]

_REGISTERED: set[tuple[str, str, str]] = set()


def register_once(mi, kind: str, name: str, make_class: Callable) -> None:
    """``mi.register_<kind>(name, ...)`` (``kind``: ``"sensor"``, ``"bsdf"``, ``"integrator"``) for
    the current variant, once per process; ``make_class(mi)`` builds the variant's subclass."""
    key = (mi.variant(), kind, name)
    if key in _REGISTERED:
        return
    cls = make_class(mi)
    getattr(mi, f"register_{kind}")(name, lambda props: cls(props))
    _REGISTERED.add(key)
