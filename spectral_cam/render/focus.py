"""Focus on a named object: ``lens.focus_object`` sets ``lens.focus_distance_m`` to the depth of
that shape of the scene (an XML scene's shape ``id``, or a preset's object such as ``object_3``
or ``plant_2``), as a photographer puts the focus point on a subject.

The depth is that of the object's visible surface along the ray from the camera to the centre
of its bounding box (camera-space z, as the depth label is), or of that centre when another
shape hides it there: a sphere is focused on its near surface, not its middle.

References
----------
.. [1] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10 (focusing on a subject).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from ..errors import ConfigError
from ..optics import ThinLens
from ..scene import SceneConfig

__all__ = ["resolve_focus"]


def resolve_focus(config: SceneConfig, lens: ThinLens) -> tuple[SceneConfig, dict | None, ThinLens]:
    """The scene with ``lens.focus_distance_m`` set from ``lens.focus_object`` (unchanged, with
    record None, when no object is named), a record for ``model_decisions["focus"]``, and
    ``lens`` (built from ``config``) focused there.

    Raises
    ------
    ConfigError
        When no shape has that id (the message lists the scene's), or the object lies behind
        the camera or nearer than the lens can focus.
    """
    if not config.lens.focus_object:
        return config, None, lens
    for _ in range(4):  # a preset laid out against the lens moves a little as the focus (and so the
        distance, record = _focus_depth(config, lens)  # image distance) changes: iterate to the fixed point
        settled = abs(distance - config.lens.focus_distance_m) <= 1e-7 * distance
        config = config.replace(**{"lens.focus_distance_m": distance})
        lens = dataclasses.replace(lens, focus_distance_m=distance)
        if settled:
            break
    if distance * 1000.0 <= config.lens.focal_length_mm * 1.001:
        raise ConfigError(f"lens.focus_object = {config.lens.focus_object!r} lies {distance:.3g} m from the camera, "
                          f"nearer than the {config.lens.focal_length_mm:g} mm lens can focus; choose another object")
    return config, record, lens


@functools.lru_cache(maxsize=16)
def _focus_depth(config: SceneConfig, lens: ThinLens) -> tuple[float, dict]:
    """(depth, record) of ``config``'s focus object seen through ``lens`` (the scene laid out
    for it), with Mitsuba's variant already set; cached on both (a dataset's items repeat them)."""
    import mitsuba as mi

    from .scene_dict import build_scene, camera_dict

    name = config.lens.focus_object
    film = {"type": "hdrfilm", "width": 8, "height": 8}
    scene, sensor, _ = build_scene(mi, config, lens.layout_lens, camera_dict(mi, lens.layout_lens, "pinhole", film, 1),
                                   {"type": "direct"})
    shapes = {shape.id(): shape for shape in scene.shapes()}
    if name not in shapes:
        known = sorted(key for key in shapes if key)
        listed = ", ".join(known[:30]) + (f" … ({len(known)} in all)" if len(known) > 30 else "")
        raise ConfigError(f"lens.focus_object = {name!r} is no shape of the scene; its shapes: {listed or 'none with an id'}")
    to_world = np.asarray(sensor.world_transform().matrix, dtype=np.float64).reshape(4, 4, -1)[..., 0]
    origin, axis = to_world[:3, 3], to_world[:3, 2] / np.linalg.norm(to_world[:3, 2])
    box = shapes[name].bbox()
    centre = np.array([(float(box.min[i]) + float(box.max[i])) / 2 for i in range(3)])
    direction = (centre - origin) / np.linalg.norm(centre - origin)
    hit = scene.ray_intersect(mi.Ray3f(mi.Point3f(*map(float, origin)), mi.Vector3f(*map(float, direction))))
    if bool(np.asarray(hit.is_valid() & (hit.shape == mi.ShapePtr(shapes[name])))[0]):
        point, how = np.array([float(np.asarray(c)[0]) for c in hit.p]), "its surface on the ray to its centre"
    else:
        point, how = centre, "its bounding box's centre (another shape hides it there)"
    depth = float((point - origin) @ axis)
    if depth <= 0:
        raise ConfigError(f"lens.focus_object = {name!r} lies behind the camera; choose an object in view")
    return depth, {"choice": depth, "object": name, "at": how,
                   "reason": f"lens.focus_object = {name!r}: the depth of {how}"}
