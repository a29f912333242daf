"""The depth-layered lens model (``lens.model = "layered"``): thin-lens depth of field
without its Monte-Carlo noise.

A small bright source far out of focus is seen by a pixel through only a fraction p of the
aperture (:func:`aperture_fraction`), so camera-side path tracing of the thin lens has a
relative noise of √((1 − p)/(p·spp)) per pixel. :func:`render_layered` renders through a
pinhole of the same geometry instead, takes the nearest depth per pixel from supersampled
depth samples (:func:`nearest_depth`), and applies the uniform-disc CoC PSF of each depth
layer to every spectral band (:func:`defocus_layers`), compositing back to front. Limit:
one depth per pixel, so a near object lacks partial occlusion at its blurred edge; the
``auto`` lens decision picks this model only where that cannot happen (docs/design.md,
"Model decisions").

References
----------
.. [1] Potmesil, M., & Chakravarty, I. (1981). A lens and aperture camera model for
   synthetic image generation. Proc. SIGGRAPH '81, 297–305.
.. [2] Kraus, M., & Strengert, M. (2007). Depth-of-field rendering by pyramidal image
   processing. Computer Graphics Forum 26(3), 645–654.
.. [3] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §5.2.3 (thin-lens ray generation).
"""

from __future__ import annotations

import math
import time

import numpy as np

from .. import spectra
from ..errors import ConfigError
from ..image import SpectralImage
from ..optics import ThinLens
from .depth import render_depth
from .trace import frame_optics, trace
from .variants import choose_variant

__all__ = ["render_layered", "defocus_layers", "disc_kernel", "nearest_depth", "aperture_fraction"]


def disc_kernel(diameter_px: float, *, supersample: int = 9) -> np.ndarray:
    """A uniform disc of the given diameter as a pixel kernel: each entry is the fraction
    of its pixel the disc covers (``supersample``² points per pixel), normalised to sum 1.

    Parameters
    ----------
    diameter_px
        Disc diameter, pixels; below 1 px the kernel is the identity (1×1).
    supersample
        Coverage samples per pixel along each axis.

    Returns
    -------
    numpy.ndarray
        (2k + 1, 2k + 1) float64 kernel, k = ⌈diameter/2 − ½⌉.

    References
    ----------
    .. [1] Ray (2002), Applied Photographic Optics, ch. 10 (geometric defocus: a uniform
       disc the size of the circle of confusion, for a circular aperture).
    """
    if not (math.isfinite(diameter_px) and diameter_px >= 0):
        raise ConfigError(f"disc diameter {diameter_px!r} px must be a finite number >= 0")
    radius = 0.5 * float(diameter_px)
    if diameter_px < 1.0:
        return np.ones((1, 1))
    half = int(math.ceil(radius - 0.5))
    offsets = (np.arange(supersample) + 0.5) / supersample - 0.5
    fine = (np.arange(-half, half + 1)[:, None] + offsets[None, :]).ravel()
    inside = (fine[:, None] ** 2 + fine[None, :] ** 2) <= radius * radius
    n = 2 * half + 1
    kernel = inside.reshape(n, supersample, n, supersample).mean(axis=(1, 3))
    return kernel / kernel.sum()


#: Largest distance (px) over which a lit pixel without a depth sample takes its nearest
#: neighbour's depth; lit pixels farther from any hit are treated as at infinity.
DEPTH_FILL_PX = 1.5


def _fill_depth(depth: np.ndarray, lit: np.ndarray) -> np.ndarray:
    from scipy import ndimage

    finite = np.isfinite(depth)
    missing = lit & ~finite
    if not missing.any() or not finite.any():
        return depth
    distance, (iy, ix) = ndimage.distance_transform_edt(~finite, return_indices=True)
    return np.where(missing & (distance <= DEPTH_FILL_PX), depth[iy, ix], depth)


