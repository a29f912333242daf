"""``dead_leaves``: occluding discs at depths spread over a range, the texture and depth-of-field
target with natural-image statistics.

The dead-leaves model (Matheron 1968; Lee, Mumford & Huang 2001) drops opaque discs of i.i.d.
radius and reflectance at uniformly random positions, each hiding what lies behind it. With
radii distributed as f(r) = C·r⁻³ on [r_min, r_max] (C = 2/(r_min⁻² − r_max⁻²)) the image is
scale invariant between the two radii and its power spectrum falls as 1/ν² (Gousseau &
Roueff 2007): the target of ISO 19567-2's texture-loss measurement (Cao, Guichard & Hornung
2010). Here each disc also has a depth, log-uniform over ``scene.depths_m``, independent of
its radius, so the nearer disc hides the farther one as the model's later leaf hides the
earlier, and every occlusion edge has a depth step: depth of field shows everywhere.

Radii and positions are drawn on the sensor (pixels of the configured frame) and each disc is
placed at its depth with the size and position that project there through the lens's pinhole,
so the image statistics do not depend on the depths. The number of discs is set so the
expected fraction of the view they cover, 1 − exp(−N·ā/A) with ā = π·C·ln(r_max/r_min) the
mean disc area and A the area their centres fall on, is ``scene.leaf_coverage``; a grey
(0.18) backdrop behind the farthest disc shows where none lands.

References
----------
.. [1] Matheron, G. (1968). Modèle séquentiel de partition aléatoire. CMM, Fontainebleau.
.. [2] Lee, A. B., Mumford, D., & Huang, J. (2001). Occlusion models for natural images.
   International Journal of Computer Vision 41(1/2), 35–59.
.. [3] Gousseau, Y., & Roueff, F. (2007). Modeling occlusion and scaling in natural images.
   Multiscale Modeling & Simulation 6(1), 105–134.
.. [4] Cao, F., Guichard, F., & Hornung, H. (2010). Dead leaves model for measuring texture
   quality on a digital camera. Proc. SPIE 7537, 75370E; ISO 19567-2:2019.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..keys import Key, non_negative_whole
from .common import PRESETS, facing_rectangle, light_irradiance, spectrum_dict
from .keys import reflectance_set

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

__all__ = ["DeadLeaves", "dead_leaves_layout", "leaf_meshes", "radius_cdf", "expected_coverage", "MAX_LEAVES"]

#: Most discs a layout may hold (Mitsuba loads 3000 discs in 0.2 s; this keeps it to seconds).
MAX_LEAVES = 50_000
#: Reflectance of the backdrop behind every disc.
BACKDROP_REFLECTANCE = 0.18


@dataclass(frozen=True)
class DeadLeaves:
    """A layout in sensor pixels of the frame (0 at the top-left corner, rows down), from the
    farthest disc to the nearest.

    Attributes
    ----------
    column_px, row_px, radius_px, depth_m : numpy.ndarray
        Centre, radius and camera-space depth of each disc.
    reflectance_index : numpy.ndarray
        Index of each disc's reflectance in ``reflectance_names``.
    reflectance_names : tuple of str
        The reflectance set's samples.
    backdrop_depth_m : float
        Depth of the grey backdrop.
    domain_px : (float, float, float, float)
        (left, top, right, bottom) of the area the centres were drawn in.
    """

    column_px: np.ndarray
    row_px: np.ndarray
    radius_px: np.ndarray
    depth_m: np.ndarray
    reflectance_index: np.ndarray
    reflectance_names: tuple[str, ...]
    backdrop_depth_m: float
    domain_px: tuple[float, float, float, float]

    def __len__(self) -> int:
        return len(self.radius_px)


def _radius_constant(r_min: float, r_max: float) -> float:
    return 2.0 / (r_min ** -2 - r_max ** -2)


def radius_cdf(radius_px, r_min: float, r_max: float) -> np.ndarray:
    """P(R ≤ r) of radii distributed as C·r⁻³ on [r_min, r_max]:
    (r_min⁻² − r⁻²)/(r_min⁻² − r_max⁻²)."""
    r = np.clip(np.asarray(radius_px, dtype=float), r_min, r_max)
    return (r_min ** -2 - r ** -2) / (r_min ** -2 - r_max ** -2)


def mean_disc_area(r_min: float, r_max: float) -> float:
    """E[π R²] = π·C·ln(r_max/r_min) for the r⁻³ law (px²)."""
    return math.pi * _radius_constant(r_min, r_max) * math.log(r_max / r_min)


def expected_coverage(count: int, r_min: float, r_max: float, domain_area_px2: float) -> float:
    """Expected fraction of the frame covered by ``count`` discs whose centres fall uniformly
    on ``domain_area_px2`` (the frame grown by r_max on every side, so the frame sees no
    border effect): 1 − exp(−count·ā/A) (the Boolean model's coverage)."""
    return 1.0 - math.exp(-count * mean_disc_area(r_min, r_max) / domain_area_px2)


def dead_leaves_layout(config: "SceneConfig", lens: "ThinLens", names: tuple[str, ...]) -> DeadLeaves:
    """Draw the discs of ``config``'s dead-leaves scene on ``lens``'s frame.

    Parameters
    ----------
    config : SceneConfig
        Reads ``scene.leaf_radius_px``, ``leaf_coverage``, ``leaf_seed``, ``depths_m``.
    lens : ThinLens
        The frame's lens (its pixel grid).
    names : tuple of str
        The reflectance samples to draw from.

    Raises
    ------
    ConfigError
        When the coverage asked needs more than :data:`MAX_LEAVES` discs.
    """
    from ..errors import ConfigError

    s = config.scene
    r_min, r_max = (float(r) for r in s.leaf_radius_px)
    width, height = lens.width_px, lens.height_px
    domain = (-r_max, -r_max, width + r_max, height + r_max)
    area = (domain[2] - domain[0]) * (domain[3] - domain[1])
    count = math.ceil(-math.log(1.0 - s.leaf_coverage) * area / mean_disc_area(r_min, r_max))
    if count > MAX_LEAVES:
        raise ConfigError(f"scene.leaf_coverage = {s.leaf_coverage} with radii {r_min:g}–{r_max:g} px on a "
                          f"{width} × {height} frame needs {count} discs (at most {MAX_LEAVES}); raise the smallest "
                          "radius (scene.leaf_radius_px) or lower scene.leaf_coverage")
    rng = np.random.default_rng(np.random.SeedSequence([s.leaf_seed, 0xDEAD1EAF]))
    u = rng.random(count)
    radius = (r_min ** -2 - u * (r_min ** -2 - r_max ** -2)) ** -0.5  # inverse CDF of C·r⁻³
    column = rng.uniform(domain[0], domain[2], count)
    row = rng.uniform(domain[1], domain[3], count)
    near, far = min(s.depths_m), max(s.depths_m)
    depth = near * (far / near) ** rng.random(count) if far > near else np.full(count, near)
    index = rng.integers(0, len(names), count)
    order = np.argsort(-depth, kind="stable")  # farthest first
    return DeadLeaves(column[order], row[order], radius[order], depth[order], index[order], tuple(names),
                      far * 1.25, domain)


#: Largest distance (px on the sensor) between a disc's polygon and its circle.
POLYGON_TOLERANCE_PX = 0.05


def polygon_sides(radius_px) -> np.ndarray:
    """Sides of each disc's polygon (:func:`disc_polygons`): as many as keep its edge within
    :data:`POLYGON_TOLERANCE_PX` of the circle, 16–256; one triangle per side."""
    radius_px = np.asarray(radius_px, dtype=np.float64)
    sides = np.clip(np.ceil(np.pi / np.arccos(1.0 - np.minimum(POLYGON_TOLERANCE_PX / radius_px, 1.0))), 16, 256)
    return sides.astype(np.int64)


def leaf_meshes(layout: DeadLeaves) -> dict[str, np.ndarray]:
    """Which disc of ``layout`` each triangle of the preset's meshes belongs to: mesh name
    (``leaves_<sample>``, one per reflectance sample) → (triangles,) indices into the layout
    (its discs in the mesh's order, each fanned into :func:`polygon_sides` triangles)."""
    meshes = {}
    for index in np.unique(layout.reflectance_index):
        discs = np.flatnonzero(layout.reflectance_index == index)
        meshes[f"leaves_{int(index)}"] = np.repeat(discs, polygon_sides(layout.radius_px[discs]))
    return meshes


def disc_polygons(column_px, row_px, radius_px, depth_m, width_px: int, height_px: int, pixel: float):
    """Discs facing the camera as one triangle mesh: each a regular polygon of as many sides as
    keep its edge within :data:`POLYGON_TOLERANCE_PX` of the circle (16–256), its circumradius
    enlarged so its area is the disc's (the Boolean model's coverage is kept), fanned from its
    centre, wound so its normal faces the camera (−z: an area emitter emits on its normal's side).

    Camera space: +x is the image's left, +y up, +z the view; column c at depth z lies at
    x = −(c − W/2)·pixel·z, ``pixel`` being metres per pixel per metre of depth.

    Returns
    -------
    vertices : numpy.ndarray
        (V, 3) float32 positions, metres.
    faces : numpy.ndarray
        (F, 3) uint32 vertex indices.
    """
    radius_px = np.asarray(radius_px, dtype=np.float64)
    sides = polygon_sides(radius_px)
    area_scale = np.sqrt(2.0 * np.pi / (sides * np.sin(2.0 * np.pi / sides)))
    depth = np.asarray(depth_m, dtype=np.float64)
    x0 = -(np.asarray(column_px, dtype=np.float64) - width_px / 2) * pixel * depth
    y0 = -(np.asarray(row_px, dtype=np.float64) - height_px / 2) * pixel * depth
    metres = radius_px * area_scale * pixel * depth
    disc = np.repeat(np.arange(len(sides)), sides)  # the disc of each rim vertex
    first = np.concatenate([[0], np.cumsum(sides)[:-1]])
    step = np.arange(len(disc)) - np.repeat(first, sides)  # the rim vertex's number on its disc
    angle = 2.0 * np.pi * step / sides[disc]
    rim = np.stack([x0[disc] + metres[disc] * np.cos(angle), y0[disc] + metres[disc] * np.sin(angle), depth[disc]],
                   axis=1)
    centres = np.stack([x0, y0, depth], axis=1)
    vertices = np.concatenate([centres, rim]).astype(np.float32)
    rim_index = len(centres) + np.arange(len(disc))
    following = len(centres) + np.repeat(first, sides) + (step + 1) % sides[disc]
    # (centre, next, this): clockwise seen from the camera, so the normal points towards it (−z)
    faces = np.stack([disc, following, rim_index], axis=1).astype(np.uint32)
    return vertices, faces


def _radius_range(value, scene):
    if len(value) != 2 or not value[0] < value[1]:
        return "give [smallest, largest] disc radius in pixels, smallest < largest"
    return None


_LEAF_KEYS = (
    Key("leaf_radius_px", (3.0, 120.0), "tuple[float, ...]", "[smallest, largest] disc radius on the sensor (r⁻³ "
        "law between)", (_radius_range,), range=(0.5, 1e5, "px")),
    Key("leaf_coverage", 0.99, "float", "the expected fraction of the view the discs cover",
        (lambda v, s: None if 0 < v <= 0.9999 else "must lie in (0, 0.9999]: the expected fraction of the view the "
         "discs cover",)),
    Key("leaf_reflectances", "cie2017", "str", "the reflectance set the discs draw from, or a CSV",
        (reflectance_set(),)),
    Key("leaf_seed", 0, "int", "the layout's seed", (non_negative_whole(),)),
)


@PRESETS.register("dead_leaves", options=("depths_m",), keys=_LEAF_KEYS,
                  description="occluding discs (r^-3 radii) at depths over depths_m: texture and depth of field")
def dead_leaves(config: "SceneConfig", lens: "ThinLens", mi) -> dict:
    """Discs facing the camera, laid out by :func:`dead_leaves_layout`, each with the radiance
    ρ(λ)·E(λ)/π of a Lambertian sample of ``scene.leaf_reflectances`` under the configured
    light (E at ``illuminance_lux``). They emit that radiance rather than reflect a light: a
    light along the optical axis casts shadows the camera sees beside every nearer disc (the
    view is a perspective, the shadows are not), which is not the dead-leaves model."""
    from .. import spectra
    from ..reflectance_sets import reflectance_set

    samples = reflectance_set(config.scene.leaf_reflectances)
    layout = dead_leaves_layout(config, lens, samples.names)
    wavelengths, irradiance = light_irradiance(config)

    def radiance(reflectance) -> object:
        rho = np.clip(spectra.sample(reflectance, wavelengths), 0.0, 1.0) if not isinstance(reflectance, float) \
            else np.full(len(wavelengths), reflectance)
        return mi.load_dict(spectrum_dict((wavelengths, rho * irradiance / np.pi)))

    pixel = lens.pixel_pitch_m / lens.image_distance_m  # metres per pixel per metre of depth
    black = mi.load_dict({"type": "diffuse", "reflectance": {"type": "uniform", "value": 0.0}})
    objects = {}
    # one emitting mesh per reflectance sample, holding all its discs: Mitsuba records a render
    # call's kernel once per shape and emitter, so 8,900 separate discs cost 2.8 s a call and
    # 99 meshes 0.08 s (docs/design.md, "The capture plan")
    for index in np.unique(layout.reflectance_index):  # the meshes leaf_meshes() reads back
        chosen = layout.reflectance_index == index
        vertices, faces = disc_polygons(layout.column_px[chosen], layout.row_px[chosen], layout.radius_px[chosen],
                                        layout.depth_m[chosen], lens.width_px, lens.height_px, pixel)
        props = mi.Properties()
        props["bsdf"] = black
        props["emitter"] = mi.load_dict({"type": "area", "radiance": radiance(samples.sds[int(index)])})
        mesh = mi.Mesh(f"leaves_{int(index)}", len(vertices), len(faces), props=props)
        params = mi.traverse(mesh)
        params["vertex_positions"] = mi.Float(vertices.ravel())
        params["faces"] = mi.UInt32(faces.ravel())
        params.update()
        objects[f"leaves_{int(index)}"] = mesh
    back = layout.backdrop_depth_m
    half_w = (layout.domain_px[2] - layout.domain_px[0]) * pixel * back
    half_h = (layout.domain_px[3] - layout.domain_px[1]) * pixel * back
    backdrop = facing_rectangle(mi, (0.0, 0.0, back), half_w, half_h, black)
    backdrop["emitter"] = {"type": "area", "radiance": radiance(BACKDROP_REFLECTANCE)}
    objects["backdrop"] = backdrop
    return objects
