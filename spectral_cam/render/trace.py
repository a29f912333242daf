"""Path tracing of one frame through a thin lens or a pinhole: film, passes, seeds, spp.

:func:`trace` renders in passes of at most :data:`LANES_PER_PASS` lanes, each with its own
seed derived from ``render.seed``; ``spp = "auto"`` stops when the Monte-Carlo noise is a
small fraction of the sensor's (:class:`~spectral_cam.render.decisions.NoiseMonitor`).

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3 renderer (``mi.render``, ``specfilm``).
.. [2] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §2.1.4 (Monte Carlo estimators).
"""

from __future__ import annotations

import itertools
import time
from typing import Callable

import numpy as np

from .. import spectra
from ..errors import ConfigError, RenderError
from ..image import SpectralImage
from ..optics import ThinLens
from ..scene import SceneConfig
from .decisions import AUTO_SPP_MIN_PASSES, NoiseMonitor, auto_spp_per_pass
from .robust import adaptive_median_of_means, spread_removed_light
from .films import render_film
from .motion import ObjectMotion, exposure_span_s, is_rolling, rolling_row_weights, subframe_transform
from .scene_dict import (TILE_PIXELS, build_scene, camera_dict, configured_camera, exact_pass_spp, frame_tiles,
                         moved_sensor, pass_seed, release_render_memory, tile_sensors)

#: Most wavefront lanes (pixels × spp) of one Mitsuba call in the vectorised variants. Mitsuba's
#: path tracer runs as a symbolic loop whose memory does not grow with the lanes (measured: see
#: docs/design.md), so this only keeps a call well inside drjit's 32-bit lane indices; a frame
#: whose samples fit is one call, as a bare ``mi.render`` would be.
LANES_PER_PASS = 1 << 28
#: Lanes per pass for the scalar variant (its cost is per sample; smaller passes give progress).
SCALAR_LANES_PER_PASS = 1 << 20


def _fixed_passes(sampler: str, spp: int, lane_cap: int):
    """Pass sizes of a fixed-spp frame: as few calls as the lane cap allows, each a size the
    sampler keeps exactly."""
    done = 0
    while done < spp:
        size = exact_pass_spp(sampler, min(spp - done, lane_cap))
        done += size
        yield size


