"""Camera-space depth z (m) per pixel from the position AOV (not the ray length).

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3, plugin ``aov`` (position).
"""

from __future__ import annotations

import numpy as np

from ..optics import ThinLens
from ..scene import SceneConfig
from .scene_dict import build_scene, camera_dict, frame_tiles, pass_seed, release_render_memory, tile_sensors


def render_depth(mi, config: SceneConfig, lens: ThinLens) -> np.ndarray:
    """Camera-space z (m) per pixel from the first hit's world position.

    Mitsuba's ``depth`` AOV is the ray length, which off axis exceeds z by 1/cos θ, so z is
    taken as (p − camera origin)·(optical axis) from the ``position`` AOV. One sample per
    pixel keeps it the depth of one surface, never a blend across an edge.
    """
    width, height = lens.width_px, lens.height_px
    film = {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
            "pixel_format": "luminance", "component_format": "float32"}
    tiles = frame_tiles(width, height)  # the radiance's tiles: bounded memory on large frames
    camera = camera_dict(mi, lens, "pinhole", film, 1)
    scene, sensor, integrator = build_scene(mi, config, lens, camera, {"type": "aov", "aovs": "pos:position"})
    to_world = np.asarray(sensor.world_transform().matrix, dtype=np.float64).reshape(4, 4, -1)[..., 0]
    origin, axis = to_world[:3, 3], to_world[:3, 2] / np.linalg.norm(to_world[:3, 2])
    depth = np.empty((height, width), np.float32)
    for _, (first, end), tile_camera, seed_key in tile_sensors(mi, sensor, camera, tiles):
        seed = pass_seed(config.render.seed, 1 << 20, seed_key)
        image = np.asarray(mi.render(scene, sensor=tile_camera, integrator=integrator, seed=seed, spp=1))
        position = image.reshape(end - first, width, -1)[..., :3].astype(np.float64)
        z = (position - origin) @ axis
        hit = np.any(position != 0.0, axis=-1)  # the AOV is all zero where a ray escapes
        depth[first:end] = np.where(hit & (z > 0), z, np.inf)
    del image
    release_render_memory()
    return depth
