"""The sensor-kind registry (``sensor.kind``): what an entry declares, and the one capture function.

An entry (:class:`SensorKind`) declares everything the rest of the package asks of a kind (its
capture, keys, files, memory, whether sequences take it); the bundled entries are registered in
:mod:`.kinds`. This module imports nothing of the sensor model, so the model's own modules
(``expose()``, photon counting) can ask the registry about a kind without an import cycle.

References
----------
.. [1] colour-science, method mappings (named entries with their functions): one mapping per
   extension point.
.. [2] docs/design.md, "Sensor (`sensor/`)" (its "Sensor kinds" entry).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from ..errors import ConfigError
from ..keys import Key
from ..registry import Entry, Registry

__all__ = ["SensorKind", "SensorKinds", "SensorFile", "SensorCapture", "kind_key", "SENSOR_KINDS", "capture",
           "validate_sensor_keys", "sensor_file"]


def kind_key(name: str, default: float, low: float, high: float, what: str, *, whole: bool = False,
             rule: str = "") -> Key:
    """A ``sensor.*`` key a kind owns: a number in ``low..high`` (a whole number with ``whole``), its
    default ``default``; ``what`` says what it is (the message reads ``sensor.<key> = <value>: <what>, a
    number in <low>..<high>``), ``rule`` replaces that whole message when given."""
    def check(value, sensor):
        kinds = int if whole else (int, float)
        if isinstance(value, kinds) and not isinstance(value, bool) and low <= value <= high:
            return None
        return rule or f"{what}, a {'whole number' if whole else 'number'} in {low:g}..{high:g}"
    return Key(name, default, "int" if whole else "float", rule or what, (check,))


@dataclass(frozen=True)
class SensorFile:
    """An extra result file a kind writes (a name among :data:`spectral_cam.job.RESULT_FILES`).

    Attributes
    ----------
    name : str
        The result-file name (``"photon_counts"``), the key of the capture's ``outputs``.
    files : tuple of str
        The file names written in the folder.
    write : callable
        ``write(output, folder) -> list[Path]``: the capture's output into the folder.
    read : callable
        ``read(folder) -> object``: the file(s) back from a result folder.
    size_bytes : callable
        ``size_bytes(config) -> float``: the files' size from the config alone, before rendering
        (an upper bound for the disk check, :func:`spectral_cam.budget.estimate_result_bytes`).
    description : str
        One line for help texts.
    """

    name: str
    files: tuple[str, ...]
    write: Callable[[Any, Path], list]
    read: Callable[[Path], Any]
    size_bytes: Callable[[Any], float]
    description: str = ""


@dataclass
class SensorCapture:
    """What a capture made: the RAW the ISP develops, the kind's own outputs (by :class:`SensorFile`
    name) and seconds of stages besides the sensor's own (``{"events": ...}``)."""

    raw: Any
    outputs: dict = field(default_factory=dict)
    timings_s: dict = field(default_factory=dict)


def _no_bytes(config) -> float:
    return 0.0


@dataclass(frozen=True)
class SensorKind(Entry):
    """One ``sensor.kind``: :class:`~spectral_cam.registry.Entry` whose function is its capture,
    ``capture(radiance, config, *, frame_seed=None, render_pose=None) -> SensorCapture``.

    ``render_pose(frame_config) -> SpectralImage`` renders one more pose of the scene (no margin,
    no depth): the job passes it for a kind that needs renders of its own (an event sensor's span);
    it is None in a sequence. :func:`spectral_cam.sensor.expose` is the integrating (CMOS) model and
    takes ``sensor.kind = "cmos"`` only: a kind built on it exposes ``config.replace(**{"sensor.kind":
    "cmos"})`` (as the event sensor's APS frame does). ``outputs_noun`` names its outputs in a memory
    message (``"count frames"``); ``direct_use`` says how to capture it outside the job (the message of
    ``expose()`` refusing it).
    """

    keys: tuple[Key, ...] = ()
    exclusive_keys: tuple[str, ...] = ()
    exclusive_rule: str = ""
    files: tuple[SensorFile, ...] = ()
    sequences: bool = True
    sequence_refusal: str = ""
    memory_bytes_per_pixel: Callable[[Any], float] = _no_bytes
    memory_remedy: Callable[[Any, float], str | None] | None = None
    outputs_noun: str = "outputs"
    direct_use: str = ""


class SensorKinds(Registry):
    """The registry of :class:`SensorKind` entries (a :class:`~spectral_cam.registry.Registry`)."""

    def add_kind(self, kind: SensorKind) -> SensorKind:
        """Register a :class:`SensorKind` (a name can be registered once); the keys it declares are among
        its options, as for any registry entry."""
        if kind.name in self._entries:
            raise ValueError(f"{self.kind} {kind.name!r} is registered twice")
        missing = tuple(key.name for key in kind.keys if key.name not in kind.options)
        if missing:
            kind = dataclasses.replace(kind, options=kind.options + missing)
        self._entries[kind.name] = kind
        return kind

    def remove(self, name: str) -> None:
        """Unregister a kind (a test's toy entry)."""
        self._entries.pop(name, None)

    def files(self) -> dict[str, SensorFile]:
        """Every kind's extra files by name, in registration order."""
        out: dict[str, SensorFile] = {}
        for entry in self._entries.values():
            out.update({f.name: f for f in entry.files if f.name not in out})
        return out


#: ``sensor.kind`` → :class:`SensorKind`.
SENSOR_KINDS = SensorKinds("sensor kind")


def capture(radiance, config, *, frame_seed: int | None = None, render_pose: Callable | None = None,
            sequence: bool = False) -> SensorCapture:
    """Expose ``config.sensor.kind`` to a rendered radiance image: the one capture of the render job and
    the sequence.

    Parameters
    ----------
    radiance : SpectralImage
        The render (with the sensor's crop margin).
    config : SceneConfig
        The resolved scene.
    frame_seed : int, optional
        The noise draw (default ``render.seed``): a sequence's frame index.
    render_pose : callable, optional
        Renders one more pose of the scene (see :class:`SensorKind`); None where none can be made.
    sequence : bool
        The capture is a sequence's frame: a kind with ``sequences = False`` is refused.

    Raises
    ------
    ConfigError
        For an unknown kind, or a kind a sequence does not take.
    """
    entry = SENSOR_KINDS[config.sensor.kind]
    if sequence and not entry.sequences:
        raise ConfigError(entry.sequence_refusal or f"sensor.kind = {entry.name!r} cannot be a sequence's frame")
    return entry.function(radiance, config, frame_seed=frame_seed, render_pose=render_pose)


def validate_sensor_keys(sensor) -> tuple[str, Any, str] | None:
    """The problem ``(key, value, rule)`` of ``sensor.kind``, or of a key set for a kind it does not
    belong to (each kind's own keys are checked by the section, as declared)."""
    if sensor.kind not in SENSOR_KINDS:
        return "sensor.kind", sensor.kind, "valid: " + ", ".join(
            f"{name!r} ({entry.description})" for name, entry in SENSOR_KINDS.items())
    for entry in SENSOR_KINDS.values():
        stray = [key for key in entry.exclusive_keys if getattr(sensor, key)]
        if sensor.kind != entry.name and stray:
            return f"sensor.{stray[0]}", getattr(sensor, stray[0]), entry.exclusive_rule
    return None


def sensor_file(name: str) -> SensorFile | None:
    """The :class:`SensorFile` called ``name`` among every kind's, or None."""
    return SENSOR_KINDS.files().get(name)
