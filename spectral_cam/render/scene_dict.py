"""The Mitsuba scene of a SceneConfig: our camera (thin lens or pinhole, film, sampler),
the preset's objects or a user's XML scene with its pose, and the integrator.

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3, plugins ``thinlens``, ``perspective``.
.. [2] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §5.2.3 (thin lens).
"""

from __future__ import annotations

import numpy as np

from ..errors import RenderError
from ..optics import ThinLens
from ..scene import RENDER_SAMPLERS, SceneConfig
from .lens_models import FAR_CLIP_M, LENS_MODELS, camera_options  # noqa: F401  (FAR_CLIP_M: its old home)


#: Mitsuba samplers a render may use (``render.sampler``, validated in scene.py). Each keeps some
#: sample counts per pass exactly and rounds others up (stratified and ldsampler to powers of 4,
#: multijitter 32 to 35 and 128 to 132; orthogonal to prime squares, 64 to 121, so it is not offered).
SAMPLERS = RENDER_SAMPLERS


def power_of_two_at_most(spp: int) -> int:
    """The largest power of two ≤ ``spp`` (at least 1): the samples per pixel of one pass.

    With the LLVM variant a pass whose samples per pixel is not a power of two gives
    run-to-run differences in the last bits (measured: 25, 26, 27, 100, 109 spp differ in
    1–10 % of the values between two renders of one seed; 1, 2, 4, …, 128 never do, at any
    image size): the film adds a pixel's samples in an order that then depends on the
    threads. Passes of 2^k spp make a seed give the same bits every time.

    Examples
    --------
    >>> [power_of_two_at_most(n) for n in (1, 3, 27, 64, 100)]
    [1, 2, 16, 64, 64]
    """
    return 1 << max(int(spp), 1).bit_length() - 1


def exact_pass_spp(sampler: str, spp: int) -> int:
    """The largest samples-per-pixel count ≤ ``spp`` that is a power of two (a seed then gives
    the same bits every time, see :func:`power_of_two_at_most`) and
    that ``sampler`` keeps as it is, so a frame gets exactly the samples asked for.

    Examples
    --------
    >>> [exact_pass_spp("multijitter", n) for n in (1, 3, 8, 32, 100, 256)]
    [1, 2, 8, 16, 64, 256]
    >>> [exact_pass_spp("independent", n) for n in (3, 32, 100)]
    [2, 32, 64]
    """
    count = power_of_two_at_most(spp)
    while count > 1:
        power_of_four = count.bit_length() % 2 == 1
        if sampler == "independent" or power_of_four or (sampler == "multijitter" and count in (2, 8)):
            return count
        count >>= 1
    return 1


#: Most pixels of one render call. A larger frame renders in tiles of whole rows (film crop
#: windows, :func:`frame_tiles`): Mitsuba's film and wavefront then need memory for one tile,
#: not the frame (measured at 2.5 MP, 31 bands, 16 spp: one call 1.13 GB peak, tiles of
#: 0.6 MP 0.68 GB, as fast). The grid depends on the frame's size only, so a seed gives the
#: same image on any machine; frames up to this size render in one call as before.
TILE_PIXELS = 1 << 20
#: Tile heights are a multiple of this many rows (an OpenEXR ZIP block is 16 scanlines).
TILE_ROW_MULTIPLE = 16


