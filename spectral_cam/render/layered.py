"""The depth-layered lens model (``lens.model = "layered"``): thin-lens depth of field
without its Monte-Carlo noise.

A small bright source far out of focus is seen by a pixel through only a fraction p of the
aperture (:func:`aperture_fraction`), so camera-side path tracing of the thin lens has a
relative noise of √((1 − p)/(p·spp)) per pixel. :func:`render_layered` renders through a
pinhole of the same geometry instead, takes the nearest depth per pixel from supersampled
depth samples (:func:`nearest_depth`), and applies the uniform-disc CoC PSF of each depth
layer to every spectral band (:func:`spectral_cam.optics.layered_defocus.defocus_layers`), compositing back to front. Limit:
one depth per pixel, so a near object lacks partial occlusion at its blurred edge; the
``auto`` lens decision picks this model only where that cannot happen (docs/design.md,
"Model decisions").

References
----------
.. [1] The layered model's optics and its sources (Potmesil & Chakravarty 1981; Kraus &
   Strengert 2007): :mod:`spectral_cam.optics.layered_defocus`.
.. [2] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §5.2.3 (thin-lens ray generation).
"""

from __future__ import annotations

import time

import numpy as np

from .. import spectra
from ..errors import ConfigError
from ..image import SpectralImage
from ..optics import ThinLens
from ..optics.layered_defocus import defocus_layers
from .depth import render_depth
from .lens_models import LENS_MODELS, pinhole_camera
from .trace import frame_optics, trace
from .variants import choose_variant

__all__ = ["render_layered", "nearest_depth", "aperture_fraction"]


