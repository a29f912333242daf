"""Which light lights each pixel: the per-pixel illuminant of a scene with several lights.

Mixed-light white balance needs, per pixel, the camera RGB of the light arriving there. The
Large Scale Multi-Illuminant dataset (LSMI, Kim et al. 2021) defines it from one photograph per
light: the share of light ``i`` at pixel ``p`` is its green channel over all the lights'

    α_i(p) = G_i(p) / Σ_j G_j(p),

and the pixel's illuminant is ``ℓ(p) = Σ_i α_i(p)·ℓ_i``, where ``ℓ_i`` is light ``i``'s
camera RGB with green 1. The surface's reflectance cancels in the ratio (the same surface is
seen under every light), so on a diffuse surface ℓ(p) is the camera RGB of the irradiance
there: ``image / ℓ`` is the image white-balanced pixel by pixel.

:func:`render_light_mixture` makes LSMI's photographs: the scene through the frame's pinhole,
once per part of its light (each emitter, and a ``sunsky``'s sun and sky apart: sunlit and
shadowed ground are the outdoor case of mixed light) with the others dimmed
(:func:`spectral_cam.render.lights.lit_alone`), on a film of the camera's own curves
(:func:`spectral_cam.render.films.camera_film`). ``ℓ_i`` is the camera's response to the
spectral irradiance the part sends to the point the camera looks at
(:func:`spectral_cam.render.lights.light_part_spectrum`): one colour per light, as LSMI's.

References
----------
.. [1] Kim, D., Kim, J., Nam, S., Lee, D., Lee, Y., Kang, N., Lee, H.-E., Yoo, B., Han, J.-J., &
   Kim, S. J. (2021). Large Scale Multi-Illuminant (LSMI) Dataset for Developing White Balance
   Algorithm Under Mixed Illumination. ICCV 2021, 2410–2419 (§3: mixture map from the green
   channel of single-illuminant images).
.. [2] Hui, Z., Sunkavalli, K., Hadap, S., & Sankaranarayanan, A. C. (2019). Illuminant spectra-based
   source separation using flash photography. CVPR 2019 (per-pixel illuminant of mixed light).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..optics import ThinLens
from ..scene import SceneConfig
from .plugins import register_once
from .variants import choose_variant

__all__ = ["LightMixture", "render_light_mixture", "MIXTURE_SPP"]

#: Rays per pixel of each light's render, per camera channel.
MIXTURE_SPP = 64
#: A pixel whose lights all send less than this fraction of the frame's 99th percentile is
#: unlit: its shares and illuminant are 0.
UNLIT_FRACTION = 1e-4


@dataclass(frozen=True)
class LightMixture:
    """Each pixel's light and each light's share of it.

    Attributes
    ----------
    names : list of str
        Each light's name (an emitter's; ``<id>.sun``/``<id>.sky`` for a ``sunsky``;
        ``"illuminant"`` for an emissive chart lit by ``[illuminant]``).
    spectra : numpy.ndarray
        (N, L) relative spectral irradiance each light sends to the point the camera looks at
        (max 1), on :data:`spectral_cam.render.lights.LIGHT_GRID_NM`.
    camera_rgb_g1 : numpy.ndarray
        (N, 3) each light's own camera RGB from that spectrum, green 1 (LSMI's ℓ_i).
    illuminant_rgb : numpy.ndarray
        (H, W, 3) the camera RGB of the light arriving at each pixel's surface, green 1 (0 where
        unlit): a white diffuser's response there, interreflections included.
    shares : numpy.ndarray
        (H, W, N) each light's share of the green signal at each pixel (sum 1; 0 where unlit).
    spp : int
        Rays per pixel of each light's render, per camera channel (0: nothing rendered).
    """

    names: list
    spectra: np.ndarray
    camera_rgb_g1: np.ndarray
    illuminant_rgb: np.ndarray
    shares: np.ndarray
    spp: int

    @property
    def unlit(self) -> np.ndarray:
        """(H, W) True where no light reaches the pixel's surface."""
        return ~np.any(self.shares > 0, axis=-1)

    def chromaticities(self) -> list[dict]:
        """Each light's CIE 1931 xy, CCT and Duv (Robertson 1968), from its spectrum."""
        from ..cie import cct_robertson1968, cmfs_1931, xy_to_uv_1960, xyz_to_xy
        from ..spectra import sample
        from .lights import LIGHT_GRID_NM

        records = []
        for spectrum in self.spectra:
            xy = xyz_to_xy(spectrum @ sample(cmfs_1931(), LIGHT_GRID_NM, outside=0.0))
            cct, duv = cct_robertson1968(xy_to_uv_1960(xy))
            records.append({"xy": [float(v) for v in xy], "cct_k": float(cct), "duv": float(duv)})
        return records