def frame_tiles(width: int, height: int) -> list[tuple[int, int]]:
    """Row spans ``(first, end)`` of the render tiles of a ``width`` × ``height`` frame: the
    whole frame when it has at most :data:`TILE_PIXELS` pixels, else stripes of whole rows,
    :data:`TILE_ROW_MULTIPLE` rows at the least, each at most :data:`TILE_PIXELS` pixels
    where the width allows.

    Examples
    --------
    >>> frame_tiles(640, 480)
    [(0, 480)]
    >>> frame_tiles(4096, 600)
    [(0, 256), (256, 512), (512, 600)]
    """
    if width * height <= TILE_PIXELS:
        return [(0, height)]
    rows = max(TILE_ROW_MULTIPLE, TILE_PIXELS // width // TILE_ROW_MULTIPLE * TILE_ROW_MULTIPLE)
    return [(first, min(first + rows, height)) for first in range(0, height, rows)]


def tile_sensors(mi, sensor, camera: dict, tiles: list[tuple[int, int]]):
    """(tile index, rows, sensor, seed key) for each tile of :func:`frame_tiles`: an untiled
    frame renders through its own ``sensor`` with the seeds it always had (key None); a tile
    through :func:`tile_sensor` with its index as the key of its seeds (:func:`pass_seed`)."""
    if len(tiles) == 1:
        yield 0, tiles[0], sensor, None
        return
    for index, rows in enumerate(tiles):
        yield index, rows, tile_sensor(mi, sensor, camera, rows), index


def tile_sensor(mi, sensor, camera: dict, rows: tuple[int, int]):
    """A copy of the loaded ``sensor`` (built from ``camera``, pose included) whose film
    renders only ``rows`` of the frame: a crop window, so each pixel sees the rays it would
    see in the whole frame."""
    first, end = rows
    film = dict(camera["film"], crop_offset_x=0, crop_offset_y=first, crop_width=camera["film"]["width"],
                crop_height=end - first)
    matrix = np.asarray(sensor.world_transform().matrix, dtype=np.float64).reshape(4, 4, -1)[..., 0]
    return load_dict(mi, dict(camera, film=film, to_world=mi.ScalarTransform4f(matrix)))


def moved_sensor(mi, sensor, camera: dict, move):
    """A copy of the loaded ``sensor`` (its film crop and pose kept) moved by ``move`` in its
    own frame: a motion-blur sub-frame's camera."""
    matrix = np.asarray(sensor.world_transform().matrix, dtype=np.float64).reshape(4, 4, -1)[..., 0]
    film = dict(camera["film"])
    crop = sensor.film().crop_offset(), sensor.film().crop_size()
    if tuple(crop[1]) != tuple(sensor.film().size()):
        film.update(crop_offset_x=int(crop[0][0]), crop_offset_y=int(crop[0][1]), crop_width=int(crop[1][0]),
                    crop_height=int(crop[1][1]))
    return load_dict(mi, dict(camera, film=film, to_world=mi.ScalarTransform4f(matrix) @ move))


def camera_dict(mi, lens: ThinLens, model: str, film: dict, spp: int, sampler: str = "independent",
                glass: str = "N-BK7", prescription: str = "dgauss_50mm", blades: int = 0,
                blade_rotation_deg: float = 0.0, blade_rounding: float = 0.0,
                distortion=(0.0, 0.0, 0.0, 0.0, 0.0)) -> dict:
    """Our camera as a Mitsuba sensor dict for the lens model ``model`` (an entry of
    :data:`~spectral_cam.render.lens_models.LENS_MODELS`: ``"pinhole"``, ``"thin"``,
    ``"spectral_thin"``, ``"prescription"``, …) with the ``[lens]`` keys given, for a camera built
    without a scene (probes, tests)."""
    options = camera_options(sampler, glass=glass, prescription=prescription, blades=blades,
                             blade_rotation_deg=blade_rotation_deg, blade_rounding=blade_rounding,
                             distortion=distortion)
    return LENS_MODELS[model].camera(mi, options, lens, film, spp)


def configured_camera(mi, config: SceneConfig, lens: ThinLens, model: str, film: dict, spp: int) -> dict:
    """The camera a render of ``config`` traces through the lens model ``model``: its entry's
    ``camera`` with ``render.sampler`` and the ``[lens]`` section's glass, prescription, aperture
    blades and distortion."""
    return LENS_MODELS[model].camera(mi, config, lens, film, spp)


def build_scene(mi, config: SceneConfig, lens: ThinLens, camera: dict, integrator: dict, *, optimize: bool = True):
    """Load (scene, sensor, integrator). Presets are built as one scene dict; a user's
    Mitsuba XML scene keeps its shapes, emitters and its first sensor's pose, while our
    camera (lens, film, sampler) and integrator replace its own. ``optimize=False`` keeps
    every shape its own (Mitsuba otherwise merges shapes it finds alike: a segmentation
    needs them apart)."""
    from ..presets import build_objects
    from .leaf_bsdf import register as register_leaf

    register_leaf(mi)  # before any load: presets name it
    if not config.scene.mitsuba_xml:
        scene = {"type": "scene", "integrator": integrator, "sensor": camera}
        scene.update(build_objects(config, lens.layout_lens, mi))  # laid out for the frame
        loaded = load_dict(mi, scene, optimize=optimize)
        return loaded, loaded.sensors()[0], loaded.integrator()
    try:
        loaded = mi.load_file(config.scene.mitsuba_xml, optimize=optimize)
    except Exception as exc:
        raise RenderError(f"Mitsuba could not load {config.scene.mitsuba_xml}: {exc}") from None
    fix_computed_normals(mi, loaded)
    pose = mi.ScalarTransform4f()
    if loaded.sensors():
        matrix = np.asarray(loaded.sensors()[0].world_transform().matrix, dtype=np.float64)
        pose = mi.ScalarTransform4f(matrix.reshape(4, 4, -1)[..., 0])
    camera = dict(camera, to_world=pose @ camera_move(mi, config))
    return loaded, load_dict(mi, camera), load_dict(mi, integrator)


#: Loaded normals within this of the angle-weighted rule's (any component) were computed by
#: Mitsuba, not given by the file: its float32 sums differ from ours by ~1.5e-7.
COMPUTED_NORMALS_ATOL = 1e-5


def fix_computed_normals(mi, scene) -> int:
    """Replace the vertex normals Mitsuba computed for a loaded scene's meshes (a PLY or OBJ
    file without normals) by :func:`spectral_cam.presets.meshes.vertex_normals`, the same
    rule summed in a fixed order: Mitsuba's atomic scatter-add on its threads gives other last
    bits under load, and a grazing path then another turn (issue 39 #17). A mesh whose normals
    differ from the rule by more than :data:`COMPUTED_NORMALS_ATOL` keeps them: the file gave
    them. Returns the number of meshes changed.

    References
    ----------
    .. [1] Mitsuba 3, ``Mesh::recompute_vertex_normals`` (PLY and OBJ loaders without normals).
    """
    from ..presets.meshes import vertex_normals

    params = mi.traverse(scene)
    changed = 0
    for key in [k for k in params.keys() if k.endswith(".vertex_normals")]:
        owner = key[:-len("vertex_normals")]
        if f"{owner}vertex_positions" not in params.keys() or f"{owner}faces" not in params.keys():
            continue
        given = np.asarray(params[key], dtype=np.float64).reshape(-1, 3)
        positions = np.asarray(params[f"{owner}vertex_positions"], dtype=np.float64).reshape(-1, 3)
        if not given.size or len(given) != len(positions):
            continue
        ours = vertex_normals(positions, np.asarray(params[f"{owner}faces"], dtype=np.int64).reshape(-1, 3))
        finite = np.isfinite(given).all(axis=1)  # a vertex only degenerate faces use: NaN in Mitsuba's
        if not np.allclose(given[finite], ours[finite], rtol=0.0, atol=COMPUTED_NORMALS_ATOL):
            continue
        params[key] = type(params[key])(np.ascontiguousarray(ours, dtype=np.float32).ravel())
        changed += 1
    if changed:
        params.update()
    return changed


def camera_move(mi, config: SceneConfig):
    """``scene.camera_offset_m`` and ``camera_rotation_deg`` as a transform in the camera's own
    frame (Mitsuba's: +x image-left, +y up, +z the view): translate, then yaw about +y (> 0
    turns left), pitch about −x (> 0 tilts up), roll about +z."""
    yaw, pitch, roll = (float(v) for v in config.scene.camera_rotation_deg)
    return (mi.ScalarTransform4f().translate([float(v) for v in config.scene.camera_offset_m])
            .rotate([0, 1, 0], yaw).rotate([1, 0, 0], -pitch).rotate([0, 0, 1], roll))


def load_dict(mi, scene_dict: dict, *, optimize: bool = True):
    try:
        return mi.load_dict(scene_dict, optimize=optimize)
    except Exception as exc:  # Mitsuba raises plain RuntimeError on bad scenes
        raise RenderError(f"Mitsuba could not load the scene: {exc}") from exc

def release_render_memory() -> None:
    """Hand the memory drjit keeps for reuse after a render back to the system. The depth
    pass's buffers do not fit the radiance render's, and nothing after the last render
    allocates through drjit: kept, they only raise the job's peak (measured at 0.6 MP:
    522 → 474 MB with the depth pass's released)."""
    import drjit as dr

    dr.flush_malloc_cache()


def pass_seed(seed: int, index: int, tile: int | None = None) -> int:
    """Distinct, reproducible 32-bit seeds for the passes of one frame (and of each of its
    tiles, :func:`frame_tiles`; an untiled frame keeps the seeds it always had)."""
    spawn_key = () if tile is None else (int(tile),)
    return int(np.random.SeedSequence([seed, index], spawn_key=spawn_key).generate_state(1)[0])

