"""Camera-space depth z (m) per pixel from the position AOV (not the ray length).

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3, plugin ``aov`` (position).
"""

from __future__ import annotations

import numpy as np

from ..optics import ThinLens
from ..scene import SceneConfig
from .plugins import register_once
from .scene_dict import (build_scene, camera_dict, configured_camera, frame_tiles, pass_seed, release_render_memory,
                         tile_sensors)


def _luminance_film(width: int, height: int) -> dict:
    return {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
            "pixel_format": "luminance", "component_format": "float32"}


def _pinhole_probe(mi, config: SceneConfig, lens: ThinLens, film: dict, integrator: dict, *, spp: int, stream: int,
                   optimize: bool = True, model: str = "pinhole"):
    """A probe through the frame's pinhole: (scene, sensor, tiles), the scene loaded once with
    ``film`` and ``integrator``; ``tiles()`` renders the radiance's tiles (bounded memory on
    large frames), each with its own seed of ``stream``, as (first row, end row, (rows, W, C)
    image), and releases drjit's memory at the end. It can be called again (after changing the
    scene's parameters): the same seeds, so two calls' noise is correlated; ``tiles(k)`` draws
    the seeds of pass k. ``model``: another of the frame's cameras (:func:`configured_camera`'s
    models: ``"thin"``, ``"spectral_thin"``, ``"prescription"``) in place of the pinhole."""
    width, height = lens.width_px, lens.height_px
    camera = camera_dict(mi, lens, "pinhole", film, spp) if model == "pinhole" else \
        configured_camera(mi, config, lens, model, film, spp)
    scene, sensor, loaded = build_scene(mi, config, lens, camera, integrator, optimize=optimize)

    def tiles(pass_index: int = 0):
        for _, (first, end), tile_camera, seed_key in tile_sensors(mi, sensor, camera, frame_tiles(width, height)):
            seed = pass_seed(config.render.seed, stream + pass_index, seed_key)
            image = np.asarray(mi.render(scene, sensor=tile_camera, integrator=loaded, seed=seed, spp=spp))
            yield first, end, image.reshape(end - first, width, -1)
            del image
        release_render_memory()

    return scene, sensor, tiles


#: The depth label's seed stream: the normals take the same one, so each pixel's one ray (a
#: random point of the pixel) is the depth label's ray and meets the same surface.
DEPTH_STREAM = 1 << 20


def render_depth(mi, config: SceneConfig, lens: ThinLens) -> np.ndarray:
    """Camera-space z (m) per pixel from the first hit's world position.

    Mitsuba's ``depth`` AOV is the ray length, which off axis exceeds z by 1/cos θ, so z is
    taken as (p − camera origin)·(optical axis) from the ``position`` AOV. One sample per
    pixel keeps it the depth of one surface, never a blend across an edge.
    """
    width, height = lens.width_px, lens.height_px
    _, sensor, tiles = _pinhole_probe(mi, config, lens, _luminance_film(width, height),
                                      {"type": "aov", "aovs": "pos:position"}, spp=1, stream=DEPTH_STREAM)
    to_world = np.asarray(sensor.world_transform().matrix, dtype=np.float64).reshape(4, 4, -1)[..., 0]
    origin, axis = to_world[:3, 3], to_world[:3, 2] / np.linalg.norm(to_world[:3, 2])
    depth = np.empty((height, width), np.float32)
    for first, end, image in tiles():
        position = image[..., :3].astype(np.float64)
        z = (position - origin) @ axis
        hit = np.any(position != 0.0, axis=-1)  # the AOV is all zero where a ray escapes
        depth[first:end] = np.where(hit & (z > 0), z, np.inf)
    return depth