def _camera_rgb(config: SceneConfig, spectra: np.ndarray) -> np.ndarray:
    """(N, 3) camera RGB, green 1, of relative spectra on the light grid (the film's curves)."""
    from ..sensor import film_curves
    from .lights import LIGHT_GRID_NM

    rgb = np.asarray(spectra, dtype=np.float64) @ film_curves(config, LIGHT_GRID_NM)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(rgb[:, 1:2] > 0, rgb / rgb[:, 1:2], 0.0)


WHITE_BOUNCE_INTEGRATOR = "spectral_cam_white_bounce"


def _white_bounce_class(mi):
    """A Mitsuba integrator returning, for each camera ray, the radiance a perfect white
    diffuser would reflect at its first hit: E(λ)/π, the irradiance there over π. Direct light
    by emitter sampling (unbiased for area, point, directional and environment emitters alone),
    indirect light by one cosine-weighted ray continued by Mitsuba's ``path`` with the emitters
    it sees at once hidden (emitter sampling counted them). A ray that meets an emitter, or
    the environment, returns that light's own radiance. Registered once per variant
    (:func:`.plugins.register_once`)."""
    import drjit as dr

    # Mitsuba requires this class inside a function: a Python plugin subclasses the active variant's
    # mi.SamplingIntegrator, which exists only once mi.set_variant has run and is another class in each variant
    # (so one class is made and registered per variant: mi.register_*)
    class WhiteBounce(mi.SamplingIntegrator):
        def __init__(self, props):
            super().__init__(props)
            depth = props.get("max_depth", 8)
            self.path = mi.load_dict({"type": "path", "max_depth": max(int(depth) - 1, 1), "hide_emitters": True})

        def sample(self, scene, sampler, ray, medium=None, active=True):
            si = scene.ray_intersect(ray, active)
            hit = si.is_valid()
            emitter = si.emitter(scene, active)  # the environment where the ray escapes
            is_light = active & (emitter != None)  # noqa: E711 - drjit compares pointer arrays with !=
            seen = dr.select(is_light, emitter.eval(si, is_light), 0.0)
            surface = active & hit & ~is_light
            normal = dr.select(dr.dot(si.sh_frame.n, ray.d) > 0, -si.sh_frame.n, si.sh_frame.n)
            ds, weight = scene.sample_emitter_direction(si, sampler.next_2d(surface), True, surface)
            direct = weight * dr.maximum(dr.dot(normal, ds.d), 0.0) / dr.pi
            direction = mi.Frame3f(normal).to_world(mi.warp.square_to_cosine_hemisphere(sampler.next_2d(surface)))
            onward = si.spawn_ray(direction)
            indirect, _, _ = self.path.sample(scene, sampler, onward, medium, surface)
            value = seen + dr.select(surface, direct + indirect, 0.0)
            return value, active, []

    return WhiteBounce


#: Presets whose surfaces are emitters standing in for lit surfaces (each leaf sends ρ·E/π):
#: their light is ``[illuminant]`` everywhere.
EMISSIVE_CHARTS = ("dead_leaves",)


def _one_light_everywhere(config: SceneConfig, lens: ThinLens) -> LightMixture:
    """An emissive chart lit by ``[illuminant]``: one light, the same everywhere."""
    from .. import spectra as spectra_module
    from .lights import LIGHT_GRID_NM

    spectrum = spectra_module.sample(spectra_module.illuminant(config.illuminant.spd), LIGHT_GRID_NM, outside=0.0)
    spectrum = np.asarray(spectrum, dtype=np.float64).reshape(1, -1)
    spectrum /= spectrum.max()
    rgb = _camera_rgb(config, spectrum)
    shape = (lens.height_px, lens.width_px)
    return LightMixture(["illuminant"], spectrum, rgb, np.broadcast_to(rgb[0], shape + (3,)).copy(),
                        np.ones(shape + (1,)), 0)


