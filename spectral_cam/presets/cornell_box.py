"""The ``cornell_box`` preset: Mitsuba's Cornell box with measured ColorChecker spectra and
the configured illuminant as its area light.

References
----------
.. [1] Goral, C. M., Torrance, K. E., Greenberg, D. P., & Battaile, B. (1984). Modeling the
   interaction of light between diffuse surfaces. Proc. SIGGRAPH '84, 213–222.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .. import spectra
from ..colour_ground_truth import WHITE_PATCH
from .common import PRESETS, diffuse, light_irradiance, spectrum_dict

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig


@PRESETS.register("cornell_box", options=("distance_m",),
                  description="Mitsuba's Cornell box with measured spectra and the configured light")
def cornell_box(config: SceneConfig, lens: ThinLens, mi) -> dict:
    """Mitsuba's Cornell box with measured spectra: ColorChecker white, red and green patches
    for its walls and boxes, and the configured illuminant in its ceiling light.

    The box (2 units wide in Mitsuba's dict) is scaled so its back wall stands
    ``distance_m`` in front of the camera, keeping Mitsuba's framing (its camera sits 3.9
    units from the centre; a 39.3° field of view frames it). The light's radiance is set so
    that the floor's centre receives about ``illuminance_lux`` (small-source approximation
    E ≈ L·A/h²).
    """
    reference = mi.cornell_box()
    scale = config.scene.distance_m / 4.9  # camera to back wall: 3.9 + 1 units
    camera = np.asarray(reference["sensor"]["to_world"].matrix, dtype=float).reshape(4, 4, -1)[..., 0]
    to_camera = np.diag([scale, scale, scale, 1.0]) @ np.linalg.inv(camera)
    patches = spectra.colorchecker_reflectances()
    materials = {"white": diffuse(patches[WHITE_PATCH]), "red": diffuse(patches["red"]),
                 "green": diffuse(patches["green"])}
    objects = {}
    for name, shape in reference.items():
        if not isinstance(shape, dict) or shape.get("type") not in ("rectangle", "cube"):
            continue
        matrix = to_camera @ np.asarray(shape["to_world"].matrix, dtype=float).reshape(4, 4, -1)[..., 0]
        item = {"type": shape["type"], "to_world": mi.ScalarTransform4f(matrix),
                "bsdf": materials[shape["bsdf"]["id"]]}
        if "emitter" in shape:
            area = 4.0 * np.linalg.norm(matrix[:3, 0]) * np.linalg.norm(matrix[:3, 1])
            height = 2.0 * scale  # ceiling to floor
            wavelengths, irradiance = light_irradiance(config)
            item["emitter"] = {"type": "area", "radiance": spectrum_dict((wavelengths, irradiance * height ** 2 / area))}
        objects[name.replace("-", "_")] = item
    return objects
