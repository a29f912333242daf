"""Scene presets: the geometry, materials and light of each ``scene.preset``, as Mitsuba
scene-dict entries, in one registry (:data:`PRESETS`).

A new preset is one function ``(config, lens, mi) -> dict`` registered with
``@PRESETS.register(name, options=(...keys it reads...), keys=(...Keys it declares...),
description=...)`` in a module of this package (and imported below); the ``[scene]`` section is
assembled from the declared keys (``keys`` holds those several presets read), and scene validation,
``spectral-cam keys`` and errors read the registry. ``common`` holds what presets share, ``charts`` the chart targets,
``depth_targets`` the depth-of-field and bokeh targets, ``dead_leaves`` the occluding-disc
texture target, ``cornell_box`` the Cornell box; ``outdoor`` the ground view and sun/sky
or lamp the outdoor presets share, ``tabletop`` objects on the ground, ``vegetation`` plants
on soil, ``meshes`` the procedural meshes; ``assets`` users' mesh files and ``scatter``
instanced ground clutter, added to an outdoor preset by ``[[scene.assets]]`` and
``[[scene.scatter]]``.

References
----------
.. [1] McCamy, Marcus & Davidson (1976), J. Applied Photographic Engineering 2(3).
.. [2] ISO 12233:2017 (slanted edge, 4:1 contrast).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from . import charts, cornell_box, dead_leaves, depth_targets, room, tabletop, vegetation  # noqa: F401  (each registers its presets)
from .charts import colorchecker_patches, white_reference_mask
from .common import EDGE_REFLECTANCES, PRESETS, Patch
from .keys import GROUND_KINDS, SCENE_LIGHTS, outdoor_presets, preset_keys
from .tabletop import OBJECT_MATERIALS

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

__all__ = ["PRESETS", "preset_keys", "outdoor_presets", "SCENE_LIGHTS", "GROUND_KINDS", "OBJECT_MATERIALS",
           "build_objects", "colorchecker_patches", "white_reference_mask", "Patch", "EDGE_REFLECTANCES"]


def build_objects(config: "SceneConfig", lens: "ThinLens", mi) -> dict:
    """Shapes and emitters of the configured preset as Mitsuba scene-dict entries
    (``mi`` must have a spectral variant set).

    References
    ----------
    .. [1] Jakob, W., et al. (2022). Mitsuba 3, ``mi.load_dict`` scene dictionaries.
    """
    objects = PRESETS[config.scene.preset](config, lens, mi)
    if config.scene.assets or config.scene.scatter:  # users' meshes and ground clutter (outdoor presets)
        from .assets import asset_objects
        from .scatter import check_instance_budget, scatter_objects

        check_instance_budget(config, lens)
        objects.update(asset_objects(config, lens, mi))
        objects.update(scatter_objects(config, lens, mi))
    return objects
