"""What every preset shares: the preset registry, measured spectra as Mitsuba spectra,
Lambertian materials, facing rectangles and the light along the optical axis.

Conventions: the camera sits at the origin looking along +z with +y up, so a point's
camera-space z is its depth. Presets without their own light are lit by one
``directional`` emitter travelling along +z (from behind the camera), whose irradiance on a
surface facing the camera is the configured illuminance: a Lambertian reflectance ρ(λ)
then has radiance ρ(λ)·E(λ)/π (docs/design.md, "Scene").

References
----------
.. [1] McCluney, W. R. (2014). Introduction to Radiometry and Photometry, 2nd ed., §1.6
   (Lambertian radiance L = ρE/π).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

from .. import spectra
from ..registry import Entry, Registry

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

#: ISO 12233:2017 low-contrast (4:1) edge: reflectances of the bright and dark sides.
EDGE_REFLECTANCES = (0.8, 0.2)


#: Reflectance of the ColorChecker's black frame (about that of the real chart's frame).
CHART_FRAME_REFLECTANCE = 0.03


SPECTRUM_STEP_NM = 5.0

#: GGX roughness below which a glossy lobe counts as sharp: its peak D = 1/(πα²) exceeds
#: 32 sr⁻¹, so a path that finds the sun or a lamp through it is rare and bright (a firefly).
#: The bundled scenes' rough lobes lie at or above it (leaf cuticles α ≥ 0.1, the room's
#: paints and metals α ≥ 0.12) and their plain means held at most 6.5e-6 fireflies
#: (docs/bench/realism.csv); the tabletop's plastics and metals reach down to 0.05.
SHARP_ALPHA = 0.1


def no_sharp_materials(config: "SceneConfig") -> tuple[str, ...]:
    """A preset of Lambertian (or rough, α ≥ :data:`SHARP_ALPHA`) materials and emitters only."""
    return ()


@dataclass(frozen=True)
class Preset(Entry):
    """One scene preset: its builder and what the renderer must know of it before building.

    Attributes
    ----------
    function : callable
        The builder, ``(config, lens, mi) -> dict`` of Mitsuba scene-dict entries (shapes and
        emitters).
    sharp_materials : callable
        ``(config) -> tuple of str``: the Mitsuba BSDF plugins the preset places under
        ``config`` whose lobes are delta (smooth ``dielectric``, ``conductor``, ``plastic``) or
        GGX α < :data:`SHARP_ALPHA`: those that make fireflies, for which ``render.estimator
        = "auto"`` takes the adaptive median (:mod:`spectral_cam.render.decisions`). Default:
        none (:func:`no_sharp_materials`); tests/presets/test_sharp_materials.py holds every
        preset's declaration to the BSDFs it builds.
    """

    sharp_materials: Callable[["SceneConfig"], tuple[str, ...]] = no_sharp_materials


#: Every ``scene.preset``: name → :class:`Preset` (builder ``(config, lens, mi) -> dict`` of
#: Mitsuba scene-dict entries, shapes and emitters); its options are the ``[scene]`` keys it reads.
PRESETS = Registry("scene preset", entry=Preset)


def reads_light(preset: str) -> bool:
    """Whether ``preset`` stands on the ground of ``outdoor.GroundView`` under the sky (it reads ``light``)."""
    return preset in PRESETS and "light" in PRESETS[preset].options


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
def spectrum_dict(values_per_wavelength: tuple[np.ndarray, np.ndarray]) -> dict:
    wavelengths, values = values_per_wavelength
    return {"type": "spectrum", "value": [(float(w), float(v)) for w, v in zip(wavelengths, values)]}


def reflectance_spectrum(sd) -> dict:
    """A reflectance on Mitsuba's whole range, end values held (ColorChecker data stop at
    380/730 nm)."""
    lo, hi = spectra.MITSUBA_RANGE_NM
    wavelengths = np.arange(lo, hi + SPECTRUM_STEP_NM / 2, SPECTRUM_STEP_NM)
    return spectrum_dict((wavelengths, np.clip(spectra.sample(sd, wavelengths), 0.0, 1.0)))


#: Sampling step of a leaf's spectra (nm): the red edge bends sharply, so 5 nm interpolated
#: linearly is off by up to 2.6·10⁻³ against PROSPECT-D's 1-nm output; 2 nm keeps it below 10⁻³.
LEAF_SPECTRUM_STEP_NM = 2.0


def leaf_bsdf(traits) -> dict:
    """A reflecting and transmitting leaf (PROSPECT-D R and T of ``traits``, a
    :class:`~spectral_cam.leaves.LeafTraits`) on Mitsuba's whole range."""
    from ..leaves import LEAF_PLUGIN, prospect_d

    lo, hi = spectra.MITSUBA_RANGE_NM
    wavelengths = np.arange(lo, hi + LEAF_SPECTRUM_STEP_NM / 2, LEAF_SPECTRUM_STEP_NM)
    r, t = prospect_d(traits, wavelengths)
    return {"type": LEAF_PLUGIN, "reflectance": spectrum_dict((wavelengths, r)),
            "transmittance": spectrum_dict((wavelengths, t))}


