"""Depth presets: ``dof_targets`` (checker planes at several depths) and ``point_sources``
(small emitting discs, for defocus and bokeh studies).

References
----------
.. [1] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10 (depth of field).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..keys import Key
from .common import PRESETS, facing_rectangle, light_irradiance, spectrum_dict, sun

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig


def _three_depths(scene):
    if len(scene.depths_m) < 3:
        return "scene.depths_m", scene.depths_m, "dof_targets needs three or more depths"
    return None


@PRESETS.register("dof_targets", options=("depths_m",), checks=(_three_depths,),
                  keys=(Key("checker_px", 16.0, "float", "the in-focus checker square size on the sensor",
                            range=(1.0, 1e5, "px")),),
                  description="checker planes side by side at several depths")
def dof_targets(config: SceneConfig, lens: ThinLens, mi) -> dict:
    """Checkerboard planes at the configured depths (squares ``checker_px`` wide on the
    sensor when in focus), each filling a vertical stripe of the view. The nearest plane takes the central stripe and farther ones alternate outwards,
    image-left first (1, 2, 4 m read 2 / 1 / 4 m left to right, whatever the lens), so a
    nearer plane's shadow (cast straight back) always falls where it hides it."""
    depths = sorted(config.scene.depths_m)
    n = len(depths)
    tan_x = lens.sensor_width_m / 2 / lens.image_distance_m
    tan_y = lens.sensor_height_m / 2 / lens.image_distance_m
    edges = np.linspace(-tan_x, tan_x, n + 1)
    # nearest plane in the centre, then outwards, image-left before image-right at equal
    # distance; the distance is rounded so float noise in the edges (which depends on the
    # lens and focus) cannot break the tie and mirror the layout
    stripes = sorted(zip(edges[:-1], edges[1:]), key=lambda e: (round(abs(e[0] + e[1]) / tan_x, 9), e[0] + e[1]))
    objects = {}
    square_px = config.scene.checker_px  # the same apparent square size at every depth
    for index, (depth, (lo, hi)) in enumerate(zip(depths, stripes)):
        # extend inwards to the axis (hidden behind nearer planes) and outwards past the
        # frame at the outermost stripes, so defocus never shows a gap
        lo_ext = -1.5 * tan_x if lo <= -tan_x + 1e-12 else min(lo, 0.0)
        hi_ext = 1.5 * tan_x if hi >= tan_x - 1e-12 else max(hi, 0.0)
        x_lo, x_hi = lo_ext * depth, hi_ext * depth
        half_h = 1.5 * tan_y * depth
        square_m = square_px * lens.pixel_pitch_m * depth / lens.image_distance_m
        half_w = (x_hi - x_lo) / 2
        checker = {
            "type": "checkerboard",
            "color0": {"type": "uniform", "value": 0.1},
            "color1": {"type": "uniform", "value": 0.8},
            "to_uv": mi.ScalarTransform4f().scale([half_w / square_m, half_h / square_m, 1.0]),
        }
        # camera-space +x is image-left: stripe (lo, hi) in image angles maps to −x
        objects[f"plane_{index}"] = facing_rectangle(
            mi, (-(x_lo + x_hi) / 2, 0.0, depth), half_w, half_h, {"type": "diffuse", "reflectance": checker}
        )
    objects["light"] = sun(config)
    return objects


@PRESETS.register("point_sources", options=("depths_m",),
                  keys=(Key("source_radius_m", 0.002, "float", "the discs' radius", range=(1e-7, 1e3, "m")),),
                  description="small emitting discs at several depths (defocus, bokeh)")
def point_sources(config: SceneConfig, lens: ThinLens, mi) -> dict:
    """Small Lambertian emitting discs (radiance of a white diffuser under the illuminant)
    at the configured depths, spread along the horizontal centre line; one sits on axis."""
    s = config.scene
    depths = list(s.depths_m)
    tan_x = lens.sensor_width_m / 2 / lens.image_distance_m
    offsets = [0.0] if len(depths) == 1 else np.linspace(-0.6, 0.6, len(depths)) * tan_x
    wavelengths, irradiance = light_irradiance(config)
    radiance = spectrum_dict((wavelengths, irradiance / np.pi))
    objects = {}
    for index, (depth, offset) in enumerate(zip(depths, offsets)):
        to_world = (
            mi.ScalarTransform4f()
            .translate([-float(offset) * depth, 0.0, depth])
            .rotate([0, 1, 0], 180.0)
            .scale([s.source_radius_m, s.source_radius_m, 1.0])
        )
        objects[f"source_{index}"] = {
            "type": "disk",
            "to_world": to_world,
            "bsdf": {"type": "diffuse", "reflectance": {"type": "uniform", "value": 0.0}},
            "emitter": {"type": "area", "radiance": radiance},
        }
    return objects
