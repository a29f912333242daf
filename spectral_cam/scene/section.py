"""A scene file's sections, assembled from the keys their owners declare.

Each section (``[scene]``, ``[sensor]``, …) is a frozen dataclass built by
:func:`section_class` from :class:`~spectral_cam.keys.Key` declarations: the section's own
(:mod:`.sections`) and those of the registries that extend it — presets add ``scene.*`` keys,
sensor kinds ``sensor.*``, lens models ``lens.*`` (:data:`EXTENDERS`). A class is rebuilt when
a registry gains keys (a user's module registering a kind), so a key is declared in one place
only. An instance checks every key when made and pickles by its values, so it crosses processes
(Dask workers) whatever class the other side built.

References
----------
.. [1] Python, ``dataclasses.make_dataclass``.
.. [2] docs/design.md, "Scene file" and "Where to make a change".
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Callable

from ..errors import ConfigError
from ..keys import Key, declared_once

__all__ = ["Section", "SectionSpec", "section_class", "section_keys", "SECTION_SPECS", "EXTENDERS", "fail"]


def fail(key: str, value: Any, rule: str) -> None:
    """Refuse ``key = value`` saying the rule it breaks."""
    raise ConfigError(f"{key} = {value!r}: {rule}")


@dataclass(frozen=True)
class SectionSpec:
    """A section's own declaration: its keys, its class's docstring, the properties it computes and
    the checks of key combinations (``check(section) -> (key, value, rule) | None``)."""

    name: str
    class_name: str
    doc: str
    keys: tuple[Key, ...]
    properties: dict = field(default_factory=dict)
    checks: tuple[Callable, ...] = ()
    owner: str = ""


#: section name -> its :class:`SectionSpec` (filled by :mod:`.sections`).
SECTION_SPECS: dict[str, SectionSpec] = {}

#: section name -> functions returning ``(owner, Key)`` pairs and the chosen entry's checks
#: ``(section) -> [check, ...]``: the registries that add keys to it (filled by :mod:`.sections`).
EXTENDERS: dict[str, tuple[Callable[[], list], Callable[[Any], tuple]]] = {}


class Section:
    """Base of every built section: checks its keys when made, pickles by value."""

    _section_name = ""
    _keys: tuple[Key, ...] = ()

    def __post_init__(self) -> None:
        for key in self._keys:  # lists from Python callers become tuples, as from a scene file
            if isinstance(getattr(self, key.name), list):
                object.__setattr__(self, key.name, tuple(getattr(self, key.name)))
        for key in self._keys:
            problem = key.problem(self._section_name, self)
            if problem:
                name, value, rule = problem
                # a list key's value is echoed as the scene file writes it ([1.0, 2.0], not a tuple)
                fail(name, list(value) if isinstance(value, tuple) else value, rule)
        spec = SECTION_SPECS[self._section_name]
        extra = EXTENDERS[self._section_name][1](self) if self._section_name in EXTENDERS else ()
        for check in (*spec.checks, *extra):
            problem = check(self)
            if problem:
                fail(*problem)

    def __reduce__(self):
        return _rebuild, (self._section_name, {f.name: getattr(self, f.name) for f in dataclasses.fields(self)})


def _rebuild(name: str, values: dict) -> Section:
    return section_class(name)(**values)


def section_keys(name: str) -> list[tuple[str, Key]]:
    """``(owner, Key)`` of every key of section ``name``: its own, then the registries'."""
    spec = SECTION_SPECS[name]
    groups = [(spec.owner or f"[{name}]", spec.keys)]
    if name in EXTENDERS:
        declared = EXTENDERS[name][0]()
        groups += [(owner, (key,)) for owner, key in declared]
    return declared_once(groups)


_BUILT: dict[str, tuple[tuple, type]] = {}


def section_class(name: str) -> type:
    """The frozen dataclass of section ``name`` for the keys declared now (built once per set of
    declarations)."""
    keyed = section_keys(name)
    signature = tuple((owner, id(key)) for owner, key in keyed)
    built = _BUILT.get(name)
    if built is None or built[0] != signature:
        built = (signature, _build(SECTION_SPECS[name], keyed))
        _BUILT[name] = built
    return built[1]


def _build(spec: SectionSpec, keyed: list[tuple[str, Key]]) -> type:
    keys = tuple(key for _, key in keyed)
    fields = [(key.name, key.type, field(default=key.default)) for key in keys]
    doc = spec.doc + "\n\n    Keys\n    ----\n" + "\n".join(
        f"    {key.name} : {key.type}, default {key.default_text()} ({owner})\n        {key.doc}" for owner, key in keyed)
    namespace = {"__doc__": doc, "_section_name": spec.name, "_keys": keys, "__module__": "spectral_cam.scene",
                 **spec.properties}
    return dataclasses.make_dataclass(spec.class_name, fields, bases=(Section,), frozen=True, namespace=namespace)