def _auto_passes(sampler: str, max_spp: int, lane_cap: int):
    """Pass sizes of ``spp = "auto"``: rounds of :data:`AUTO_SPP_MIN_PASSES` equal passes whose
    size grows 4× a round (a stratified sampler gains within a pass: one pass of 256 is far less
    noisy than 32 of 8), the last rounds shrunk to fit ``max_spp``; the monitor judges each round."""
    done, size = 0, auto_spp_per_pass(sampler)
    while (max_spp - done) // AUTO_SPP_MIN_PASSES >= 1:
        size = exact_pass_spp(sampler, min(size, lane_cap, (max_spp - done) // AUTO_SPP_MIN_PASSES))
        for _ in range(AUTO_SPP_MIN_PASSES):
            done += size
            yield size
        size *= 4


class _PassMean:
    """The spp-weighted mean of the passes, kept in one float32 frame updated in place: a
    single pass is Mitsuba's own image (no copy), later passes are added with one
    multithreaded ``cv2.scaleAdd`` each (no float64 or full-cube temporaries). float32 is
    enough: a handful of passes adds rounding far below the Monte-Carlo noise."""

    def __init__(self):
        self.total: np.ndarray | None = None
        self.spp = 0
        self.summed = False  # total holds Σ spp·image (True) or the first image itself (False)

    def add(self, image: np.ndarray, spp: int) -> None:
        import cv2

        if self.total is None:
            self.total = image if image.flags.writeable else image.copy()
            self.spp = spp
            return
        if not self.summed:
            self.total *= np.float32(self.spp)
            self.summed = True
        rows = self.total.shape[0]
        flat = self.total.reshape(rows, -1)
        cv2.scaleAdd(np.ascontiguousarray(image).reshape(rows, -1), float(spp), flat, dst=flat)
        self.spp += spp

    def peek(self) -> np.ndarray:
        """The mean so far, as a new array (the running sum is left as it is)."""
        return self.total / np.float32(self.spp) if self.summed else self.total

    def mean(self) -> np.ndarray:
        """The mean, computed in place (the accumulator is done)."""
        if self.summed:
            self.total /= np.float32(self.spp)
            self.summed = False
        return self.total


class _RadianceRange:
    """The lowest and highest radiance over a frame's tiles. Mitsuba's film can return values
    like −1e-19 where a pixel is black (floating-point cancellation): cleared; anything clearly
    negative against the frame's brightest value would be a bug, not rounding (judged on the
    whole frame: a tile can be all black)."""

    def __init__(self):
        self.lowest, self.highest = np.inf, -np.inf

    def clear_rounding(self, data: np.ndarray) -> np.ndarray:
        self.lowest = min(self.lowest, float(data.min()))
        self.highest = max(self.highest, float(data.max()))
        return np.maximum(data, 0.0, out=data)

    def check(self) -> None:
        if self.lowest < -1e-6 * max(self.highest, 1e-30):
            raise RenderError(f"Mitsuba returned negative radiance ({self.lowest:g}, max {self.highest:g})")


def _report(progress, done: int, total: int, seconds: float, tile: int, tiles: int) -> None:
    """Progress of a pass: ``(spp done, spp total, seconds)``, and for a tiled frame also
    ``tile=(tiles finished, tiles)`` counting the current one when its last pass is done."""
    if tiles == 1:
        progress(done, total, seconds)
    else:
        progress(done, total, seconds, tile=(tile + (done >= total), tiles))


def frame_optics(lens: ThinLens) -> dict:
    """``meta.optics``: the frame's lens (its field of view, sensor size), and the rendered margin
    around it separately (issue 25 #5: a widened film's field of view was recorded 16.7 % too wide)."""
    frame = lens.layout_lens
    optics = frame.describe()
    if frame is not lens:
        optics["rendered_margin_px"] = int(round((lens.width_px - frame.width_px) / 2))
        optics["rendered_size_px"] = [int(lens.width_px), int(lens.height_px)]
    return optics


def check_tiling(config: SceneConfig, lens: ThinLens) -> None:
    """Refuse, before any rendering, what a frame rendered in tiles cannot do:
    ``render.spp = "auto"`` (it judges the whole frame between passes).

    Raises
    ------
    ConfigError
        With what to set instead.
    """
    width, height = lens.width_px, lens.height_px
    if config.render.spp == "auto" and len(frame_tiles(width, height)) > 1:
        raise ConfigError(f"render.spp = \"auto\" judges the whole frame between passes, and {width} × {height} px "
                          f"renders in tiles (more than {TILE_PIXELS} px): set render.spp to a number (auto on a "
                          f"frame of the same scene up to {TILE_PIXELS} px shows how many samples it needs)")


def trace(config: SceneConfig, lens: ThinLens, lens_model: str, *, variant: str, camera_film: bool,
          diffraction: bool, groups: int = 1, subframes: int = 1,
          depth: np.ndarray | None = None, depth_s: float = 0.0, decisions: dict | None = None,
          progress: Callable[[int, int, float], None] | None = None, aerial: bool = False) -> SpectralImage:
    """Render the radiance of ``config`` through ``lens`` as ``lens_model`` with Mitsuba's
    current variant (``variant``, already set), as a capture plan decided
    (:func:`spectral_cam.render.plan.make_plan`: nothing is decided here but ``spp = "auto"``'s stop).

    Parameters
    ----------
    config : SceneConfig
        The scene.
    lens : ThinLens
        The job's lens.
    lens_model : str
        Geometry of the camera rays: an entry of
        :data:`~spectral_cam.render.lens_models.LENS_MODELS` that path-traces (its ``camera``).
    variant : str
        The Mitsuba variant in use (recorded).
    camera_film : bool
        Integrate the camera's curves (6 channels) instead of the spectral bands.
    diffraction : bool
        Apply the per-band Airy PSF after tracing.
    groups : int
        K groups of passes for the adaptive median of means (1: the mean).
    subframes : int
        Time-stratified motion sub-frames (1: none).
    depth, depth_s
        A depth map already rendered (m) and its time (s), carried into the result.
    decisions : dict, optional
        The plan's model decisions, recorded; ``spp = "auto"``'s outcome and the adaptive
        median's share are added.
    progress : callable, optional
        Called after each pass with (spp done, spp total, seconds so far); a frame of more
        than :data:`~spectral_cam.render.scene_dict.TILE_PIXELS` pixels renders in tiles and
        adds the keyword ``tile=(tiles finished, tiles)``.
    aerial : bool
        Veil far ground with the air (:mod:`spectral_cam.render.aerial`).

    Returns
    -------
    SpectralImage
        Band integrals of radiance, W·m⁻²·sr⁻¹, with ``.lens`` set to ``lens``.

    References
    ----------
    .. [1] Jakob, W., et al. (2022). Mitsuba 3 renderer (``mi.render``).
    """
    import mitsuba as mi

    width, height = lens.width_px, lens.height_px  # the frame, or the frame and its margin
    decisions = dict(decisions or {})
    film = _Film(config, camera_film)
    passes = _PassSchedule(config, variant, width, frame_tiles(width, height))
    monitor = NoiseMonitor(config, film.wavelengths, film.edges, film.channels, lens) if passes.auto else None

    started = time.perf_counter()
    camera = configured_camera(mi, config, lens, lens_model, render_film(config, film.use_camera, width, height),
                               passes.spp_per_pass)
    integrator = {"type": "path", "max_depth": config.render.max_depth}
    if aerial:
        from .aerial import aerial_integrator, register

        register(mi)
        integrator = aerial_integrator(config, integrator)
    scene, sensor, integrator = build_scene(mi, config, lens, camera, integrator)
    load_s = time.perf_counter() - started
    # the pose of the render (camera.json): the exposure's middle (sub-frames move about it)
    camera_to_world = np.asarray(sensor.world_transform().matrix, dtype=np.float64).reshape(4, 4, -1)[..., 0]
    mover = None
    if config.motion.moving and config.motion.object:
        mover = ObjectMotion(mi, scene, sensor, config)
        decisions["motion"] = {**decisions.get("motion", {}), "object": {"name": config.motion.object,
                                                                         "shapes": mover.keys}}
    tiler = _TileRenderer(mi, config, scene, integrator, camera, passes, film.count, groups=groups,
                          subframes=subframes, mover=mover, monitor=monitor, progress=progress, started=started)
    data = tiler.render_frame(sensor, width, height)
    if tiler.robust_shares:
        decisions["estimator"] = {**decisions.get("estimator", {}), "median_share": float(np.mean(tiler.robust_shares))}
    if monitor is not None:
        decisions["spp"] = monitor.record(tiler.done, config.render.max_spp)
        if progress is not None and tiler.done < passes.target_spp:
            progress(tiler.done, tiler.done, time.perf_counter() - started)
    radiance_s = time.perf_counter() - started - load_s

    t0 = time.perf_counter()
    if diffraction:
        data = lens.apply_diffraction(data, film.bands.centres_nm, out=data if data.dtype == np.float32 else None)
    diffraction_s = time.perf_counter() - t0

    meta = {
        "variant": variant,
        "lens_model": lens_model,
        "spp": tiler.done,
        "spp_per_pass": passes.spp_per_pass if groups == 1 else config.render.spp // groups,
        "sampler": passes.sampler,
        "passes": tiler.index,
        "pass_seeds": tiler.seeds,
        "tiles": [list(rows) for rows in passes.tiles],
        "bands": "camera" if film.use_camera else config.render.spectral_bands,
        "bands_nm": list(film.wavelengths),
        "channels": list(film.channels) if film.channels else None,
        "optics": frame_optics(lens),
        "camera_to_world": camera_to_world.tolist(),
        "model_decisions": decisions,
        "timings_s": {"scene_load": load_s, "radiance": radiance_s, "depth": depth_s,
                      "diffraction": diffraction_s},
    }
    return SpectralImage(data, film.wavelengths, film.edges, depth, meta, film.channels, lens)


class _Film:
    """What the film integrates: the spectral bands (``render.bands``) or the camera's own
    channels (6: r, g, b and X, Y, Z, photon-weighted)."""

    def __init__(self, config: SceneConfig, camera_film: bool):
        self.use_camera = camera_film
        self.bands = spectra.parse_bands(config.render.spectral_bands)
        if camera_film:
            from ..sensor import CAMERA_CHANNELS

            self.channels = CAMERA_CHANNELS
            self.wavelengths, self.edges = np.array([]), np.asarray(spectra.MITSUBA_RANGE_NM)
        else:
            self.channels = None
            self.wavelengths, self.edges = np.asarray(self.bands.centres_nm), np.asarray(self.bands.edges_nm)
        self.count = len(self.channels) if self.channels else len(self.bands)


class _PassSchedule:
    """The frame's tiles and its passes' sizes: as few Mitsuba calls as the lane cap allows, or
    ``spp = "auto"``'s growing rounds."""

    def __init__(self, config: SceneConfig, variant: str, width: int, tiles: list):
        self.auto = config.render.spp == "auto"
        self.target_spp = config.render.max_spp if self.auto else config.render.spp
        self.tiles = tiles
        self.sampler = config.render.sampler
        lanes = SCALAR_LANES_PER_PASS if variant.startswith("scalar") else LANES_PER_PASS
        self.lane_cap = max(lanes // (width * max(end - first for first, end in tiles)), 1)
        self.spp_per_pass = exact_pass_spp(self.sampler, min(auto_spp_per_pass(self.sampler) if self.auto
                                                             else self.target_spp, self.lane_cap))

    def sizes(self, subframes: int, groups: int):
        """The pass sizes of one sub-frame (its share of the samples, in ``groups`` groups)."""
        if self.auto:
            return _auto_passes(self.sampler, self.target_spp, self.lane_cap)
        share = self.target_spp // subframes // groups
        return itertools.chain.from_iterable(_fixed_passes(self.sampler, share, self.lane_cap) for _ in range(groups))


class _TileRenderer:
    """Renders the frame tile by tile, pass by pass: each pass its own seed, motion's
    sub-frames in time order, the adaptive median of means over K groups of passes, and
    ``spp = "auto"``'s monitor judging each round."""

    def __init__(self, mi, config, scene, integrator, camera, passes: _PassSchedule, n_channels: int, *,
                 groups: int, subframes: int, mover, monitor, progress, started: float):
        self.mi, self.config, self.scene, self.integrator, self.camera = mi, config, scene, integrator, camera
        self.passes, self.n_channels, self.groups, self.subframes = passes, n_channels, groups, subframes
        self.mover, self.monitor, self.progress, self.started = mover, monitor, progress, started
        self.done, self.index, self.seeds, self.robust_shares = 0, 0, [], []

    def render_frame(self, sensor, width: int, height: int) -> np.ndarray:
        """(H, W, channels) float32: each tile's estimate, Mitsuba's rounding below zero cleared."""
        tiles = self.passes.tiles
        self.frame_rows = height  # a rolling shutter's readout spans the whole frame
        data = np.empty((height, width, self.n_channels), np.float32) if len(tiles) > 1 else None
        radiance_range = _RadianceRange()
        for tile, rows, tile_camera, seed_key in tile_sensors(self.mi, sensor, self.camera, tiles):
            estimate = radiance_range.clear_rounding(self._render_tile(tile, rows, tile_camera, seed_key, width))
            if data is None:
                data = estimate
            else:
                data[rows[0]:rows[1]] = estimate
        release_render_memory()
        radiance_range.check()
        return data

    def _render_tile(self, tile: int, rows: tuple, tile_camera, seed_key, width: int) -> np.ndarray:
        mi, groups = self.mi, self.groups
        accumulated = _PassMean()
        self.done, self.index = 0, 0  # a tile's passes count from 0 (its seeds differ by its seed key)
        # the adaptive median of means keeps K equal groups of passes apart (no sub-frames then)
        group_means = np.empty((groups, rows[1] - rows[0], width, self.n_channels), np.float32) if groups > 1 else None
        group, share = 0, self.passes.target_spp // self.subframes // groups
        rolling = self.subframes > 1 and is_rolling(self.config)
        span = exposure_span_s(self.config, self.frame_rows) if rolling else None
        for subframe in range(self.subframes):
            shifted = self.config.motion.moving and self.config.exposure.start_s != 0  # a later frame's pose
            frame_camera = tile_camera if self.subframes == 1 and not shifted else moved_sensor(
                mi, tile_camera, self.camera, subframe_transform(mi, self.config, subframe, self.subframes, span))
            if self.mover is not None and (self.subframes > 1 or shifted):
                self.mover.place(subframe, self.subframes, span)
            weights = rolling_row_weights(self.config, self.frame_rows, rows[0], rows[1], subframe,
                                          self.subframes)[:, None, None] if rolling else None
            for spp in self.passes.sizes(self.subframes, groups):
                image = self._one_pass(frame_camera, spp, seed_key, rows, width)
                if weights is not None:  # each row keeps the sub-frames inside its own exposure window
                    image = image * weights
                accumulated.add(image, spp)  # equal samples per sub-frame: equal time shares
                if self.progress is not None:
                    _report(self.progress, self.done, self.passes.target_spp, time.perf_counter() - self.started,
                            tile, len(self.passes.tiles))
                if self.monitor is not None and self.monitor.add(image, spp) and \
                        self.monitor.converged(accumulated.peek()):
                    break
                if group_means is not None and accumulated.spp == share:  # a group complete
                    group_means[group] = accumulated.mean()
                    accumulated, group = _PassMean(), group + 1
        if self.mover is not None:
            self.mover.restore()
        if group_means is None:
            return accumulated.mean()
        estimate, median_share = adaptive_median_of_means(group_means)
        self.robust_shares.append(median_share)
        # the light the median removed is real (a caustic's rare paths): given back, spread thin
        return spread_removed_light(group_means.mean(axis=0), estimate)

    def _one_pass(self, frame_camera, spp: int, seed_key, rows: tuple, width: int) -> np.ndarray:
        seed = pass_seed(self.config.render.seed, self.index, seed_key)
        image = self.mi.render(self.scene, sensor=frame_camera, integrator=self.integrator, seed=seed, spp=spp)
        self.done += spp
        self.index += 1
        self.seeds.append(seed)
        return np.asarray(image, dtype=np.float32).reshape(rows[1] - rows[0], width, self.n_channels)


def light_trace(config: SceneConfig, *, spp: int, seed: int, lens: ThinLens | None = None) -> tuple[np.ndarray, float]:
    """Luminance image (arbitrary units) of Mitsuba's particle tracer (``ptracer``: paths
    traced from the emitters to the thin lens) and its render time in seconds.

    ``ptracer`` accepts RGB/luminance films only, not ``specfilm``, so this is a comparison
    tool for the noise of defocused sources, not a spectral render.

    References
    ----------
    .. [1] Veach, E. (1997). Robust Monte Carlo Methods for Light Transport Simulation. PhD
       thesis, Stanford, §10.2 (light tracing).
    """
    import mitsuba as mi

    from .variants import choose_variant

    mi.set_variant(choose_variant(config.render.variant))
    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    width, height = lens.width_px, lens.height_px
    film = {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
            "pixel_format": "luminance", "component_format": "float32"}
    loaded, _, _ = build_scene(mi, config, lens, camera_dict(mi, lens, "thin", film, spp),
                               {"type": "ptracer", "max_depth": config.render.max_depth})
    started = time.perf_counter()
    image = np.asarray(mi.render(loaded, seed=seed, spp=spp), dtype=np.float64).reshape(height, width, -1)[..., 0]
    return image, time.perf_counter() - started