def render_light_mixture(config: SceneConfig, *, lens: ThinLens | None = None, spp: int = MIXTURE_SPP
                         ) -> LightMixture:
    """The light arriving at each pixel's surface, and each light's share of it, through the
    frame's pinhole.

    Each light (:func:`~spectral_cam.render.lights.light_parts`: every emitter, a ``sunsky``'s
    sun and sky apart) is rendered alone with a white first bounce (the radiance a white
    diffuser would send the camera, E/π) on a film of the camera's curves. The pixel's
    illuminant is the sum over lights, green 1; a light's share is its green over the sum
    (LSMI's mixture map, free of the surface's colour by construction).

    Parameters
    ----------
    config
        The scene: a user's XML scene, or a preset (under the sun and sky, a lamp, or
        ``[illuminant]``); an emissive chart (:data:`EMISSIVE_CHARTS`) has ``[illuminant]``
        everywhere and renders nothing.
    lens
        The frame's lens (default: built from ``config``).
    spp
        Rays per pixel of each light's render, per camera channel (three renders per light).

    Returns
    -------
    LightMixture

    Raises
    ------
    ConfigError
        When an emitter's strength cannot be set (an XML emitter without an id, among
        several): the message says to give each one an id.

    References
    ----------
    .. [1] Kim, D., et al. (2021). LSMI, ICCV 2021, §3.
    .. [2] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §13.4 (estimating direct lighting by
       sampling lights), §13.2 (cosine-weighted hemisphere sampling).
    """
    import mitsuba as mi

    from ..errors import ConfigError
    from .depth import _pinhole_probe
    from .films import camera_film
    from .lights import light_part_spectrum, light_parts, lit_alone

    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    if not config.scene.mitsuba_xml and config.scene.preset in EMISSIVE_CHARTS:
        return _one_light_everywhere(config, lens)
    mi.set_variant(choose_variant(config.render.variant))
    register_once(mi, "integrator", WHITE_BOUNCE_INTEGRATOR, _white_bounce_class)
    width, height = lens.width_px, lens.height_px
    integrator = {"type": WHITE_BOUNCE_INTEGRATOR, "max_depth": config.render.max_depth}
    rgb, spectra, names = None, [], []
    for channel, name in enumerate(("camera_r", "camera_g", "camera_b")):
        # one film per channel: Mitsuba samples wavelengths by the film's curves, so each channel
        # alone has a fraction of the colour noise of three together (measured: 0.5 % against
        # 3.5 % per pixel in B/G at 128 rays per pixel)
        film = camera_film(config, width, height, channels=(name,))
        scene, sensor, tiles = _pinhole_probe(mi, config, lens, film, integrator, spp=spp, stream=1 << 23)
        parts = light_parts(mi, scene, split_sky=True)
        if parts is None:
            raise ConfigError("the per-pixel illuminant renders each emitter alone, which needs every emitter's "
                              "strength: give each emitter of the XML scene an id (its shape's id for an area light)")
        params = mi.traverse(scene)
        if rgb is None:
            rgb, names = np.zeros((len(parts), height, width, 3)), [part.name for part in parts]
        for k in range(len(parts)):
            with lit_alone(params, parts, k):
                if channel == 0:
                    spectra.append(light_part_spectrum(mi, scene, sensor, parts[k]))
                for first, end, image in tiles():
                    rgb[k, first:end, :, channel] = image[..., 0]
        del scene, sensor, tiles, params
    green = rgb[..., 1]
    total = green.sum(axis=0)
    lit = total > UNLIT_FRACTION * max(float(np.percentile(total, 99)), 0.0)
    safe = np.where(lit, total, 1.0)
    shares = np.where(lit, np.clip(green, 0.0, None) / safe, 0.0)
    illuminant = np.where(lit[..., None], rgb.sum(axis=0) / safe[..., None], 0.0)
    spectra = np.array(spectra)
    return LightMixture(names, spectra, _camera_rgb(config, spectra), illuminant, np.moveaxis(shares, 0, -1), spp)
