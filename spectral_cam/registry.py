"""One registry shape for every extension point: name → :class:`Entry`.

Scene presets, ISP methods (white balance, demosaic, denoise, highlights, tone, encoders),
validation pipeline types, stress studies and benchmarks are all :class:`Registry` objects.
An entry names its function, the option keys it accepts and a one-line description, so
adding a demosaicer or a pipeline type is one ``@REGISTRY.register(...)`` in one place: the
config validation, the CLI help and the error messages read the registry.

References
----------
.. [1] Mitsuba 3, ``mi.register_bsdf``/``register_sensor`` (plugins registered by name).
.. [2] colour-science, method mappings such as ``colour.MSDS_CMFS`` and ``method=``
   arguments (a named mapping per extension point).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Callable, Iterator

from .errors import ConfigError

__all__ = ["Entry", "Registry"]


@dataclass(frozen=True)
class Entry:
    """One registered implementation.

    Attributes
    ----------
    name : str
        The name users write (a scene key's value, a plan's ``type``, a CLI argument).
    function : callable
        The implementation.
    options : tuple of str
        Option keys the entry accepts besides the common ones (empty: none).
    description : str
        One line for help texts and error messages.
    keys : tuple of Key
        Scene keys the entry declares (:class:`spectral_cam.keys.Key`): a preset's own ``scene.*``
        keys, which the scene's section is assembled from (keys it only reads are in ``options``).
    checks : tuple of callable
        ``check(section) -> (key, value, rule) | None``: combinations of keys refused when this
        entry is the one chosen (a preset's ``dof_targets needs three depths``).
    """

    name: str
    function: Callable
    options: tuple[str, ...] = ()
    description: str = ""
    # keyword-only, so subclasses' positional fields (a Label's files, reader, ...) keep their places
    keys: tuple = field(default=(), kw_only=True)
    checks: tuple = field(default=(), kw_only=True)

    def __call__(self, *args, **kwargs):
        return self.function(*args, **kwargs)


class Registry(Mapping):
    """A named mapping of :class:`Entry` objects, read-only except through :meth:`register`.

    Parameters
    ----------
    kind : str
        What the entries are, for messages (``"demosaic method"``, ``"scene preset"``).
    entry : type
        The :class:`Entry` subclass its entries are (default :class:`Entry`); its own fields are
        given to :meth:`register` and :meth:`add` as keywords (a scene preset's
        ``sharp_materials``).

    Examples
    --------
    >>> DEMO = Registry("greeting")
    >>> @DEMO.register("hello", options=("name",), description="says hello")
    ... def hello(name="world"):
    ...     return f"hello {name}"
    >>> DEMO["hello"](name="you")
    'hello you'
    >>> DEMO.check_options("hello", {"name": "x"})
    >>> list(DEMO)
    ['hello']
    >>> DEMO["bye"]
    Traceback (most recent call last):
    ...
    spectral_cam.errors.ConfigError: unknown greeting 'bye'; valid: hello
    """

    def __init__(self, kind: str, *, entry: type = Entry):
        self.kind = kind
        self.entry = entry  # an Entry subclass whose extra fields register() and add() pass on
        self._entries: dict[str, Entry] = {}

    def register(self, name: str, *, options: tuple[str, ...] = (), description: str = "", keys: tuple = (),
                 checks: tuple = (), **fields):
        """Decorator: register the decorated function under ``name`` (``fields``: the entry
        type's own)."""

        def decorate(function: Callable) -> Callable:
            self.add(name, function, options=options, description=description, keys=keys, checks=checks, **fields)
            return function

        return decorate

    def add(self, name: str, function: Callable, *, options: tuple[str, ...] = (), description: str = "",
            keys: tuple = (), checks: tuple = (), **fields) -> Entry:
        """Register ``function`` under ``name`` (a name can be registered once); the keys it
        declares are among its options."""
        if name in self._entries:
            raise ValueError(f"{self.kind} {name!r} is registered twice")
        options = tuple(options) + tuple(k.name for k in keys if k.name not in options)
        entry = self.entry(name, function, options, description, keys=tuple(keys), checks=tuple(checks), **fields)
        self._entries[name] = entry
        return entry

    def declared_keys(self) -> list[tuple[str, Any]]:
        """``(owner, Key)`` of every entry's declared keys, in registration order (the owner as
        ``"<kind> <name>"`` for messages and help)."""
        return [(f"{self.kind} {entry.name}", key) for entry in self._entries.values()
                for key in getattr(entry, "keys", ())]

    def __getitem__(self, name: str) -> Entry:
        try:
            return self._entries[name]
        except (KeyError, TypeError):
            raise ConfigError(f"unknown {self.kind} {name!r}; valid: {', '.join(self._entries)}") from None

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def names(self) -> tuple[str, ...]:
        """The registered names, in registration order."""
        return tuple(self._entries)

    def check(self, name: Any, *, key: str | None = None) -> str:
        """Return ``name`` if registered, else raise a :class:`ConfigError` listing the valid
        names (prefixed by the config ``key`` when given)."""
        if isinstance(name, str) and name in self._entries:
            return name
        where = f"{key} = {name!r}: " if key else ""
        raise ConfigError(f"{where}unknown {self.kind} {name!r}; valid: {', '.join(self._entries)}")

    def check_options(self, name: str, options: Mapping[str, Any], *, common: tuple[str, ...] = (),
                      where: str | None = None) -> None:
        """Raise a :class:`ConfigError` for option keys the entry does not declare."""
        entry = self[name]
        valid = (*common, *entry.options)
        unknown = [key for key in options if key not in valid]
        if unknown:
            place = where or f"{self.kind} {name!r}"
            raise ConfigError(f"{place}: unknown key(s) {', '.join(map(repr, unknown))}; "
                              f"valid: {', '.join(valid) or 'none'}")