def render_normals(mi, config: SceneConfig, lens: ThinLens) -> tuple[np.ndarray, np.ndarray]:
    """Unit surface normals per pixel in OpenCV camera axes (+x right, +y down, +z forward),
    turned to face the camera, and the camera-space z (m) of the same hit.

    Mitsuba's ``sh_normal`` AOV (the shading normal: a mesh's interpolated vertex normal, a
    plane's or sphere's exact one) is in world axes; it is rotated by the pinhole's world →
    camera rotation and its Mitsuba axes (+x left, +y up) mapped to OpenCV's. A two-sided
    surface seen from its back has its normal flipped so that n · view ray < 0. One ray per
    pixel, the depth label's own (:data:`DEPTH_STREAM`): where a ray escapes, n = (0, 0, 0) and
    z = inf.

    Returns
    -------
    normals : (H, W, 3) float32
    z : (H, W) float32, metres

    References
    ----------
    .. [1] Jakob, W., et al. (2022). Mitsuba 3, plugin ``aov`` (sh_normal, position).
    """
    width, height = lens.width_px, lens.height_px
    film = {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
            "pixel_format": "rgb", "component_format": "float32"}
    _, sensor, tiles = _pinhole_probe(mi, config, lens, film, {"type": "aov", "aovs": "pos:position,nn:sh_normal"},
                                      spp=1, stream=DEPTH_STREAM)
    to_world = np.asarray(sensor.world_transform().matrix, dtype=np.float64).reshape(4, 4, -1)[..., 0]
    axes = to_world[:3, :3] / np.linalg.norm(to_world[:3, :3], axis=0)  # camera (Mitsuba) axes in world
    world_to_opencv = np.diag([-1.0, -1.0, 1.0]) @ axes.T
    origin = to_world[:3, 3]
    normals = np.zeros((height, width, 3), np.float32)
    z = np.full((height, width), np.inf, np.float32)
    for first, end, image in tiles():
        channels = image.shape[-1]
        position = image[..., channels - 6:channels - 3].astype(np.float64)
        normal = image[..., channels - 3:].astype(np.float64) @ world_to_opencv.T
        ray = (position - origin) @ world_to_opencv.T  # camera → point, OpenCV axes
        hit = np.any(position != 0.0, axis=-1) & (ray[..., 2] > 0)
        length = np.linalg.norm(normal, axis=-1, keepdims=True)
        unit = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
        unit *= np.where(np.sum(unit * ray, axis=-1, keepdims=True) > 0, -1.0, 1.0)  # face the camera
        normals[first:end] = np.where(hit[..., None], unit, 0.0)
        z[first:end] = np.where(hit, ray[..., 2], np.inf)
    return normals, z


def render_shape_index(mi, config: SceneConfig, lens: ThinLens) -> tuple[np.ndarray, list[str]]:
    """Which shape each pixel's ray meets first: (H, W) int32 indices into the scene's
    shape names (−1 where the ray escapes), and those names (the scene dict's keys: ``plant_3``,
    ``object_0``, an XML id).

    Mitsuba's ``shape_index`` AOV holds the shape's registry id in the vectorised variants (1, 2,
    … in creation order, 0 for a miss), not its place in ``scene.shapes()``: the ids are read
    from ``scene.shapes_dr()`` and mapped back to the names (measured: three rectangles listed
    c, b, a carry ids 3, 2, 1). One sample per pixel, through a random point of it as the depth
    label's (a ray through the exact centre slips through the seams of a symmetric box), never
    a blend across an edge.

    References
    ----------
    .. [1] Jakob, W., et al. (2022). Mitsuba 3, plugin ``aov`` (shape_index).
    """
    index, shapes = render_shapes(mi, config, lens)
    return index, [shape["name"] for shape in shapes]


def _material(shape) -> str:
    """The Mitsuba class of a shape's BSDF ("SmoothDiffuse", "Principled", …), "emitter" for an
    emitting shape whose BSDF is black, from the object's own description."""
    bsdf = str(shape.bsdf()).split("[", 1)[0].strip() if shape.bsdf() is not None else "none"
    return f"emitter ({bsdf})" if shape.is_emitter() else bsdf


def _shape_ids(mi, scene) -> tuple[np.ndarray, list[dict]]:
    """Lookup from the ``shape_index`` AOV's value to the shape's place in ``scene.shapes()``
    (−1: none), and each shape's record (name, material)."""
    shapes = [{"name": shape.id(), "material": _material(shape)} for shape in scene.shapes()]
    try:  # vectorised variants: registry ids
        import drjit as dr

        ids = np.asarray(dr.reinterpret_array(mi.UInt32, scene.shapes_dr()), dtype=np.int64)
    except Exception:  # the scalar variant numbers the list from 1
        ids = np.arange(1, len(shapes) + 1)
    lookup = np.full(int(ids.max(initial=0)) + 2, -1, np.int32)
    lookup[ids] = np.arange(len(shapes), dtype=np.int32)
    return lookup, shapes


