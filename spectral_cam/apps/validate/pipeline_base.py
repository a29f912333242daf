"""The pipeline-type registry and what every pipeline type shares.

:data:`PIPELINES` maps a plan's ``[[pipeline]]`` ``type`` to a :class:`Pipeline` subclass,
registered with :func:`pipeline_type` (which names the plan keys it accepts besides ``name``
and ``type``); :class:`CellContext` is what a pipeline may know of the cell it develops. The
built-in types live in :mod:`.pipelines` (ours, rawpy, callable) and :mod:`.command_pipeline`
(command); plan parsing, ``plan.json`` and the error messages read the registry
(docs/design.md, "Registries").

References
----------
.. [1] docs/design.md, "Registries" and "Where to make a change".
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import ConfigError
from ...registry import Registry

__all__ = ["PIPELINES", "Pipeline", "CellContext", "pipeline_type", "check_choice"]

#: Pipeline types: name → the class; its entry's ``options`` are the plan keys it accepts.
PIPELINES = Registry("pipeline type")


def pipeline_type(name: str, *, options: tuple[str, ...], description: str):
    """Class decorator: register a :class:`Pipeline` subclass in :data:`PIPELINES` under ``name``.

    Parameters
    ----------
    name : str
        The plan's ``type``.
    options : tuple of str
        Plan keys the type accepts besides ``name`` and ``type``: its constructor's keyword
        arguments and attributes (``plan.json`` lists them).
    description : str
        One line for messages.
    """

    def decorate(cls):
        cls.kind = name
        PIPELINES.add(name, cls, options=options, description=description)
        return cls

    return decorate


@dataclass(frozen=True)
class CellContext:
    """What a pipeline may know of the cell it develops (a callable's ``context``; a command's
    ``$SPECTRAL_CAM_CONTEXT`` JSON file): the chart's layout and what lit and exposed it.

    Attributes
    ----------
    set_name, illuminant, camera, exposure : str
        The cell's coordinates (the illuminant as the plan names it).
    frame_size : (int, int)
        (width, height) of the developed frame, pixels.
    patches : list of dict
        Every patch: ``name``, centre ``column``/``row`` and ``half_width_px``/``half_height_px``
        (pixels, 0 at the frame's top-left corner), ``role`` (``"patch"`` or
        ``"white reference"``).
    white_index : int
        The white reference's place in ``patches``: the metric scales exposure and measures
        white balance on it, so a pipeline that balances on it scores 0° there.
    exposure_s, iso : float
        What the sensor did.
    """

    set_name: str
    illuminant: str
    camera: str
    exposure: str
    frame_size: tuple
    patches: list
    white_index: int
    exposure_s: float
    iso: float

    def to_dict(self) -> dict:
        import dataclasses

        return dataclasses.asdict(self)


class Pipeline(abc.ABC):
    """A pipeline under test: turns one RAW into a linear sRGB image of the whole frame."""

    #: The registered type name (set by :func:`pipeline_type`).
    kind = ""
    #: Plan keys a type cannot do without → how to write them (for the error message).
    required: dict[str, str] = {}

    def __init__(self, name: str):
        self.name = name

    @classmethod
    def from_table(cls, name: str, options: Mapping[str, Any], *, base_dir: Path, where: str) -> "Pipeline":
        """The pipeline of a plan's ``[[pipeline]]`` table (``options``: its keys but ``name``
        and ``type``, already checked against the registry)."""
        for key, hint in cls.required.items():
            if key not in options:
                raise ConfigError(f"{where}: a {cls.kind} pipeline needs {hint}")
        return cls(name, **options)

    @abc.abstractmethod
    def develop(self, raw, dng_path: Path, workdir: Path, context: "CellContext | None" = None) -> np.ndarray:
        """Develop a RAW.

        Parameters
        ----------
        raw : RawImage
            The exposed RAW in memory (with the simulator's metadata).
        dng_path : pathlib.Path
            The same RAW written as a DNG.
        workdir : pathlib.Path
            A scratch folder.
        context : CellContext, optional
            What the cell is: the chart's layout, the illuminant, the camera, the exposure.

        Returns
        -------
        numpy.ndarray
            (H, W, 3) linear sRGB (D65), unclipped; any exposure scale.
        """

    @abc.abstractmethod
    def describe(self) -> str:
        """One line for the report."""

    def to_dict(self) -> dict:
        """JSON-friendly settings (for plan.json): name, type and every option of the type."""
        out: dict[str, Any] = {"name": self.name, "type": self.kind}
        for key in PIPELINES[self.kind].options:
            value = getattr(self, key)
            out[key] = value.to_dict() if hasattr(value, "to_dict") else list(value) if isinstance(value, tuple) \
                else value
        return out


def check_choice(name: str, key: str, value: Any, valid: Sequence[str], *, fold: bool = False, note: str = "",
                 after: str = "") -> str:
    """A pipeline option checked: ``value`` if it is one of ``valid`` (any case with ``fold``,
    then spelled as ``valid`` spells it), else a :class:`ConfigError` listing the valid ones."""
    spelled = {(v.casefold() if fold else v): v for v in valid}
    key_of = str(value).casefold() if fold else value
    if not isinstance(key_of, str) or key_of not in spelled:
        raise ConfigError(f"pipeline {name!r}: {key} = {value!r}; valid{note}: {', '.join(valid)}{after}")
    return spelled[key_of]
