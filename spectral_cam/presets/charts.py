"""Chart presets: ``colorchecker``, ``flat_field`` and ``slanted_edge``.

References
----------
.. [1] McCamy, C. S., Marcus, H., & Davidson, J. G. (1976). A color-rendition chart.
   J. Applied Photographic Engineering 2(3) (ColorChecker layout: 6 × 4 patches).
.. [2] ISO 12233:2017, Photography — Electronic still picture imaging — Resolution and
   spatial frequency responses (slanted edge, 4:1 contrast).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .. import spectra
from ..colour_ground_truth import WHITE_PATCH
from ..keys import Key
from .common import (
    CHART_FRAME_REFLECTANCE,
    EDGE_REFLECTANCES,
    PRESETS,
    Patch,
    diffuse,
    facing_rectangle,
    field_half_size,
    sun,
)

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig


# ----------------------------------------------------------------------------- presets
def colorchecker_patches(config: SceneConfig, lens: ThinLens | None = None) -> list[Patch]:
    """Where the 24 patches of the ``colorchecker`` preset fall in the image, in reading
    order (``dark skin`` top-left)."""
    from ..optics import ThinLens

    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    s = config.scene
    half_w, _ = field_half_size(lens, s.distance_m)
    pitch = 2 * half_w * s.fill / 6
    size = pitch * (1 - s.gap)
    scale = lens.image_distance_m / (s.distance_m * lens.pixel_pitch_m)
    patches = []
    for index, name in enumerate(spectra.colorchecker_reflectances()):
        row, col = divmod(index, 6)
        # chart reading order runs left to right on the image: image-left is camera +x
        x = (2.5 - col) * pitch
        y = (1.5 - row) * pitch
        column, image_row = lens.project(x, y, s.distance_m)
        patches.append(Patch(name, float(column), float(image_row), size / 2 * scale, size / 2 * scale))
    return patches


def white_reference_mask(config: SceneConfig, lens: ThinLens | None = None) -> np.ndarray | None:
    """The ColorChecker's white patch (interior) as the auto-exposure reference, or None
    for scenes without one (the sensor then uses the 99th percentile)."""
    if config.scene.preset != "colorchecker" or config.scene.mitsuba_xml:
        return None
    from ..optics import ThinLens

    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    mask = np.zeros((lens.height_px, lens.width_px), dtype=bool)  # the frame and any margin
    white = next(p for p in colorchecker_patches(config, lens) if p.name == WHITE_PATCH)
    mask[white.interior(0.2)] = True
    return mask if mask.any() else None


def _reflectance(value, scene):
    spectra.validate_reflectance(value)


_FILL = Key("fill", 0.8, "float", "the fraction of the frame width the chart covers",
            (lambda v, s: None if 0 < v <= 1 else "must lie in (0, 1]",))
_GAP = Key("gap", 0.15, "float", "the fraction of each patch pitch left as dark border",
           (lambda v, s: None if 0 <= v < 1 else "must lie in [0, 1)",))
_SURROUND = Key("surround", 0.18, "float | str", "the card the chart lies on (0.18: an 18 % grey, as charts are "
                "photographed; 0: nothing behind it), a patch name or a CSV", (_reflectance,))
_REFLECTANCE = Key("reflectance", 0.18, "float | str", "the flat target: a number in [0, 1], a ColorChecker patch "
                   "name or a CSV", (_reflectance,))
_EDGE_ANGLE = Key("edge_angle_deg", 5.0, "float", "the edge's tilt from vertical",
                  (lambda v, s: None if 0 <= v < 45 else "must lie in [0, 45)",))


@PRESETS.register("colorchecker", options=("distance_m",), keys=(_FILL, _GAP, _SURROUND),
                  description="the 24-patch ColorChecker (BabelColor spectra) facing the camera, on a grey card")
def colorchecker(config: SceneConfig, lens: ThinLens, mi) -> dict:
    s = config.scene
    half_w, _ = field_half_size(lens, s.distance_m)
    pitch = 2 * half_w * s.fill / 6
    objects = {}
    for index, (name, sd) in enumerate(spectra.colorchecker_reflectances().items()):
        row, col = divmod(index, 6)
        centre = ((2.5 - col) * pitch, (1.5 - row) * pitch, s.distance_m)
        half = pitch * (1 - s.gap) / 2
        objects[f"patch_{index:02d}"] = facing_rectangle(mi, centre, half, half, diffuse(sd))
    if s.gap > 0:
        # the black frame sits 1 mm behind the patches
        objects["chart_frame"] = facing_rectangle(
            mi, (0.0, 0.0, s.distance_m + 1e-3), 3.25 * pitch, 2.25 * pitch, diffuse(CHART_FRAME_REFLECTANCE)
        )
    if s.surround != 0:
        # the card the chart lies on, 2 mm behind it and wider than the view, so that a camera's
        # meter reads a scene and not a chart floating in a void (issue 23)
        half_w, half_h = field_half_size(lens, s.distance_m)
        surround = spectra.reflectance(s.surround) if isinstance(s.surround, str) else s.surround
        objects["surround"] = facing_rectangle(mi, (0.0, 0.0, s.distance_m + 2e-3), 1.5 * half_w, 1.5 * half_h,
                                               diffuse(surround))
    objects["light"] = sun(config)
    return objects


@PRESETS.register("flat_field", options=("distance_m",), keys=(_REFLECTANCE,),
                  description="a uniform Lambertian target filling the view")
def flat_field(config: SceneConfig, lens: ThinLens, mi) -> dict:
    s = config.scene
    half_w, half_h = field_half_size(lens, s.distance_m)
    bsdf = diffuse(spectra.reflectance(s.reflectance) if isinstance(s.reflectance, str) else s.reflectance)
    # the field plus the blur's reach, so defocus never reveals an edge: a pixel sees the
    # target through the aperture over a disc of diameter A·|z − z_f|/z_f around its own point
    reach = 2 * lens.aperture_radius_m * abs(s.distance_m - lens.focus_distance_m) / lens.focus_distance_m
    return {"target": facing_rectangle(mi, (0, 0, s.distance_m), 1.5 * half_w + reach, 1.5 * half_h + reach, bsdf),
            "light": sun(config)}


@PRESETS.register("slanted_edge", options=("distance_m",), keys=(_EDGE_ANGLE,),
                  description="an ISO 12233 4:1 slanted edge")
def slanted_edge(config: SceneConfig, lens: ThinLens, mi) -> dict:
    s = config.scene
    half_w, half_h = field_half_size(lens, s.distance_m)
    big = 1.5 * max(half_w, half_h)
    bright, dark = EDGE_REFLECTANCES
    angle = np.radians(s.edge_angle_deg)
    # the bright square's left edge passes through the optical axis, tilted by the angle;
    # it sits 0.1 mm in front of the dark background so the two never z-fight
    centre = (-big * np.cos(angle), big * np.sin(angle), s.distance_m - 1e-4)
    return {
        "light": sun(config),
        "background": facing_rectangle(mi, (0, 0, s.distance_m), big * 2, big * 2, diffuse(dark)),
        "bright_half": facing_rectangle(mi, centre, big, big, diffuse(bright), angle_deg=-s.edge_angle_deg),
    }
