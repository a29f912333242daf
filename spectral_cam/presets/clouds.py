"""Cloud cover for the sun and sky of the outdoor presets (``sky.cloud_cover``).

Mitsuba's ``sunsky`` (Hosek & Wilkie 2012) is a clear sky. A partly cloudy sky is modelled by a
layer of cumulus at the cloud base, :data:`CLOUD_BASE_M` over the ground: a horizontal sheet,
:data:`CLOUD_LAYER_M` on a side around the look point, kept where a fractional Brownian motion
field exceeds the quantile that leaves ``cloud_cover`` of the sky covered (cells of a
:data:`CLOUD_GRID`² grid; the fraction is exact on the grid). Each cloud scatters light
diffusely both ways, flat in spectrum (cloud droplets are far larger than the wavelength:
Mie scattering is grey across the visible): it reflects :data:`THICK_CLOUD` or
:data:`THIN_CLOUD`'s albedo to the side the light comes from and transmits the rest less its
absorption to the other, thick in a cloud's core and thin at its edges (a blend weighted by how
far the field rises over the threshold). So the sun is hidden, and the ground in a cloud's
shadow is lit by the clouds' transmitted light and the blue sky between them (soft shadows,
less contrast); the camera sees white-grey clouds between patches of blue.

The light a white balance reads stays the sun and sky's (:mod:`spectral_cam.render.lights`
probes the scene without the cloud layer): the clouds pass the sun's light on in the same
spectrum, whereas counting them as occluders would balance a frame in a cloud's shadow for the
blue sky alone.

References
----------
.. [1] Wallace, J. M., & Hobbs, P. V. (2006). Atmospheric Science, 2nd ed., §6.1 (fair-weather
   cumulus bases at 0.5–2 km) and §4.5 (cloud albedo 0.4–0.8, transmittance of a cumulus
   0.1–0.5 by its optical depth; cloud droplets scatter the visible greyly).
.. [2] Stephens, G. L. (1978). Radiation profiles in extended water clouds. II: Parameterization
   schemes. Journal of the Atmospheric Sciences 35(11), 2123–2132 (reflected, transmitted and
   absorbed shares of solar light by cloud optical depth).
.. [3] Lovejoy, S. (1982). Area–perimeter relation for rain and cloud areas. Science 216(4542),
   185–187 (cloud outlines are fractal: thresholded fBm reproduces them).
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from ..scene import SceneConfig
    from .outdoor import GroundView

__all__ = ["CLOUD_BASE_M", "CLOUD_LAYER_M", "CLOUD_GRID", "THICK_CLOUD", "THIN_CLOUD", "cloud_field",
           "cloud_mask", "cloud_layer"]

#: Height of the cloud base over the ground (m): fair-weather cumulus (Wallace & Hobbs §6.1).
CLOUD_BASE_M = 1500.0
#: Side of the cloud layer (m): from the look point the sky is covered down to ~4° over the
#: horizon (atan(1.5/20)); beyond, the clear sky shows low at the horizon.
CLOUD_LAYER_M = 40000.0
#: Cells of the cloud grid on a side (39 m each) and the period of the field's largest features.
CLOUD_GRID, CLOUD_PERIOD_CELLS = 1024, 160.0
#: (reflectance, transmittance) of a cloud's core and of its edges: a cumulus of optical depth
#: ~30 reflects ~0.75 and passes ~0.2, a thin one (~5) reflects ~0.45 and passes ~0.5, with a
#: few per cent absorbed (Stephens 1978).
THICK_CLOUD, THIN_CLOUD = (0.75, 0.2), (0.45, 0.5)
#: Rise of the field over the threshold (in its standard deviations) at which a cloud is thick.
THICK_RISE = 1.0


def cloud_field(seed: int) -> np.ndarray:
    """The fBm field whose high ground is cloud (:func:`spectral_cam.textures.fbm`)."""
    from ..textures import fbm

    return fbm(CLOUD_GRID, period_px=CLOUD_PERIOD_CELLS, octaves=6, seed=int(seed) + 0xC10D)


def cloud_mask(field: np.ndarray, cover: float) -> tuple[np.ndarray, float]:
    """Cells under cloud (the ``cover`` share of them with the highest field) and the threshold."""
    threshold = float(np.quantile(field, 1.0 - cover)) if cover < 1.0 else -np.inf
    return field > threshold, threshold


def _sheet(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices (local, the layer in [-1, 1]², z = 0), faces (two per covered cell, facing down)
    and texture coordinates of the covered cells of ``mask``; vertices no cell uses are dropped."""
    n = mask.shape[0]
    rows, cols = np.nonzero(mask)
    corners = np.stack([rows * (n + 1) + cols, rows * (n + 1) + cols + 1,
                        (rows + 1) * (n + 1) + cols + 1, (rows + 1) * (n + 1) + cols], axis=1)
    used, index = np.unique(corners, return_inverse=True)
    index = index.reshape(corners.shape)
    r, c = np.divmod(used, n + 1)
    uv = np.stack([c / n, r / n], axis=1)
    vertices = np.stack([2 * uv[:, 0] - 1, 2 * uv[:, 1] - 1, np.zeros(len(used))], axis=1)
    faces = np.concatenate([index[:, [0, 2, 1]], index[:, [0, 3, 2]]])  # wound to face down (−z)
    return vertices, faces, uv


@functools.lru_cache(maxsize=4)
def _cloud_geometry(seed: int, cover: float) -> tuple[np.ndarray, ...]:
    """The layer's sheet (:func:`_sheet`) and thickness map, made once per layout and cover: a
    job builds its scene several times (probes, depth, labels), 0.4 s each for 10⁶ triangles."""
    field = cloud_field(seed)
    mask, threshold = cloud_mask(field, cover)
    thickness = np.clip((field - threshold) / THICK_RISE, 0.0, 1.0) if np.isfinite(threshold) else np.ones_like(field)
    out = (*_sheet(mask), thickness)
    for array in out:
        array.setflags(write=False)
    return out


def _cloud_bsdf(albedo: tuple[float, float]) -> dict:
    from ..leaves import LEAF_PLUGIN

    reflectance, transmittance = albedo
    return {"type": LEAF_PLUGIN, "reflectance": {"type": "uniform", "value": reflectance},
            "transmittance": {"type": "uniform", "value": transmittance}}


def cloud_layer(config: "SceneConfig", view: "GroundView", mi) -> dict:
    """The cloud layer of ``sky.cloud_cover`` as scene-dict entries (none for a clear sky), drawn
    by ``scene.layout_seed``."""
    from .common import bitmap_texture
    from .meshes import mitsuba_mesh

    cover = float(config.sky.cloud_cover)
    if cover <= 0.0:
        return {}
    vertices, faces, uv, thickness = _cloud_geometry(int(config.scene.layout_seed), cover)
    bsdf = {"type": "blendbsdf", "weight": bitmap_texture(mi, thickness),
            "bsdf_0": _cloud_bsdf(THIN_CLOUD), "bsdf_1": _cloud_bsdf(THICK_CLOUD)}
    half = CLOUD_LAYER_M / 2
    place = mi.ScalarTransform4f().translate([0.0, 0.0, CLOUD_BASE_M]).scale([half, half, 1.0])
    return {"clouds": mitsuba_mesh(mi, "clouds", vertices, faces, bsdf, view.transform(mi, place), texcoords=uv)}