def _convolve(image: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """``image`` (H, W) or (H, W, B) convolved with an odd square ``kernel`` over its first two
    axes, same size (zero outside), in float32 through real FFTs on every core: what
    ``scipy.signal.fftconvolve(mode="same")`` gives, 2–3× faster on a 31-band layer."""
    from scipy import fft

    half = kernel.shape[0] // 2
    height, width = image.shape[:2]
    shape = (fft.next_fast_len(height + 2 * half, real=True), fft.next_fast_len(width + 2 * half, real=True))
    spectrum = fft.rfftn(np.asarray(image, dtype=np.float32), shape, axes=(0, 1), workers=-1)
    taps = fft.rfftn(kernel.astype(np.float32), shape, axes=(0, 1), workers=-1)
    if image.ndim == 3:
        taps = taps[..., None]
    spectrum *= taps
    full = fft.irfftn(spectrum, shape, axes=(0, 1), workers=-1)
    return full[half:half + height, half:half + width]


def _layer(data: np.ndarray, mask: np.ndarray, hidden: np.ndarray, diameter: float, fill_diameter: float):
    """One depth layer, blurred: (alpha, premultiplied colour, box) over the box it reaches.

    Where nearer surfaces hide the layer in the pinhole image (``hidden``), its coverage and
    colour are filled in from its visible neighbours within ``fill_diameter`` (normalised
    convolution: the fraction of known pixels around that belong to the layer, and their
    mean colour), since the thin lens sees past a blurred near edge to what lies behind it;
    then the layer is blurred by its own CoC disc."""
    height, width = mask.shape
    kernel = disc_kernel(diameter)
    fill = disc_kernel(max(fill_diameter, diameter)) if hidden.any() else np.ones((1, 1))
    reach = kernel.shape[0] // 2 + fill.shape[0] // 2
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    box = (slice(max(rows[0] - reach, 0), min(rows[-1] + reach + 1, height)),
           slice(max(cols[0] - reach, 0), min(cols[-1] + reach + 1, width)))
    # beyond the frame the scene goes on as at its edge (replicated), not as empty space: a
    # layer that fills the frame keeps its full coverage up to the border
    pad = ((reach if box[0].start == 0 else 0, reach if box[0].stop == height else 0),
           (reach if box[1].start == 0 else 0, reach if box[1].stop == width else 0))
    alpha = np.pad(mask[box].astype(np.float32), pad, mode="edge")
    colour = np.pad(data[box], (*pad, (0, 0)), mode="edge") * alpha[..., None]
    gap = np.pad(hidden[box], pad, mode="edge")
    if fill.shape[0] > 1 and gap.any():
        known = _convolve(~gap, fill)
        share = _convolve(alpha, fill)
        spread = _convolve(colour, fill)
        inside = gap & (known > 1e-3)
        alpha[inside] = np.clip(share[inside] / known[inside], 0.0, 1.0)
        colour[inside] = np.maximum(spread[inside], 0.0) / known[inside][:, None]
    if kernel.shape[0] > 1:
        colour = _convolve(colour, kernel)
        alpha = _convolve(alpha, kernel)
    crop = (slice(pad[0][0], alpha.shape[0] - pad[0][1]), slice(pad[1][0], alpha.shape[1] - pad[1][1]))
    alpha, colour = alpha[crop], colour[crop]
    # FFT round-off leaves ~1e-16 negatives
    return np.clip(alpha, 0.0, 1.0), np.maximum(colour, 0.0), box


def defocus_layers(radiance, lens, *, depth_m: np.ndarray | None = None, coc_ratio: float = 1.05):
    """Thin-lens defocus of an all-in-focus (pinhole) spectral image, layer by layer.

    Pixels are grouped by side of the focus plane and circle-of-confusion diameter
    c(z) = A·f·|z − z_f|/(z·(z_f − f)) (bins a factor ``coc_ratio`` wide; c < 1 px is in
    focus). Each layer — its radiance and its coverage (alpha) — is convolved with a
    uniform disc of its mean CoC (:func:`disc_kernel`), and the layers are composited back
    to front (far side from the largest CoC down, then the in-focus layer, then the near
    side up to the largest CoC): ``out = L_layer + (1 − α_layer)·out``. Every band gets the
    same geometric PSF, so the whole spectral cube is defocused at once.

    Limitations: a pixel carries one depth (mixed pixels take the nearest surface), and
    what a near object hides in the pinhole image is missing behind its blurred edge
    (partial occlusion: a thin rim darker than the thin-lens render's).

    Parameters
    ----------
    radiance : SpectralImage
        (H, W, B) band radiance rendered through a pinhole of the lens's geometry.
    lens : ThinLens
        The lens whose defocus to apply (f, N, focus distance, pixel pitch).
    depth_m : numpy.ndarray, optional
        (H, W) camera-space z (m), inf where nothing was hit; default ``radiance.depth_m``.
        Lit pixels without a depth take their neighbour's within :data:`DEPTH_FILL_PX`,
        else infinity.
    coc_ratio : float
        Width of a CoC bin as a ratio (> 1); 1.05 keeps every disc within 2.5 % of its
        pixels' own CoC.

    Returns
    -------
    SpectralImage
        The defocused image (same bands), depth and ``meta["defocus_layers"]`` (number of
        layers, CoC range in px).

    Raises
    ------
    ConfigError
        Without a depth map of the image's size, or for ``coc_ratio`` <= 1.

    References
    ----------
    .. [1] Potmesil, M., & Chakravarty, I. (1981). Proc. SIGGRAPH '81, 297–305.
    .. [2] Kraus, M., & Strengert, M. (2007). Computer Graphics Forum 26(3), 645–654.
    """

    
    data = np.asarray(radiance.data, dtype=np.float32)
    depth = radiance.depth_m if depth_m is None else depth_m
    if depth is None or np.shape(depth) != data.shape[:2]:
        raise ConfigError(f"defocus_layers needs an (H, W) = {data.shape[:2]} depth map in metres; got "
                          f"{None if depth is None else np.shape(depth)} (render with with_depth=True or pass depth_m)")
    if not (math.isfinite(coc_ratio) and coc_ratio > 1.0):
        raise ConfigError(f"coc_ratio {coc_ratio!r} must be a number > 1 (e.g. 1.05)")
    lit = data.max(axis=-1) > 0
    depth = _fill_depth(np.asarray(depth, dtype=np.float64), lit)
    # every pixel belongs to a layer: what no ray hit is a black layer at infinity (its blur
    # must darken the edge of a bright object before it, as the thin lens does)
    depth = np.where(np.isnan(depth), np.inf, depth)
    coc = np.asarray(lens.coc_diameter_px(depth), dtype=np.float64)
    bins = np.zeros(depth.shape, dtype=np.int64)
    blurred = coc >= 1.0
    bins[blurred] = 1 + np.floor(np.log(coc[blurred]) / math.log(coc_ratio)).astype(np.int64)
    side = np.where(bins == 0, 0, np.where(depth > lens.focus_distance_m, 1, -1))
    keys = {(int(s), int(b)) for s, b in zip(side.ravel(), bins.ravel())}
    order = (sorted((k for k in keys if k[0] == 1), key=lambda k: -k[1]) + [k for k in keys if k[0] == 0]
             + sorted((k for k in keys if k[0] == -1), key=lambda k: k[1]))
    masks = [(side == s) & (bins == b) for s, b in order]
    diameters = [float(coc[mask].mean()) if s != 0 else 0.0 for (s, _), mask in zip(order, masks)]
    # the widest blur of each layer and all composited after it: how far a nearer layer's
    # soft edge uncovers what the pinhole image hides behind it
    reach_after = np.maximum.accumulate(np.asarray(diameters[::-1] or [0.0]))[::-1]
    out = np.zeros_like(data)
    coverage = np.zeros(depth.shape, dtype=np.float64)
    hidden = np.zeros(depth.shape, dtype=bool)
    for mask in masks[::-1]:
        hidden |= mask
    for index, mask in enumerate(masks):
        hidden &= ~mask  # the pixels of the layers still to come: nearer surfaces
        alpha, colour, box = _layer(data, mask, hidden, diameters[index], float(reach_after[index]))
        out[box] = (colour + (1.0 - alpha)[..., None] * out[box]).astype(np.float32)
        coverage[box] = alpha + (1.0 - alpha) * coverage[box]
    # the layers' coverages, each filled and blurred on its own, need not sum to one where
    # surfaces meet: normalise so every pixel keeps a whole aperture's worth of light
    np.divide(out, coverage[..., None].astype(np.float32), out=out, where=coverage[..., None] > 1e-6)
    meta = dict(getattr(radiance, "meta", {}) or {})
    meta["defocus_layers"] = {"layers": len(order), "coc_ratio": coc_ratio,
                              "coc_range_px": [min(diameters, default=0.0), max(diameters, default=0.0)]}
    return SpectralImage(out, np.asarray(radiance.wavelengths_nm), np.asarray(radiance.band_edges_nm),
                         depth.astype(np.float32), meta, getattr(radiance, "channels", None))


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
    then defocus by depth layers (:func:`defocus_layers`).

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
                  decisions=dict(plan.decisions), progress=progress)
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


