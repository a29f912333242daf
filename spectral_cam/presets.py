"""Scene presets: the geometry, materials and light of each ``scene.preset``, as Mitsuba
scene-dict entries.

Conventions: the camera sits at the origin looking along +z with +y up, so a point's
camera-space z is its depth. Every preset is lit by one ``directional`` emitter travelling
along +z (from behind the camera), whose irradiance on a surface facing the camera is the
configured illuminance: a Lambertian reflectance ρ(λ) then has radiance ρ(λ)·E(λ)/π.
Light along the optical axis casts shadows straight back, so no shadow is visible from
the camera's viewpoint in these layouts.

References
----------
.. [1] ISO 12233:2017, Photography — Electronic still picture imaging — Resolution and
   spatial frequency responses (slanted edge, 4:1 contrast).
.. [2] McCamy, C. S., Marcus, H., & Davidson, J. G. (1976). A color-rendition chart.
   J. Applied Photographic Engineering 2(3) (ColorChecker layout: 6 × 4 patches).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import spectra
from .optics import ThinLens
from .scene import SceneConfig

__all__ = ["build_objects", "colorchecker_patches", "white_reference_mask", "Patch", "EDGE_REFLECTANCES"]

#: ISO 12233:2017 low-contrast (4:1) edge: reflectances of the bright and dark sides.
EDGE_REFLECTANCES = (0.8, 0.2)
#: Reflectance of the ColorChecker's black frame (about that of the real chart's frame).
CHART_FRAME_REFLECTANCE = 0.03
_SPECTRUM_STEP_NM = 5.0


@dataclass(frozen=True)
class Patch:
    """A chart patch in pixel coordinates (continuous; 0 at the top-left image corner)."""

    name: str
    column: float
    row: float
    half_width_px: float
    half_height_px: float

    def interior(self, margin: float = 0.2) -> tuple[slice, slice]:
        """Row and column slices of the whole pixels inside the patch, shrunk by
        ``margin`` of its size on each side (to stay clear of blur and edges)."""
        hw = self.half_width_px * (1 - 2 * margin)
        hh = self.half_height_px * (1 - 2 * margin)
        c0, c1 = int(np.ceil(self.column - hw - 1e-6)), int(np.floor(self.column + hw + 1e-6))
        r0, r1 = int(np.ceil(self.row - hh - 1e-6)), int(np.floor(self.row + hh + 1e-6))
        return slice(r0, max(r1, r0 + 1)), slice(c0, max(c1, c0 + 1))


# ----------------------------------------------------------------------------- helpers
def _spectrum(values_per_wavelength: tuple[np.ndarray, np.ndarray]) -> dict:
    wavelengths, values = values_per_wavelength
    return {"type": "spectrum", "value": [(float(w), float(v)) for w, v in zip(wavelengths, values)]}


def _reflectance_spectrum(sd) -> dict:
    """A reflectance on Mitsuba's whole range, end values held (ColorChecker data stop at
    380/730 nm)."""
    lo, hi = spectra.MITSUBA_RANGE_NM
    wavelengths = np.arange(lo, hi + _SPECTRUM_STEP_NM / 2, _SPECTRUM_STEP_NM)
    return _spectrum((wavelengths, np.clip(spectra.sample(sd, wavelengths), 0.0, 1.0)))


def _diffuse(reflectance) -> dict:
    if isinstance(reflectance, (int, float)):
        return {"type": "diffuse", "reflectance": {"type": "uniform", "value": float(reflectance)}}
    return {"type": "diffuse", "reflectance": _reflectance_spectrum(reflectance)}


def _facing_rectangle(mi, centre, half_width, half_height, bsdf, angle_deg=0.0) -> dict:
    """A rectangle at ``centre`` facing the camera (normal −z), rotated by ``angle_deg``
    about the optical axis."""
    to_world = (
        mi.ScalarTransform4f()
        .translate([float(c) for c in centre])
        .rotate([0, 0, 1], angle_deg)
        .rotate([0, 1, 0], 180.0)
        .scale([half_width, half_height, 1.0])
    )
    return {"type": "rectangle", "to_world": to_world, "bsdf": bsdf}


def _field_half_size(lens: ThinLens, depth_m: float) -> tuple[float, float]:
    """Half width and height (m) of the field of view at a depth."""
    scale = depth_m / lens.image_distance_m
    return lens.sensor_width_m / 2 * scale, lens.sensor_height_m / 2 * scale


def _irradiance(config: SceneConfig):
    return spectra.absolute_irradiance(config.illuminant.spd, config.illuminant.illuminance_lux)


def _sun(config: SceneConfig) -> dict:
    """Directional light along +z with the configured spectral irradiance."""
    return {"type": "directional", "direction": [0.0, 0.0, 1.0], "irradiance": _spectrum(_irradiance(config))}


# ----------------------------------------------------------------------------- presets
def colorchecker_patches(config: SceneConfig) -> list[Patch]:
    """Where the 24 patches of the ``colorchecker`` preset fall in the image, in reading
    order (``dark skin`` top-left)."""
    lens = ThinLens.from_config(config.lens, config.sensor)
    s = config.scene
    half_w, _ = _field_half_size(lens, s.distance_m)
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


def white_reference_mask(config: SceneConfig) -> np.ndarray | None:
    """The ColorChecker's white patch (interior) as the auto-exposure reference, or None
    for scenes without one (the sensor then uses the 99th percentile)."""
    if config.scene.preset != "colorchecker" or config.scene.mitsuba_xml:
        return None
    mask = np.zeros((config.sensor.height_px, config.sensor.width_px), dtype=bool)
    white = next(p for p in colorchecker_patches(config) if p.name.startswith("white"))
    mask[white.interior(0.2)] = True
    return mask if mask.any() else None


def _colorchecker(config: SceneConfig, lens: ThinLens, mi) -> dict:
    s = config.scene
    half_w, _ = _field_half_size(lens, s.distance_m)
    pitch = 2 * half_w * s.fill / 6
    objects = {}
    for index, (name, sd) in enumerate(spectra.colorchecker_reflectances().items()):
        row, col = divmod(index, 6)
        centre = ((2.5 - col) * pitch, (1.5 - row) * pitch, s.distance_m)
        half = pitch * (1 - s.gap) / 2
        objects[f"patch_{index:02d}"] = _facing_rectangle(mi, centre, half, half, _diffuse(sd))
    if s.gap > 0:
        # the black frame sits 1 mm behind the patches
        objects["chart_frame"] = _facing_rectangle(
            mi, (0.0, 0.0, s.distance_m + 1e-3), 3.25 * pitch, 2.25 * pitch, _diffuse(CHART_FRAME_REFLECTANCE)
        )
    return objects


def _flat_field(config: SceneConfig, lens: ThinLens, mi) -> dict:
    s = config.scene
    half_w, half_h = _field_half_size(lens, s.distance_m)
    bsdf = _diffuse(spectra.reflectance(s.reflectance) if isinstance(s.reflectance, str) else s.reflectance)
    # 1.5× the field so defocus never reveals an edge
    return {"target": _facing_rectangle(mi, (0, 0, s.distance_m), 1.5 * half_w, 1.5 * half_h, bsdf)}


def _slanted_edge(config: SceneConfig, lens: ThinLens, mi) -> dict:
    s = config.scene
    half_w, half_h = _field_half_size(lens, s.distance_m)
    big = 1.5 * max(half_w, half_h)
    bright, dark = EDGE_REFLECTANCES
    angle = np.radians(s.edge_angle_deg)
    # the bright square's left edge passes through the optical axis, tilted by the angle;
    # it sits 0.1 mm in front of the dark background so the two never z-fight
    centre = (-big * np.cos(angle), big * np.sin(angle), s.distance_m - 1e-4)
    return {
        "background": _facing_rectangle(mi, (0, 0, s.distance_m), big * 2, big * 2, _diffuse(dark)),
        "bright_half": _facing_rectangle(mi, centre, big, big, _diffuse(bright), angle_deg=-s.edge_angle_deg),
    }


def _dof_targets(config: SceneConfig, lens: ThinLens, mi) -> dict:
    """Checkerboard planes at the configured depths (squares ``checker_px`` wide on the
    sensor when in focus), each filling a vertical stripe of the view. The nearest plane takes the central stripe and farther ones alternate outwards,
    so a nearer plane's shadow (cast straight back) always falls where it hides it."""
    depths = sorted(config.scene.depths_m)
    n = len(depths)
    tan_x = lens.sensor_width_m / 2 / lens.image_distance_m
    tan_y = lens.sensor_height_m / 2 / lens.image_distance_m
    edges = np.linspace(-tan_x, tan_x, n + 1)
    stripes = sorted(zip(edges[:-1], edges[1:]), key=lambda e: abs(e[0] + e[1]))
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
        objects[f"plane_{index}"] = _facing_rectangle(
            mi, (-(x_lo + x_hi) / 2, 0.0, depth), half_w, half_h, {"type": "diffuse", "reflectance": checker}
        )
    return objects