def nearest_depth(config, *, lens: ThinLens | None = None, supersample: int = 4,
                  variant: str | None = None) -> np.ndarray:
    """Camera-space z (m) of the nearest surface in each pixel, from ``supersample``²
    depth samples per pixel (a pinhole depth render at ``supersample``× the resolution,
    min-pooled), so small objects are not missed as by a 1-sample depth map.

    Parameters
    ----------
    config : SceneConfig
        The scene.
    lens : ThinLens, optional
        The lens and sensor area imaged (default: from ``config``); the probe samples the
        same area ``supersample``× finer, with the scene laid out for the same frame.
    supersample : int
        Depth samples per pixel along each axis, 1–8.
    variant : str, optional
        The Mitsuba variant already chosen (default: from ``render.variant``).

    Returns
    -------
    numpy.ndarray
        (H, W) float32 depth in metres, inf where no sample hit anything.

    References
    ----------
    .. [1] :func:`spectral_cam.render.render_depth` (z from the position AOV).
    """
    import mitsuba as mi

    
    if not (isinstance(supersample, int) and 1 <= supersample <= 8):
        raise ConfigError(f"depth supersample {supersample!r} must be a whole number in 1..8")
    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    width, height = lens.width_px, lens.height_px
    factor = max(1, min(supersample, 20000 // max(width, height)))
    mi.set_variant(choose_variant(config.render.variant) if variant is None else variant)
    depth = render_depth(mi, config, lens.supersampled(factor))
    return depth.reshape(height, factor, width, factor).min(axis=(1, 3)).astype(np.float32)


def render_layered(config, *, lens: ThinLens | None = None, depth_supersample: int = 4, coc_ratio: float = 1.05,
                   margin_px: int | str = "auto", progress=None, plan=None):
    """Thin-lens depth of field without its Monte-Carlo noise: render through a pinhole,
    then defocus by depth layers (:func:`spectral_cam.optics.layered_defocus.defocus_layers`).

    A small bright source far out of focus is seen by a pixel through only a fraction of
    the aperture, so camera-side path tracing needs ~1/p samples per pixel per unit of
    relative variance; through a pinhole the same source covers whole pixels and converges
    as fast as anything else. The spectral radiance is rendered through a pinhole of the
    configured geometry (the capture area enlarged by the plan's layered margin on each side
    so light from just outside the view blurs in), the nearest depth per pixel from
    ``depth_supersample``² samples, the per-depth uniform disc PSF of the CoC diameter applied
    to all bands, the capture area cropped; diffraction as the plan decided.

    Parameters
    ----------
    config : SceneConfig
        The scene with its thin lens (``lens.model`` is ignored: this is the thin lens's
        defocus).
    lens : ThinLens, optional
        The frame's lens (default: from ``config``), when no ``plan`` is given.
    depth_supersample : int
        Depth samples per pixel along each axis (1–8).
    coc_ratio : float
        CoC bin width as a ratio (> 1).
    margin_px : int or "auto"
        Extra pixels rendered on each side; ``"auto"``: the plan's (half the largest CoC in
        view + 1).
    progress : callable, optional
        Called after each pass of the pinhole render with (spp done, spp total, seconds).
    plan : CapturePlan, optional
        The capture plan (:func:`spectral_cam.render.plan.make_plan`) of a layered capture; default:
        planned here for ``config`` with ``lens.model = "layered"``, without a crop margin.

    Returns
    -------
    SpectralImage
        Band radiance (W·m⁻²·sr⁻¹ per band) with depth and ``meta`` (timings, the layer
        decision under ``model_decisions["defocus"]``).

    References
    ----------
    .. [1] Potmesil & Chakravarty (1981), Proc. SIGGRAPH '81, 297–305.
    .. [2] Kraus & Strengert (2007), Computer Graphics Forum 26(3), 645–654.
    """
    from .plan import clamp_margin, make_plan

    if not (margin_px == "auto" or (isinstance(margin_px, int) and margin_px >= 0)):
        raise ConfigError(f"margin_px {margin_px!r} must be 'auto' or a whole number of pixels >= 0")
    if plan is None:
        plan = make_plan(config.replace(**{"lens.model": "layered"}), with_margin=False, with_depth=False, lens=lens)
    timings: dict[str, float] = {}
    started = time.perf_counter()
    lens = plan.capture_lens
    width, height = lens.width_px, lens.height_px
    margin = plan.layered_margin_px if margin_px == "auto" else clamp_margin(lens, margin_px)
    t0 = time.perf_counter()
    wide_lens = lens.widened(margin)  # the scene stays laid out for the frame
    sharp = trace(plan.config, wide_lens, "pinhole", variant=plan.variant, camera_film=plan.camera_film,
                  diffraction=False, groups=plan.estimator_passes, subframes=plan.subframes,
                  decisions=dict(plan.decisions), progress=progress, aerial=plan.aerial)
    timings["pinhole_render"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    depth = nearest_depth(plan.config, lens=wide_lens, supersample=depth_supersample, variant=plan.variant)
    timings["depth"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    blurred = defocus_layers(sharp, wide_lens, depth_m=depth, coc_ratio=coc_ratio)
    timings["defocus_layers"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    data = blurred.data
    if plan.diffraction:
        bands = spectra.parse_bands(plan.config.render.spectral_bands)
        data = lens.apply_diffraction(data, bands.centres_nm, out=data if data.dtype == np.float32 else None)
    timings["diffraction"] = time.perf_counter() - t0
    crop = (slice(margin, margin + height), slice(margin, margin + width))
    meta = dict(sharp.meta)
    decisions = dict(meta.get("model_decisions", {}))
    layers = blurred.meta["defocus_layers"]
    decisions["defocus"] = {
        "choice": "depth_layered_disc_psf",
        "reason": (f"pinhole render + uniform-disc CoC PSF per depth layer ({layers['layers']} layers, "
                   f"CoC {layers['coc_range_px'][0]:.3g}–{layers['coc_range_px'][1]:.3g} px), "
                   "instead of thin-lens path tracing"),
        "depth_supersample": depth_supersample, "margin_px": margin, **layers,
    }
    meta.update({"lens_model": "layered", "model_decisions": decisions,
                 "optics": frame_optics(lens),
                 "timings_s": {**meta.get("timings_s", {}), **timings, "total": time.perf_counter() - started}})
    return SpectralImage(np.ascontiguousarray(data[crop], dtype=np.float32), blurred.wavelengths_nm,
                         blurred.band_edges_nm, blurred.depth_m[crop], meta, blurred.channels, lens)


def aperture_fraction(config, lens: ThinLens | None = None) -> float:
    """Fraction p of the aperture through which a pixel inside the blur disc sees the
    (single, on-axis) source of a ``point_sources`` scene: ``(r·z_f/(|z − z_f|·R))²``.

    A lens point u sees the source when the ray through u and the pixel's conjugate point
    on the focus plane meets the source disc at depth z; those u form a disc of radius
    r·z_f/|z − z_f| on the aperture of radius R.

    References
    ----------
    .. [1] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §5.2.3 (thin-lens ray generation).
    """
    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    z, zf = config.scene.depths_m[0], lens.focus_distance_m
    return float(min(1.0, (config.scene.source_radius_m * zf / (abs(z - zf) * lens.aperture_radius_m)) ** 2))




def _layered_render(config, plan, progress):
    return render_layered(config, plan=plan, progress=progress)


def _layered_margin(lens: ThinLens, depth: np.ndarray) -> int:
    from .plan import layered_margin

    return layered_margin(lens, depth)


def _layered_memory(channels: int) -> float:
    """Bytes a pixel holds beyond the radiance cube: the defocus's extra cubes and its depths."""
    from .memory import LAYERED_DEPTH_BYTES_PER_PIXEL, LAYERED_EXTRA_CUBES

    return LAYERED_EXTRA_CUBES * 4.0 * channels + LAYERED_DEPTH_BYTES_PER_PIXEL


# registered here, beside its render: the registry (read by plan.py) cannot import this module,
# which plans through plan.py
LENS_MODELS.add("layered", pinhole_camera, render=_layered_render, memory_bytes_per_pixel=_layered_memory,
                margin=_layered_margin, needs_depth=True,
                description="a pinhole render defocused per depth layer (thin-lens depth of field without its "
                            "Monte-Carlo noise)")
