"""spectral_cam — a spectral, path-traced scene-to-sensor camera simulator.

The chain, one package per stage (docs/design.md, "Architecture")::

    load_scene (scene.py, presets/) -> render (render/, Mitsuba 3) -> expose (sensor/)
        -> write_dng / read_raw (raw/) -> develop (isp/) -> metrics/

Heavy modules (Mitsuba, OpenEXR) are imported on first use.
"""

from __future__ import annotations

import importlib

from ._lazy_colour import defer_colour_plotting

defer_colour_plotting()  # before anything imports colour: its plotting (matplotlib) loads on use

from .errors import ConfigError, RawFormatError, RenderError, SensorError, SpectralCamError  # noqa: E402
from .scene import SceneConfig, load_scene, scene_from_dict

from .image import SpectralImage

# imported eagerly so that the function, not the subpackage of the same name, is
# ``spectral_cam.render`` (render/ imports Mitsuba only when it renders)
from .render import render

__version__ = "0.1.0"

_LAZY = {
    "ThinLens": ("optics", "ThinLens"),
    "write_spectral_exr": ("spectral_exr", "write_spectral_exr"),
    "read_spectral_exr": ("spectral_exr", "read_spectral_exr"),
    "expose": ("sensor", "expose"),
    "expose_photon_counting": ("sensor.photon_counting", "expose_photon_counting"),
    "RawImage": ("raw", "RawImage"),
    "write_dng": ("raw", "write_dng"),
    "read_raw": ("raw", "read_raw"),
    "develop": ("isp", "develop"),
    "ISPConfig": ("isp", "ISPConfig"),
}

__all__ = [
    "SpectralCamError", "ConfigError", "RenderError", "SensorError", "RawFormatError",
    "SceneConfig", "load_scene", "scene_from_dict", "render", "SpectralImage", *_LAZY,
]


def __getattr__(name: str):
    if name in _LAZY:
        module, attribute = _LAZY[name]
        return getattr(importlib.import_module(f".{module}", __name__), attribute)
    raise AttributeError(f"module 'spectral_cam' has no attribute {name!r}")