def _index_of(lookup: np.ndarray, image: np.ndarray) -> np.ndarray:
    """The shape index from the AOV image's ``shape_index`` channel (the second last)."""
    value = np.rint(image[..., -2]).astype(np.int64)
    return lookup[np.clip(value, 0, len(lookup) - 1)]


#: The AOVs the shape probes render: the shape and its primitive (a mesh's triangle).
SHAPE_AOVS = "index:shape_index,prim:prim_index"


class _Instances:
    """Instances from (shape, primitive) pairs: each shape is one, except the dead-leaves
    preset's meshes, whose every disc is one (``leaf_<n>``, n its place in the layout, farthest
    first), found from the triangle a ray meets (:func:`~spectral_cam.presets.dead_leaves.leaf_meshes`)."""

    def __init__(self, config: SceneConfig, lens: ThinLens, shapes: list[dict]):
        self.records, self.shape_to_instance, self.leaves = list(shapes), np.arange(len(shapes)), None
        if config.scene.mitsuba_xml or config.scene.preset != "dead_leaves":
            return
        from ..presets.dead_leaves import dead_leaves_layout, leaf_meshes
        from ..reflectance_sets import reflectance_set

        layout = dead_leaves_layout(config, lens.layout_lens, reflectance_set(config.scene.leaf_reflectances).names)
        meshes = leaf_meshes(layout)
        kept = [k for k, shape in enumerate(shapes) if shape["name"] not in meshes]
        self.records = [shapes[k] for k in kept]
        self.shape_to_instance = np.full(len(shapes), -1, np.int64)
        self.shape_to_instance[kept] = np.arange(len(kept))
        self.leaves = {k: meshes[shape["name"]] for k, shape in enumerate(shapes) if shape["name"] in meshes}
        material = next(shapes[k]["material"] for k in self.leaves) if self.leaves else "none"
        set_name = config.scene.leaf_reflectances
        self.records += [{"name": f"leaf_{n}", "material": material, "leaf": True,
                          "reflectance": f"{set_name}: {layout.reflectance_names[int(layout.reflectance_index[n])]}",
                          "depth_m": float(layout.depth_m[n]), "radius_px": float(layout.radius_px[n])}
                         for n in range(len(layout))]
        self.first_leaf = len(kept)

    def __call__(self, shape: np.ndarray, image: np.ndarray) -> np.ndarray:
        """Instance indices (−1: none) of shape indices and the AOV image's primitives."""
        found = np.where(shape >= 0, self.shape_to_instance[np.clip(shape, 0, None)], -1)
        if self.leaves:
            prim = np.rint(image[..., -1]).astype(np.int64)
            for k, disc_of_triangle in self.leaves.items():
                here = shape == k
                found[here] = self.first_leaf + disc_of_triangle[np.clip(prim[here], 0, len(disc_of_triangle) - 1)]
        return found


def render_shapes(mi, config: SceneConfig, lens: ThinLens) -> tuple[np.ndarray, list[dict]]:
    """:func:`render_shape_index` with each shape's record: ``name`` (the scene dict's key or
    the XML id), ``material`` (its BSDF's Mitsuba class, or ``emitter (…)``)."""
    width, height = lens.width_px, lens.height_px
    scene, _, tiles = _pinhole_probe(mi, config, lens, _luminance_film(width, height),
                                     {"type": "aov", "aovs": SHAPE_AOVS}, spp=1, stream=1 << 21, optimize=False)
    lookup, shapes = _shape_ids(mi, scene)
    instances = _Instances(config, lens, shapes)
    index = np.empty((height, width), np.int32)
    for first, end, image in tiles():
        index[first:end] = instances(_index_of(lookup, image), image)
    return index, instances.records


#: Ranked instances a pixel's coverage keeps (Cryptomatte keeps 6 by default; 3 hold > 99 % of a
#: defocused edge's light where at most three surfaces meet).
COVERAGE_RANKS = 3