def _point_sources(config: SceneConfig, lens: ThinLens, mi) -> dict:
    """Small Lambertian emitting discs (radiance of a white diffuser under the illuminant)
    at the configured depths, spread along the horizontal centre line; one sits on axis."""
    s = config.scene
    depths = list(s.depths_m)
    tan_x = lens.sensor_width_m / 2 / lens.image_distance_m
    offsets = [0.0] if len(depths) == 1 else np.linspace(-0.6, 0.6, len(depths)) * tan_x
    wavelengths, irradiance = _irradiance(config)
    radiance = _spectrum((wavelengths, irradiance / np.pi))
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


def _cornell_box(config: SceneConfig, lens: ThinLens, mi) -> dict:
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
    materials = {"white": _diffuse(patches["white 9.5 (.05 D)"]), "red": _diffuse(patches["red"]),
                 "green": _diffuse(patches["green"])}
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
            wavelengths, irradiance = _irradiance(config)
            item["emitter"] = {"type": "area", "radiance": _spectrum((wavelengths, irradiance * height ** 2 / area))}
        objects[name.replace("-", "_")] = item
    return objects


_BUILDERS = {
    "colorchecker": _colorchecker,
    "flat_field": _flat_field,
    "slanted_edge": _slanted_edge,
    "dof_targets": _dof_targets,
    "point_sources": _point_sources,
    "cornell_box": _cornell_box,
}


def build_objects(config: SceneConfig, lens: ThinLens, mi) -> dict:
    """Shapes and emitters of the configured preset as Mitsuba scene-dict entries
    (``mi`` must have a spectral variant set)."""
    objects = _BUILDERS[config.scene.preset](config, lens, mi)
    if config.scene.preset not in ("point_sources", "cornell_box"):  # these carry their own light
        objects["light"] = _sun(config)
    return objects
