"""Keep ``import colour`` from importing matplotlib.

colour-science's ``__init__`` runs ``from colour import plotting``, and ``colour.plotting``
imports matplotlib (~0.6 s of a ~1.3 s ``import colour`` on these machines), although nothing
but plotting needs it. Before colour is first imported, :func:`defer_colour_plotting` puts a
stand-in module at ``colour.plotting`` whose module ``__getattr__`` (PEP 562) loads the real
package on the first name looked up in it — by a user, never by spectral_cam — and then
replaces itself everywhere. (:class:`importlib.util.LazyLoader` cannot do this on Python 3.11:
the import system reads ``__spec__``, which loads a lazy module at once.)
"""

from __future__ import annotations

import importlib.util
import sys
import types
from pathlib import Path

_NAME = "colour.plotting"


class _DeferredModule(types.ModuleType):
    """``colour.plotting`` until a name in it is used."""

    def __getattr__(self, name: str):
        if name.startswith("__") and name.endswith("__"):
            raise AttributeError(name)
        return getattr(_load(self), name)


def _load(stand_in: types.ModuleType) -> types.ModuleType:
    loaded = stand_in.__dict__.get("_loaded")
    if loaded is not None:  # code that holds the stand-in (``from colour import plotting``)
        return loaded
    real = importlib.util.module_from_spec(stand_in.__spec__)
    sys.modules[_NAME] = real
    try:
        stand_in.__spec__.loader.exec_module(real)
    except BaseException:
        sys.modules[_NAME] = stand_in
        raise
    stand_in.__dict__["_loaded"] = real
    parent = sys.modules.get("colour")
    if parent is not None:
        parent.plotting = real
    return real


def defer_colour_plotting() -> None:
    """Put the stand-in in place (a no-op once colour is imported, or without colour-science)."""
    if "colour" in sys.modules or _NAME in sys.modules:
        return
    package = importlib.util.find_spec("colour")  # locates colour without executing it
    if package is None or not package.submodule_search_locations:
        return
    folder = Path(next(iter(package.submodule_search_locations))) / "plotting"
    spec = importlib.util.spec_from_file_location(_NAME, folder / "__init__.py",
                                                  submodule_search_locations=[str(folder)])
    if spec is None or spec.loader is None:
        return
    stand_in = _DeferredModule(_NAME)
    stand_in.__spec__, stand_in.__path__, stand_in.__file__ = spec, [str(folder)], str(folder / "__init__.py")
    stand_in.__loader__, stand_in.__package__ = spec.loader, _NAME
    sys.modules[_NAME] = stand_in