def render_shape_coverage(mi, config: SceneConfig, lens: ThinLens, *, model: str = "thin", passes: int = 64,
                          ranks: int = COVERAGE_RANKS) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """Which shapes each pixel of the thin-lens image sees, and how much of it: the soft
    segmentation under defocus.

    ``passes`` renders of Mitsuba's ``shape_index`` AOV through the frame's own camera
    (``model``: its finite aperture), one ray per pixel each through a random point of the
    pixel and of the aperture; a shape's coverage of a pixel is the fraction of its rays that
    meet it first (Cryptomatte's ranked id/coverage pairs).

    Returns
    -------
    ids : numpy.ndarray
        (H, W, ranks) int32 places in the shape list, most coverage first (−1: none).
    coverage : numpy.ndarray
        (H, W, ranks) float32 fractions of the pixel's rays (summing to 1 with the rays that
        escape, and those of lower ranks).
    shapes : list of dict
        As :func:`render_shapes`.

    References
    ----------
    .. [1] Friedman, J., & Jones, A. C. (2015). Fully automatic ID mattes with support for motion
       blur and transparency. SIGGRAPH 2015 Posters (Cryptomatte: ranked id and coverage pairs).
    """
    width, height = lens.width_px, lens.height_px
    scene, _, tiles = _pinhole_probe(mi, config, lens, _luminance_film(width, height),
                                     {"type": "aov", "aovs": SHAPE_AOVS}, spp=1, stream=1 << 24, optimize=False,
                                     model=model)
    lookup, shapes = _shape_ids(mi, scene)
    instances = _Instances(config, lens, shapes)
    shapes = instances.records
    seen = np.empty((height * width, passes), np.int64)
    for k in range(passes):
        for first, end, image in tiles(k):
            seen[first * width:end * width, k] = instances(_index_of(lookup, image), image).ravel()
    pixel = np.repeat(np.arange(height * width, dtype=np.int64), passes)
    keys, counts = np.unique(pixel * (len(shapes) + 1) + seen.ravel() + 1, return_counts=True)
    owner, shape = keys // (len(shapes) + 1), keys % (len(shapes) + 1) - 1
    hit = shape >= 0  # the rays that escape hold what the ranks leave
    owner, shape, counts = owner[hit], shape[hit], counts[hit]
    order = np.lexsort((-counts, owner))  # by pixel, most rays first
    owner, shape, counts = owner[order], shape[order], counts[order]
    rank = np.arange(len(owner)) - np.searchsorted(owner, owner)
    ids = np.full((height * width, ranks), -1, np.int32)
    coverage = np.zeros((height * width, ranks), np.float32)
    kept = rank < ranks
    ids[owner[kept], rank[kept]] = shape[kept]
    coverage[owner[kept], rank[kept]] = counts[kept] / passes
    return ids.reshape(height, width, ranks), coverage.reshape(height, width, ranks), shapes


ALBEDO_INTEGRATOR = "spectral_cam_albedo"


def _albedo_class(mi):
    """A Mitsuba integrator returning, at each camera ray's first hit, its BSDF's diffuse
    reflectance (``eval_diffuse_reflectance``) at the ray's wavelengths: on a band film, the band
    integral of ρ(λ). (Mitsuba's own ``aov`` albedo aborts on a ``specfilm``: heap corruption in
    3.9.1.) Registered once per variant (:func:`.plugins.register_once`)."""
    import drjit as dr

    # Mitsuba requires this class inside a function: a Python plugin subclasses the active variant's
    # mi.SamplingIntegrator, which exists only once mi.set_variant has run and is another class in each variant
    # (so one class is made and registered per variant: mi.register_*)
    class Albedo(mi.SamplingIntegrator):
        def sample(self, scene, sampler, ray, medium=None, active=True):
            si = scene.ray_intersect(ray, active)
            hit = si.is_valid()
            value = si.bsdf(ray).eval_diffuse_reflectance(si, hit)
            return dr.select(hit, value, 0.0), hit, []

    return Albedo


#: The albedo's bands: 5 nm over the camera curves' range (the render's 10-nm bands put the
#: camera RGB of a ColorChecker patch up to 3.8 % off a 1-nm integral; 5 nm within 1 %).
ALBEDO_BANDS = "380:720:5"
#: Rays per pixel of the albedo probe (textures averaged within the pixel).
ALBEDO_SPP = 256


