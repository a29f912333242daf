"""The exception tree of spectral_cam.

Every error a user can cause derives from :class:`SpectralCamError`, so the CLI can print
its message without a traceback and programs can catch one base class.
"""

from __future__ import annotations

__all__ = ["SpectralCamError", "ConfigError", "OutputPathError", "RenderError", "SensorError", "RawFormatError",
           "SceneWarning"]


class SpectralCamError(Exception):
    """Base class of every error spectral_cam raises on purpose."""


class ConfigError(SpectralCamError, ValueError):
    """A scene file, override or argument is invalid; the message says what would be valid."""


class OutputPathError(ConfigError, NotADirectoryError):
    """An output path cannot be made: a file or a dangling link stands where its folder must be.
    A :class:`ConfigError` for the user, and an ``OSError`` for code that treats any file-system
    refusal alike (a cache that cannot be written only costs its recomputation)."""


class RenderError(SpectralCamError, RuntimeError):
    """Mitsuba could not render the scene (bad scene file, no usable variant, ...)."""


class SensorError(SpectralCamError, ValueError):
    """The sensor model got input it cannot simulate (NaN or negative radiance, ...)."""


class RawFormatError(SpectralCamError, ValueError):
    """A RAW/DNG/EXR file is unreadable, truncated or lacks a required tag."""


class SceneWarning(UserWarning):
    """A scene setting that runs but does not do what it seems to: ``[illuminant]`` on an XML
    scene that its own emitters light, a focal length that replaces the XML camera's field of
    view. The CLI prints it as one line."""
