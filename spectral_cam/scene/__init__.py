"""A scene file (TOML) read into a validated, frozen :class:`SceneConfig`, whose sections are
assembled from the keys their owners declare.

- :mod:`.config`: :class:`SceneConfig`, reading (:func:`load_scene`, :func:`scene_from_dict`),
  overrides and TOML writing;
- :mod:`.section`: how a section is built from :class:`~spectral_cam.keys.Key` declarations;
- :mod:`.sections` and :mod:`.camera_sections`: the keys each section declares itself, and the
  registries that add theirs (presets → ``[scene]``, lens models → ``[lens]``, sensor kinds →
  ``[sensor]``);
- :mod:`.key_table`: the key listing of ``spectral-cam keys``, ``--help`` and README.

The section classes (``SceneSection``, ``SensorSection``, …) are built from the declarations
when first asked for, and rebuilt when a registry gains keys.

References
----------
.. [1] docs/design.md, "Scene file" (the key names are a contract) and "Where to make a change".
"""

from __future__ import annotations

from typing import Any

from ..cfa import CFA_PATTERNS
from ..isp.config import ISPConfig as ISPSection
from ..presets import GROUND_KINDS, OBJECT_MATERIALS, PRESETS, SCENE_LIGHTS
from . import sections as _sections  # noqa: F401  (declares the sections)
from .config import SECTION_NAMES, SceneConfig, load_scene, parse_override, physical_ranges, read_toml, \
    scene_from_dict, section_from_table
from .section import section_class
from .sections import (BAND_MODES, DIFFRACTION_MODES, MAX_SPP, RADIANCE_PRECISIONS, RENDER_ESTIMATORS,
                       RENDER_SAMPLERS, SPECTRAL_BANDS_DEFAULT)

__all__ = [
    "SceneConfig",
    "SceneSection",
    "IlluminantSection",
    "LensSection",
    "SensorSection",
    "ExposureSection",
    "RenderSection",
    "ISPSection",
    "SkySection",
    "MotionSection",
    "SCENE_LIGHTS",
    "OBJECT_MATERIALS",
    "GROUND_KINDS",
    "load_scene",
    "scene_from_dict",
    "section_from_table",
    "section_class",
    "parse_override",
    "read_toml",
    "PRESETS",
    "CFA_PATTERNS",
    "SECTION_NAMES",
    "MAX_SPP",
    "RENDER_SAMPLERS",
    "RENDER_ESTIMATORS",
    "RADIANCE_PRECISIONS",
    "DIFFRACTION_MODES",
    "BAND_MODES",
    "SPECTRAL_BANDS_DEFAULT",
]

#: class name -> section name, for the classes built from the declarations.
_CLASSES = {"SceneSection": "scene", "IlluminantSection": "illuminant", "SkySection": "sky",
            "LensSection": "lens", "SensorSection": "sensor", "ExposureSection": "exposure",
            "MotionSection": "motion", "RenderSection": "render"}


def __getattr__(name: str) -> Any:
    """The section classes as declared now, and ``PHYSICAL_RANGES`` (every declared key's range)."""
    if name in _CLASSES:
        return section_class(_CLASSES[name])
    if name == "PHYSICAL_RANGES":
        return physical_ranges()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