def render_albedo(mi, config: SceneConfig, lens: ThinLens, *, spp: int = ALBEDO_SPP,
                  bands: str = ALBEDO_BANDS) -> np.ndarray:
    """(H, W, B) band integrals of the diffuse reflectance ρ(λ) seen through an ideal pinhole
    over the frame (``spp`` rays per pixel, averaged over textures within the pixel), on
    ``bands`` (:data:`ALBEDO_BANDS`). 0 where nothing is hit.

    References
    ----------
    .. [1] Jakob, W., et al. (2022). Mitsuba 3, ``BSDF.eval_diffuse_reflectance``; custom
       integrators in Python (``mi.SamplingIntegrator``).
    """
    from .. import spectra
    from .films import band_film

    register_once(mi, "integrator", ALBEDO_INTEGRATOR, _albedo_class)
    width, height = lens.width_px, lens.height_px
    bands = spectra.parse_bands(bands)
    _, _, tiles = _pinhole_probe(mi, config, lens, band_film(bands, width, height), {"type": ALBEDO_INTEGRATOR},
                                 spp=spp, stream=1 << 22)
    out = np.empty((height, width, len(bands)), np.float32)
    for first, end, image in tiles():
        out[first:end] = image
    return out


#: Surfaces each pinhole ray is followed through for the amodal masks (a closed object takes two).
AMODAL_LAYERS = 8
_LAYERS_INTEGRATOR = "spectral_cam_shape_layers"


def _shape_layers_class(mi):
    """A Mitsuba integrator returning, along each camera ray, the shape and primitive of each of
    the first :data:`AMODAL_LAYERS` surfaces it passes through (AOVs ``<k>_s``, ``<k>_p``; 0 past
    the last): the ray is spawned on from every hit, whatever the material."""
    import drjit as dr

    # Mitsuba requires this class inside a function: a Python plugin subclasses the active variant's
    # mi.SamplingIntegrator, which exists only once mi.set_variant has run and is another class in each variant
    # (so one class is made and registered per variant: mi.register_*)
    class ShapeLayers(mi.SamplingIntegrator):
        def aov_names(self):
            return [f"{k}_{c}" for k in range(AMODAL_LAYERS) for c in "sp"]

        def sample(self, scene, sampler, ray, medium=None, active=True):
            ray, alive, layers = mi.Ray3f(ray), mi.Bool(active), []
            for _ in range(AMODAL_LAYERS):
                si = scene.ray_intersect(ray, alive)
                alive = alive & si.is_valid()
                layers += [dr.select(alive, mi.Float(dr.reinterpret_array(mi.UInt32, si.shape)), 0.0),
                           dr.select(alive, mi.Float(si.prim_index), 0.0)]
                ray = si.spawn_ray(ray.d)
            return mi.Spectrum(0.0), mi.Bool(True), layers

    return ShapeLayers


def render_shape_layers(mi, config: SceneConfig, lens: ThinLens) -> np.ndarray | None:
    """The shapes each pixel's pinhole ray passes through: (H, W, :data:`AMODAL_LAYERS`) indices
    into :func:`render_shapes`' shapes, nearest first (−1: none), on the
    segmentation's own rays (the same random point of each pixel: layer 0 is its shape map).
    None in Mitsuba's scalar variants, whose shapes have no registry ids to return.

    References
    ----------
    .. [1] Everitt, C. (2001). Interactive order-independent transparency. NVIDIA (depth peeling).
    .. [2] Jakob, W., et al. (2022). Mitsuba 3, ``Scene.ray_intersect``, ``SurfaceInteraction3f.spawn_ray``.
    """
    if mi.variant().startswith("scalar"):
        return None
    register_once(mi, "integrator", _LAYERS_INTEGRATOR, _shape_layers_class)
    width, height = lens.width_px, lens.height_px
    # the shape map's stream and spp: the same rays as the segmentation's (render.depth.render_shapes)
    scene, _, tiles = _pinhole_probe(mi, config, lens, _luminance_film(width, height), {"type": _LAYERS_INTEGRATOR},
                                     spp=1, stream=1 << 21, optimize=False)
    lookup, shapes = _shape_ids(mi, scene)
    instances = _Instances(config, lens, shapes)
    out = np.empty((height, width, AMODAL_LAYERS), np.int64)
    for first, end, image in tiles():
        for k in range(AMODAL_LAYERS):
            pair = image[..., -2 * AMODAL_LAYERS + 2 * k:][..., :2]  # (shape, primitive), as _index_of reads them
            out[first:end, :, k] = instances(_index_of(lookup, pair), pair)
    return out
