"""Scene keys declared by their owners: :class:`Key`, and the checks a key's value must pass.

Every ``section.key`` of a scene file is a :class:`Key` declared once, by the code that reads it:
the scene's own sections (:mod:`spectral_cam.scene.sections`), each preset
(``PRESETS.register(..., keys=...)``), each sensor kind (``SensorKind(keys=...)``) and each lens
model (``LENS_MODELS.add(..., keys=...)``). :mod:`spectral_cam.scene` assembles the sections from
the declarations, so a new preset, kind or model brings its keys with it, and the error messages,
``spectral-cam keys`` and README's key table are written from the same declarations.

A check is ``check(value, section) -> None | str | (key, value, rule)``: None passes, a string
is the rule the value breaks (said as ``section.key = value: rule``), a triple names another key
(a combination refused on the key that should change). ``section`` is the section being built,
so a check can read the keys declared before it.

References
----------
.. [1] colour-science, method mappings: each method declares what it takes.
.. [2] docs/design.md, "Scene file" and "Where to make a change".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Iterable

__all__ = ["Key", "Problem", "number_in", "whole_in", "one_of", "boolean", "fraction_in", "triple_within",
           "is_number", "declared_once", "non_negative_whole"]

#: What a check returns: None (fine), a rule for this key, or (key, value, rule) naming another.
Problem = None | str | tuple[str, Any, str]


@dataclass(frozen=True)
class Key:
    """One scene key, declared by the code that reads it.

    Attributes
    ----------
    name : str
        The key within its section (``"jot_frames"``).
    default : object
        Its value when a scene file leaves it unset (the ``[sensor]`` defaults of a named camera are
        :func:`spectral_cam.spectra.with_camera_figures`'s).
    type : str
        The TOML value types it takes, as an annotation: ``"float"``, ``"int | str"``,
        ``"tuple[float, ...]"`` (a list). Integers are taken for floats, lists become tuples.
    doc : str
        What it is, with units and the values it takes: one line for help texts and README's table.
    checks : tuple of callable
        ``check(value, section) -> Problem`` (module docstring), run in order.
    entries : callable, optional
        For an array of tables (``[[scene.assets]]``): ``parse(table, index, base_dir)`` per entry.
    range : (low, high, unit), optional
        A physical key's valid range (each number of a list's): checked first, and listed in
        ``scene.PHYSICAL_RANGES`` and docs/design.md's table of ranges.
    """

    name: str
    default: Any
    type: str
    doc: str
    checks: tuple[Callable[[Any, Any], Problem], ...] = ()
    entries: Callable | None = None
    range: tuple[float, float, str] | None = None

    def problem(self, section_name: str, section) -> tuple[str, Any, str] | None:
        """The first ``(key, value, rule)`` the section's value breaks, or None."""
        value = getattr(section, self.name)
        if self.range is not None and not isinstance(value, str):  # a word ("auto") is for the checks
            low, high, unit = self.range
            for number in (value if isinstance(value, tuple) else (value,)):
                rule = number_in(low, high, unit)(number, section)
                if rule:
                    return f"{section_name}.{self.name}", number, rule
        for check in self.checks:
            found = check(value, section)
            if isinstance(found, str):
                return f"{section_name}.{self.name}", value, found
            if found is not None:
                return found
        return None

    def default_text(self) -> str:
        """The default as a scene file writes it (for help texts)."""
        value = self.default
        if isinstance(value, bool):
            return "true" if value else "false"
        if isinstance(value, tuple):
            return "[" + ", ".join(_plain(v) for v in value) + "]"
        return _plain(value)


def _plain(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, str):
        return f'"{value}"'
    return str(value)


def is_number(value: Any) -> bool:
    """A finite int or float (not a bool)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def number_in(low: float, high: float, unit: str = "", *, rule: str = "", open_low: bool = False) -> Callable:
    """A finite number in ``[low, high]`` (``(low, high]`` with ``open_low``); the message gives the range
    and unit (or ``rule``)."""
    def check(value, section) -> Problem:
        if is_number(value) and (low < value if open_low else low <= value) and value <= high:
            return None
        return rule or f"must be a number in [{low:g}, {high:g}]" + (f" {unit}" if unit else "")
    return check


def fraction_in(low: float, high: float, rule: str, *, open_low: bool = False) -> Callable:
    """A float in ``[low, high]`` (``(low, high]`` with ``open_low``), refused with ``rule``."""
    def check(value, section) -> Problem:
        inside = isinstance(value, float) and (low < value if open_low else low <= value) and value <= high
        return None if inside else rule
    return check


def whole_in(low: int, high: int, rule: str = "") -> Callable:
    """A whole number (an int, not a bool) in ``low..high``."""
    def check(value, section) -> Problem:
        if isinstance(value, int) and not isinstance(value, bool) and low <= value <= high:
            return None
        return rule or f"must be a whole number in {low}..{high}"
    return check


def non_negative_whole() -> Callable:
    """A whole number >= 0 (a seed)."""
    return whole_in(0, 2 ** 63, "must be a whole number >= 0")


def one_of(values: Iterable[str] | Callable[[], Iterable[str]], rule: str = "") -> Callable:
    """One of ``values`` (or of what ``values()`` returns when checked: a live registry's names)."""
    def check(value, section) -> Problem:
        valid = list(values() if callable(values) else values)
        if value in valid:
            return None
        return f"valid: {', '.join(map(str, valid))}" + (f" ({rule})" if rule else "")
    return check


def boolean(rule: str = "must be true or false") -> Callable:
    """true or false."""
    def check(value, section) -> Problem:
        return None if isinstance(value, bool) else rule
    return check


def triple_within(bound: float) -> Callable:
    """Three finite numbers within ±``bound`` (a vector or three angles)."""
    def check(value, section) -> Problem:
        if len(value) == 3 and all(is_number(v) and abs(v) <= bound for v in value):
            return None
        return f"give three numbers within ±{bound:g}"
    return check


def declared_once(groups: Iterable[tuple[str, Iterable[Key]]]) -> list[tuple[str, Key]]:
    """``(owner, key)`` for every key of every owner, each name once: a key two owners declare must be
    the same declaration (one reads the other's), else :class:`ValueError` names both."""
    out: dict[str, tuple[str, Key]] = {}
    for owner, keys in groups:
        for key in keys:
            if key.name in out and out[key.name][1] != key:
                raise ValueError(f"scene key {key.name!r} is declared by {out[key.name][0]} and again, "
                                 f"differently, by {owner}: declare it once and let the other read it")
            out.setdefault(key.name, (owner, key))
    return list(out.values())
