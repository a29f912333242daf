"""``room``: a furnished room seen from inside — textured walls, floor and ceiling, a wooden
table on a rug, a fabric sofa with cushions, a bookshelf full of books, a painted sideboard, a
metal floor lamp and things on the table — lit by a ceiling panel and the floor lamp's shade,
both of ``[illuminant]``'s spectrum (a measured LED, fluorescent or incandescent light).

Frame: the room's floor is z = 0 with x east, y north (the camera looks roughly north) and z
up, its origin under the table's centre, which is the look point: the camera stands
``scene.distance_m`` from it, looking down ``scene.view_pitch_deg`` and turned by a yaw of
6–14° to either side drawn by ``layout_seed`` (so one corner is in view). Camera frame as in
:mod:`spectral_cam.presets.outdoor` (:class:`~spectral_cam.presets.outdoor.GroundView`).

Every surface is a triangle mesh whose texture coordinates are metres on its faces, so one
texture keeps its scale on every object; every material is two-sided. Spectra (all measured):

* floor: boards of the USGS pines (``usgs_wood``) in grain (fractal fields stretched 12×
  along the boards, :func:`spectral_cam.textures.grain_maps`), each board its own part of the
  grain and its own stain; a stain is the pine's reflectance raised to a power k (its
  absorbance × k, Beer–Lambert: k = 1.6 oak, 2.2 honey, 3 walnut; the table 3.2), the joints between boards the stained
  wood at a fifth (a shadowed gap);
* walls: a paint drawn from ``scene.object_reflectances`` (L* 62–90, C* 3–30 under D65; the back wall a
  stronger colour, C* 15–32), mixed by low-contrast fBm with the same paint at 0.85 (uneven
  wear) and bump-mapped (plaster); white skirting boards and ceiling (ColorChecker white);
* fabric: a twill-woven tartan of two or three spectra of the set (warp and weft stripes of
  4–40 mm, threads of 1 mm over and under in a 2/2 twill);
* rug: a border and a diamond field of ColorChecker spectra; painting: fractal patches of
  five ColorChecker colours; books and the sideboard: samples of the set;
* metal: ``roughconductor`` with Mitsuba's measured η, k (Al, Cu, Au; Palik).

Light: the ceiling panel is a square 1 m on a side over the table whose radiance gives the
table's top ``illuminance_lux`` at its centre (E/L = 4·A/√(1+A²)·atan(A/√(1+A²)),
:func:`spectral_cam.presets.outdoor.lamp_irradiance_factor`); the floor lamp's shade sends
:data:`LAMP_FLUX_LM` lumens through diffusers closing it below and above. One spectrum lights
the room, so its white balance and ground truth are ``[illuminant]``'s.

Here: the lights and the preset, which turns the layout into Mitsuba meshes. Where each piece
stands is :mod:`spectral_cam.presets.room_furniture`; the spectra picked, the patterns and the
BSDFs are :mod:`spectral_cam.presets.room_materials`.

References
----------
.. [1] Keshava, N., & Mustard, J. F. (2002). Spectral unmixing. IEEE Signal Processing
   Magazine 19(1), 44–57 (linear mixing of measured spectra).
.. [2] Kokaly, R. F., et al. (2017). USGS Spectral Library Version 7 (woods).
.. [3] CIE 224:2017 (the colour samples); Pascale, D. (2006), BabelColor ColorChecker averages.
.. [4] Howell, J. R., A Catalog of Radiation Heat Transfer Configuration Factors, C-11.
.. [5] Palik, E. D. (1985). Handbook of Optical Constants of Solids (Mitsuba's conductors).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .. import spectra
from .common import PRESETS, spectrum_dict
from .meshes import set_vertex_normals, vertex_normals
# the layout's frame and dimensions, and the layout itself, importable from here as before the split
from .room_furniture import (BACK_WALL_M, ROOM_HEIGHT_M, SHADE_RADII_M, SHADE_Z_M, SIDE_WALL_M,  # noqa: F401
                             TABLE_HEIGHT_M, Piece, RoomLayout, room_layout, room_view)

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

__all__ = ["Piece", "RoomLayout", "room_layout", "room_view", "ceiling_lamp", "lamp_diffusers", "ROOM_HEIGHT_M",
           "TABLE_HEIGHT_M"]

#: The ceiling panel: side (m).
PANEL_SIDE_M = 1.0
#: The floor lamp: luminous flux (lm; a 400-lm "40 W" bulb) leaving its shade's diffusers and the
#: share going down (its shade's radii and heights: :data:`SHADE_RADII_M`, :data:`SHADE_Z_M`).
LAMP_FLUX_LM, LAMP_DOWN_SHARE = 400.0, 0.6


# ----------------------------------------------------------------------------- light
def ceiling_lamp(config: "SceneConfig", view, mi, *, centre=(0.0, 0.0)) -> dict:
    """The ceiling panel (:data:`PANEL_SIDE_M` square, facing down, over ``centre``): its
    radiance L(λ) = E(λ)/F with E the ``[illuminant]`` irradiance of ``illuminance_lux`` and
    F = :func:`~spectral_cam.presets.outdoor.lamp_irradiance_factor` for the drop to the
    table's top, so the table's centre receives ``illuminance_lux`` from it."""
    from .common import light_irradiance
    from .outdoor import lamp_irradiance_factor

    wavelengths, irradiance = light_irradiance(config)
    radiance = irradiance / lamp_irradiance_factor(PANEL_SIDE_M / 2, ROOM_HEIGHT_M - 0.005 - TABLE_HEIGHT_M)
    local = (mi.ScalarTransform4f().translate([centre[0], centre[1], ROOM_HEIGHT_M - 0.005])
             .rotate([1, 0, 0], 180.0).scale([PANEL_SIDE_M / 2, PANEL_SIDE_M / 2, 1.0]))
    return {"type": "rectangle", "to_world": view.transform(mi, local),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "uniform", "value": 0.0}},
            "emitter": {"type": "area", "radiance": spectrum_dict((wavelengths, radiance))}}


def lamp_diffusers(config: "SceneConfig", view, mi, centre) -> dict:
    """The floor lamp's light: two Lambertian diffusers closing its shade, the bottom one facing
    down with :data:`LAMP_DOWN_SHARE` of :data:`LAMP_FLUX_LM` lumens of ``[illuminant]``'s
    spectrum, the top one facing up with the rest: a disc of area A sending Φ has
    L = Φ/(π·A), so L(λ) = Φ_v/(π·A) × (the spectral irradiance of 1 lx). (Area lights are
    sampled directly; a bulb inside the shade lit its inside, a small bright surface that
    only paths found by chance: speckles on the walls.)"""
    wavelengths, per_lux = spectra.absolute_irradiance(config.illuminant.spd if config.illuminant.spd != "auto"
                                                       else "D65", 1.0)
    out = {}
    for name, radius, z, share, turn in (("lamp_light_down", SHADE_RADII_M[0], SHADE_Z_M[0] + 0.002, LAMP_DOWN_SHARE,
                                          180.0),
                                         ("lamp_light_up", SHADE_RADII_M[1], SHADE_Z_M[1] - 0.002,
                                          1.0 - LAMP_DOWN_SHARE, 0.0)):
        radiance = LAMP_FLUX_LM * share * per_lux / (math.pi * math.pi * radius ** 2)
        local = (mi.ScalarTransform4f().translate([float(centre[0]), float(centre[1]), z]).rotate([1, 0, 0], turn)
                 .scale([radius, radius, 1.0]))
        out[name] = {"type": "disk", "to_world": view.transform(mi, local),
                     "bsdf": {"type": "diffuse", "reflectance": {"type": "uniform", "value": 0.0}},
                     "emitter": {"type": "area", "radiance": spectrum_dict((wavelengths, radiance))}}
    return out


def _mesh(mi, piece: Piece, bsdf, view, texcoords: bool):
    vertices = view.to_camera(piece.vertices)
    props = mi.Properties()
    props["bsdf"] = bsdf
    mesh = mi.Mesh(piece.name, len(vertices), len(piece.faces), props=props, has_vertex_normals=not texcoords,
                   has_vertex_texcoords=texcoords and piece.texcoords is not None)
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(np.ascontiguousarray(vertices, dtype=np.float32).ravel())
    params["faces"] = mi.UInt32(np.ascontiguousarray(piece.faces, dtype=np.uint32).ravel())
    if texcoords and piece.texcoords is not None:
        params["vertex_texcoords"] = mi.Float(np.ascontiguousarray(piece.texcoords, dtype=np.float32).ravel())
    params.update()
    return mesh


@PRESETS.register("room", options=("distance_m", "view_pitch_deg", "object_count", "object_reflectances",
                                   "layout_seed"),
                  description="a furnished room (wood floor, painted walls, sofa, table, rug, books, metal lamp) "
                              "lit by a ceiling panel and a floor lamp of [illuminant]'s spectrum")
def room(config: "SceneConfig", lens: "ThinLens", mi) -> dict:
    """The pieces of :func:`room_layout` as Mitsuba meshes (each material loaded once and shared),
    the ceiling panel over the table and the floor lamp's diffusers."""
    layout = room_layout(config, lens)
    view = room_view(config)
    loaded = {}
    objects = {}
    for piece in layout.pieces:
        if piece.material not in loaded:
            loaded[piece.material] = mi.load_dict(layout.materials[piece.material](mi))
        lathe_piece = piece.texcoords is None
        mesh = _mesh(mi, piece, loaded[piece.material], view, texcoords=not lathe_piece)
        if lathe_piece:  # curved: smooth shading, with normals summed in a fixed order (issue 39 #17)
            set_vertex_normals(mi, mesh, vertex_normals(view.to_camera(piece.vertices), piece.faces))
        objects[piece.name] = mesh
    objects["ceiling_lamp"] = ceiling_lamp(config, view, mi)
    objects.update(lamp_diffusers(config, view, mi, layout.lamp_m))
    return objects