def bitmap_texture(mi, values: np.ndarray, to_uv=None) -> dict:
    """A float texture from a 2-D array (raw values, bilinear, mirrored beyond its edges so that
    it never shows a seam)."""
    texture = {"type": "bitmap", "bitmap": mi.Bitmap(np.ascontiguousarray(values, dtype=np.float32)[..., None]),
               "raw": True, "filter_type": "bilinear", "wrap_mode": "mirror"}
    if to_uv is not None:
        texture["to_uv"] = to_uv
    return texture


def mixed_bsdf(mi, endmembers, abundances: np.ndarray, *, to_uv=None, height: np.ndarray | None = None,
               bump_scale: float = 0.0) -> dict:
    """A Lambertian surface whose reflectance is Σ_k a_k(x)·S_k(λ) (linear spectral mixing),
    as nested ``blendbsdf``s: level k blends S_k with the normalised mixture of the later
    endmembers, weight Σ_{j>k} a_j / Σ_{j≥k} a_j, which is exact for any number of endmembers;
    with ``height``, a ``bumpmap`` of it for relief.

    References
    ----------
    .. [1] Keshava, N., & Mustard, J. F. (2002). Spectral unmixing. IEEE Signal Processing
       Magazine 19(1), 44–57; Mitsuba 3 plugins ``blendbsdf``, ``bitmap``, ``bumpmap``.
    """
    abundances = np.asarray(abundances, dtype=np.float64)
    bsdf = diffuse(endmembers[-1])
    rest = abundances[-1]
    for k in range(len(endmembers) - 2, -1, -1):
        total = abundances[k] + rest
        weight = np.where(total > 0, rest / np.maximum(total, 1e-30), 0.5)
        bsdf = {"type": "blendbsdf", "weight": bitmap_texture(mi, weight, to_uv),
                "bsdf_0": diffuse(endmembers[k]), "bsdf_1": bsdf}
        rest = total
    if height is not None and bump_scale > 0:
        bsdf = {"type": "bumpmap", "arbitrary": bitmap_texture(mi, height, to_uv), "scale": float(bump_scale),
                "bsdf": bsdf}
    return bsdf


def diffuse(reflectance) -> dict:
    if isinstance(reflectance, (int, float)):
        return {"type": "diffuse", "reflectance": {"type": "uniform", "value": float(reflectance)}}
    return {"type": "diffuse", "reflectance": reflectance_spectrum(reflectance)}


def facing_rectangle(mi, centre, half_width, half_height, bsdf, angle_deg=0.0) -> dict:
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


def field_half_size(lens: ThinLens, depth_m: float) -> tuple[float, float]:
    """Half width and height (m) of the field of view at a depth."""
    scale = depth_m / lens.image_distance_m
    return lens.sensor_width_m / 2 * scale, lens.sensor_height_m / 2 * scale


def light_irradiance(config: SceneConfig):
    return spectra.absolute_irradiance(config.illuminant.spd, config.illuminant.illuminance_lux)


def sun(config: SceneConfig) -> dict:
    """Directional light along +z with the configured spectral irradiance."""
    return {"type": "directional", "direction": [0.0, 0.0, 1.0], "irradiance": spectrum_dict(light_irradiance(config))}
