"""Spectral rendering with Mitsuba 3: variant choice, camera, film bands, passes, depth.

The only module that imports Mitsuba. It turns a :class:`~spectral_cam.scene.SceneConfig`
into a :class:`SpectralImage` of band radiances (W·m⁻²·sr⁻¹ per band: each value is the
integral of L(λ) over its band, as Mitsuba's ``specfilm`` returns it) and a depth map.

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3 renderer, https://mitsuba-renderer.org
   (plugins ``thinlens``, ``perspective``, ``specfilm``, ``aov``).
.. [2] Pharr, M., Jakob, W., & Humphreys, G. (2023). Physically Based Rendering, 4th ed.,
   §5.2.3 (thin lens), §4.6 (spectral sampling).
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from . import spectra
from .errors import ConfigError, RenderError
from .optics import MTF_TOLERANCE, ThinLens
from .scene import BAND_MODES, SPECTRAL_BANDS_DEFAULT, SceneConfig

__all__ = ["SpectralImage", "render", "choose_variant", "band_film"]

#: Wavefront lanes per Mitsuba pass (pixels × spp); bounds memory for the vectorised variants.
LANES_PER_PASS = 1 << 22
#: Lanes per pass for the scalar variant (its cost is per sample; smaller passes give progress).
SCALAR_LANES_PER_PASS = 1 << 20
#: Oldest libLLVM that drjit's LLVM backend works with (older ones abort the process).
MIN_LLVM_MAJOR = 16
#: spp = "auto": samples per pass, passes before judging, and the stopping rule.
AUTO_SPP_PER_PASS = 8
AUTO_SPP_MIN_PASSES = 4
AUTO_SPP_TARGET_RATIO = 0.3
AUTO_SPP_BRIGHT_FRACTION = 0.1
#: Wavelength step (nm) of the camera film's tabulated curves.
CAMERA_FILM_STEP_NM = 5.0


@dataclass
class SpectralImage:
    """Spectral radiance on the image plane.

    Attributes
    ----------
    data
        (H, W, B) float32 band integrals of radiance, W·m⁻²·sr⁻¹ (per band, not per nm).
    wavelengths_nm
        (B,) band centres, nm.
    band_edges_nm
        (B + 1,) band edges, nm.
    depth_m
        (H, W) camera-space z in metres (inf where nothing was hit), or None.
    meta
        Provenance: variant, spp, seeds, timings, optics.
    channels
        None for spectral bands; for ``render.bands = "camera"`` the names of the six film
        channels (:data:`spectral_cam.sensor.CAMERA_CHANNELS`): the photon-weighted camera
        curves and the CIE 1931 CMFs, each value the integral of radiance against its curve
        (``wavelengths_nm``/``band_edges_nm`` then give the film's spectral range).
    """

    data: np.ndarray
    wavelengths_nm: np.ndarray
    band_edges_nm: np.ndarray
    depth_m: np.ndarray | None = None
    meta: dict = field(default_factory=dict)
    channels: tuple[str, ...] | None = None

    @property
    def band_widths_nm(self) -> np.ndarray:
        return np.diff(self.band_edges_nm)

    @property
    def radiance_per_nm(self) -> np.ndarray:
        """Mean spectral radiance in each band, W·m⁻²·sr⁻¹·nm⁻¹."""
        return self.data / self.band_widths_nm.astype(np.float32)


# ----------------------------------------------------------------------------- variants
_PROBE = r"""
import sys
import drjit as dr
version = dr.detail.llvm_version()
if version is None or version[0] < {min_major}:
    sys.exit(3)
import mitsuba as mi
mi.set_variant("llvm_ad_spectral")
scene = mi.load_dict({{"type": "scene", "sensor": {{"type": "perspective",
    "film": {{"type": "specfilm", "width": 2, "height": 2,
              "b": {{"type": "spectrum", "value": [(500, 1.0), (510, 1.0)]}}}}}},
    "integrator": {{"type": "path"}}, "light": {{"type": "constant"}}}})
mi.render(scene, spp=4)
"""


@functools.lru_cache(maxsize=None)
def _llvm_usable() -> bool:
    """Try the LLVM backend in a child process: with libLLVM < 16 drjit aborts the whole
    process ("Cannot select fminimum"), which must not take this one down."""
    try:
        result = subprocess.run(
            [sys.executable, "-c", _PROBE.format(min_major=MIN_LLVM_MAJOR)],
            capture_output=True, timeout=120,
        )
    except (OSError, subprocess.TimeoutExpired):
        return False
    return result.returncode == 0


@functools.lru_cache(maxsize=None)
def _cuda_usable() -> bool:
    code = "import drjit as dr, sys; sys.exit(0 if dr.has_backend(dr.JitBackend.CUDA) else 3)"
    try:
        return subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=120).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


def choose_variant(requested: str = "auto") -> str:
    """The Mitsuba variant to render with.

    ``"auto"`` picks ``cuda_ad_spectral`` where a CUDA device works, else
    ``llvm_ad_spectral`` where libLLVM ≥ 16 works, else ``scalar_spectral``. The
    environment variable ``SPECTRAL_CAM_VARIANT`` overrides ``"auto"``.
    """
    import mitsuba as mi

    requested = os.environ.get("SPECTRAL_CAM_VARIANT", requested) if requested == "auto" else requested
    if requested != "auto" and "spectral" not in requested:
        raise ConfigError(f"Mitsuba variant {requested!r} (render.variant or SPECTRAL_CAM_VARIANT) must be "
                          "a spectral one, e.g. 'llvm_ad_spectral' or 'scalar_spectral'")
    available = mi.variants()
    if requested != "auto":
        if requested not in available:
            raise ConfigError(
                f"render.variant = {requested!r} is not in this Mitsuba build; valid: auto, "
                + ", ".join(v for v in available if "spectral" in v)
            )
        if requested.startswith("llvm") and not _llvm_usable():
            raise RenderError(
                f"{requested} needs libLLVM >= {MIN_LLVM_MAJOR} (apt-get install libllvm19); "
                "use render.variant = 'scalar_spectral' or 'auto'"
            )
        return requested
    if "cuda_ad_spectral" in available and _cuda_usable():
        return "cuda_ad_spectral"
    if "llvm_ad_spectral" in available and _llvm_usable():
        return "llvm_ad_spectral"
    return "scalar_spectral"


# ----------------------------------------------------------------------------- scene dict
def band_film(bands: spectra.BandGrid, width: int, height: int) -> dict:
    """A ``specfilm`` with one box-shaped unit-sensitivity channel per band, so each channel
    is the band integral of radiance. Names sort in band order (EXR sorts channel names)."""
    film = {
        "type": "specfilm",
        "width": width,
        "height": height,
        "component_format": "float32",  # float16 overflows above 65504
        "rfilter": {"type": "box"},  # the default gaussian correlates neighbouring pixels
    }
    for index, (lo, hi) in enumerate(zip(bands.edges_nm[:-1], bands.edges_nm[1:])):
        film[f"band_{index:03d}"] = {"type": "spectrum", "value": [(lo, 1.0), (hi, 1.0)]}
    return film


def _camera(mi, lens: ThinLens, model: str, film: dict, spp: int) -> dict:
    camera = {
        "type": "thinlens" if model == "thin" else "perspective",
        "fov": lens.fov_x_deg,
        "fov_axis": "x",
        "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 0], target=[0, 0, 1], up=[0, 1, 0]),
        "film": film,
        "sampler": {"type": "independent", "sample_count": spp},
        "near_clip": min(1e-3, lens.focus_distance_m / 10),
    }
    if model == "thin":
        camera["aperture_radius"] = lens.aperture_radius_m
        camera["focus_distance"] = lens.focus_distance_m
    return camera


def _build(mi, config: SceneConfig, lens: ThinLens, camera: dict, integrator: dict):
    """Load (scene, sensor, integrator). Presets are built as one scene dict; a user's
    Mitsuba XML scene keeps its shapes, emitters and its first sensor's pose, while our
    camera (lens, film, sampler) and integrator replace its own."""
    from .presets import build_objects

    if not config.scene.mitsuba_xml:
        scene = {"type": "scene", "integrator": integrator, "sensor": camera}
        scene.update(build_objects(config, lens, mi))
        loaded = _load(mi, scene)
        return loaded, loaded.sensors()[0], loaded.integrator()
    try:
        loaded = mi.load_file(config.scene.mitsuba_xml)
    except Exception as exc:
        raise RenderError(f"Mitsuba could not load {config.scene.mitsuba_xml}: {exc}") from None
    if loaded.sensors():
        matrix = np.asarray(loaded.sensors()[0].world_transform().matrix, dtype=np.float64)
        camera = dict(camera, to_world=mi.ScalarTransform4f(matrix.reshape(4, 4, -1)[..., 0]))
    return loaded, _load(mi, camera), _load(mi, integrator)


def _load(mi, scene_dict: dict):
    try:
        return mi.load_dict(scene_dict)
    except Exception as exc:  # Mitsuba raises plain RuntimeError on bad scenes
        raise RenderError(f"Mitsuba could not load the scene: {exc}") from exc


def _pass_seed(seed: int, index: int) -> int:
    """Distinct, reproducible 32-bit seeds for the passes of one frame."""
    return int(np.random.SeedSequence([seed, index]).generate_state(1)[0])


# ----------------------------------------------------------------------------- render
def render(
    config: SceneConfig,
    *,
    progress: Callable[[int, int, float], None] | None = None,
    with_depth: bool = True,
) -> SpectralImage:
    """Render the scene's spectral radiance through the configured lens.

    Parameters
    ----------
    config
        The validated scene.
    progress
        Called after each pass with (spp done, spp total, seconds so far).
    with_depth
        Also render the camera-space depth map (a second, cheap render).

    Returns
    -------
    SpectralImage
        Band integrals of radiance, W·m⁻²·sr⁻¹, shape (height_px, width_px, bands).
    """
    import mitsuba as mi

    variant = choose_variant(config.render.variant)
    mi.set_variant(variant)
    lens = ThinLens.from_config(config.lens, config.sensor)
    width, height = config.sensor.width_px, config.sensor.height_px
    decisions: dict[str, dict] = {}

    depth, depth_s = None, 0.0
    lens_model = config.lens.model
    if with_depth or lens_model == "auto":
        t0 = time.perf_counter()
        depth = render_depth(mi, config, lens)
        depth_s = time.perf_counter() - t0
    if lens_model == "auto":
        lens_model, decisions["lens_model"] = decide_lens_model(lens, depth)

    spectral_spec = config.render.bands if config.render.bands not in BAND_MODES else SPECTRAL_BANDS_DEFAULT
    bands = spectra.parse_bands(spectral_spec)
    diffract, decisions["diffraction"] = decide_diffraction(lens, bands, config.render.diffraction)
    use_camera, decisions["bands"] = decide_bands(config, diffract)
    if use_camera:
        from .sensor import CAMERA_CHANNELS

        film, channels = camera_film(config, width, height), CAMERA_CHANNELS
        wavelengths, edges = np.array([]), np.asarray(spectra.MITSUBA_RANGE_NM)
    else:
        film, channels = band_film(bands, width, height), None
        wavelengths, edges = np.asarray(bands.centres_nm), np.asarray(bands.edges_nm)
    n_channels = len(channels) if channels else len(bands)

    auto_spp = config.render.spp == "auto"
    target_spp = config.render.max_spp if auto_spp else config.render.spp
    lanes = SCALAR_LANES_PER_PASS if variant.startswith("scalar") else LANES_PER_PASS
    spp_per_pass = max(1, min(AUTO_SPP_PER_PASS if auto_spp else target_spp, lanes // (width * height)))
    monitor = None
    if auto_spp:  # equal passes: the pass-to-pass spread estimates the Monte-Carlo noise
        target_spp = -(-target_spp // spp_per_pass) * spp_per_pass
        monitor = NoiseMonitor(config, wavelengths, edges, channels)

    started = time.perf_counter()
    camera = _camera(mi, lens, lens_model, film, spp_per_pass)
    integrator = {"type": "path", "max_depth": config.render.max_depth}
    scene, sensor, integrator = _build(mi, config, lens, camera, integrator)
    load_s = time.perf_counter() - started

    accumulated = np.zeros((height, width, n_channels), dtype=np.float64)
    done, index, seeds = 0, 0, []
    while done < target_spp:
        spp = min(spp_per_pass, target_spp - done)
        seed = _pass_seed(config.render.seed, index)
        image = np.asarray(mi.render(scene, sensor=sensor, integrator=integrator, seed=seed, spp=spp),
                           dtype=np.float64).reshape(height, width, n_channels)
        accumulated += image * spp
        done += spp
        index += 1
        seeds.append(seed)
        if progress is not None:
            progress(done, target_spp, time.perf_counter() - started)
        if monitor is not None and monitor.add(image) and monitor.converged(accumulated / done):
            break
    if monitor is not None:
        decisions["spp"] = monitor.record(done, config.render.max_spp)
        if progress is not None and done < target_spp:
            progress(done, done, time.perf_counter() - started)
    data = accumulated / done
    # Mitsuba's film can return values like −1e-19 where a pixel is black (floating-point
    # cancellation); anything clearly negative would be a bug, not rounding
    lowest, highest = float(data.min()), float(data.max())
    if lowest < -1e-6 * max(highest, 1e-30):
        raise RenderError(f"Mitsuba returned negative radiance ({lowest:g}, max {highest:g})")
    data = np.maximum(data, 0.0).astype(np.float32)
    radiance_s = time.perf_counter() - started - load_s

    t0 = time.perf_counter()
    if diffract:
        data = lens.apply_diffraction(data, bands.centres_nm)
    diffraction_s = time.perf_counter() - t0

    meta = {
        "variant": variant,
        "lens_model": lens_model,
        "spp": done,
        "spp_per_pass": spp_per_pass,
        "passes": index,
        "pass_seeds": seeds,
        "bands": "camera" if use_camera else spectral_spec,
        "bands_nm": list(wavelengths),
        "channels": list(channels) if channels else None,
        "optics": lens.describe(),
        "model_decisions": decisions,
        "timings_s": {"scene_load": load_s, "radiance": radiance_s, "depth": depth_s,
                      "diffraction": diffraction_s},
    }
    return SpectralImage(data, wavelengths, edges, depth, meta, channels)


def camera_film(config: SceneConfig, width: int, height: int) -> dict:
    """A 6-channel ``specfilm``: the photon-weighted camera curves η_c(λ)·T(λ)·λ/λ_ref
    (:func:`spectral_cam.sensor.film_curves`) and the CIE 1931 2° CMFs, so one render
    integrates the camera's response exactly and gives the XYZ ground truth too."""
    import colour

    from .sensor import CAMERA_CHANNELS, film_curves

    lo, hi = spectra.MITSUBA_RANGE_NM
    wl = np.arange(lo, hi + 0.5, CAMERA_FILM_STEP_NM)
    cmfs = spectra.sample(colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"], wl, outside=0.0)
    curves = np.concatenate([film_curves(config, wl), cmfs], axis=1)
    film = {"type": "specfilm", "width": width, "height": height, "component_format": "float32",
            "rfilter": {"type": "box"}}
    for index, name in enumerate(CAMERA_CHANNELS):  # names sort in channel order
        film[f"ch{index}_{name}"] = {"type": "spectrum",
                                     "value": [(float(w), float(v)) for w, v in zip(wl, curves[:, index])]}
    return film


def decide_bands(config: SceneConfig, diffraction: bool) -> tuple[bool, dict]:
    """Camera-film channels instead of spectral bands when nothing needs the spectrum.

    ``render.bands = "auto"`` picks the camera film when no spectral output is asked
    (``render.spectral_output = false``) and diffraction (a per-band PSF) does not apply:
    the film integrates the measured curves exactly, so it has no band-discretisation bias
    and 6 channels instead of 31.
    """
    requested = config.render.bands
    if config.sensor.cfa == "none":
        if requested == "camera":
            raise ConfigError("render.bands = 'camera' needs a colour sensor; a monochrome sensor "
                              "(sensor.cfa = 'none') integrates spectral bands")
        choice = requested if requested != "auto" else SPECTRAL_BANDS_DEFAULT
        return False, {"choice": choice, "reason": "monochrome sensor: flat-QE spectral bands"}
    if requested == "camera":
        if diffraction:
            raise ConfigError("render.bands = 'camera' cannot carry the per-band diffraction PSF that applies "
                              "here; use render.bands = 'auto' or a band grid, or render.diffraction = 'off'")
        return True, {"choice": "camera", "reason": "render.bands = 'camera'"}
    if requested != "auto":
        return False, {"choice": requested, "reason": f"render.bands = {requested!r}"}
    if config.render.spectral_output:
        return False, {"choice": SPECTRAL_BANDS_DEFAULT, "reason": "a spectral output (radiance.exr) is asked"}
    if diffraction:
        return False, {"choice": SPECTRAL_BANDS_DEFAULT, "reason": "diffraction needs a per-band PSF"}
    return True, {"choice": "camera", "reason": "one camera, no spectral output, no diffraction: the camera "
                                                "curves go into the film (no band discretisation)"}


class NoiseMonitor:
    """Monte-Carlo noise against sensor noise, pass by pass (``render.spp = "auto"``).

    Each pass's image is turned into noise-free photo-electrons per pixel (through the
    CFA, at the configured exposure); the spread between passes estimates the Monte-Carlo
    standard deviation of their mean, σ_MC² = var(pass)/n. The sensor's own noise is
    σ_sensor² = μ_e + σ_d² (shot + dark noise, EMVA 1288). The render stops when, over the
    pixels brighter than 10 % of the maximum, the 90th percentile of σ_MC/σ_sensor is ≤ 0.3.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.3 (temporal noise model).
    .. [2] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §2.1.4 (Monte Carlo variance).
    """

    def __init__(self, config: SceneConfig, wavelengths_nm, edges_nm, channels):
        from .presets import white_reference_mask

        self.config, self.channels = config, channels
        self.wavelengths, self.edges = np.asarray(wavelengths_nm), np.asarray(edges_nm)
        self.white_mask = white_reference_mask(config)
        self.count = 0
        self.sum = self.sum_sq = None
        self.ratio_p90 = np.inf
        self.exposure_s = None
        self.history: list[tuple[int, float]] = []

    def _image(self, data):
        return SpectralImage(np.asarray(data, dtype=np.float32), self.wavelengths, self.edges, None, {},
                             self.channels)

    def add(self, image: np.ndarray) -> bool:
        """Add one pass (all passes have the same spp); returns True once enough passes
        exist to judge convergence."""
        from .sensor import expected_electrons

        rate, _ = expected_electrons(self._image(np.maximum(image, 0.0)), self.config, exposure_s=1.0)
        rate = rate.astype(np.float64)
        if self.sum is None:
            self.sum, self.sum_sq = np.zeros_like(rate), np.zeros_like(rate)
        self.sum += rate
        self.sum_sq += rate * rate
        self.count += 1
        return self.count >= AUTO_SPP_MIN_PASSES

    def converged(self, mean_image: np.ndarray) -> bool:
        """Judge the passes so far; ``mean_image`` is their running mean (for the exposure
        time when ``exposure.time_s = "auto"``)."""
        from .sensor import dark_noise_electrons, expected_electrons

        n = self.count
        mean_rate = self.sum / n
        if self.config.exposure.time_s == "auto":
            _, exposure_s = expected_electrons(self._image(np.maximum(mean_image, 0.0)), self.config,
                                               white_mask=self.white_mask)
        else:
            exposure_s = float(self.config.exposure.time_s)
        self.exposure_s = exposure_s
        mean_e = mean_rate * exposure_s
        var_pass = np.maximum(self.sum_sq / n - mean_rate ** 2, 0.0) * n / (n - 1) * exposure_s ** 2
        sigma_mc = np.sqrt(var_pass / n)
        sigma_sensor = np.sqrt(mean_e + dark_noise_electrons(self.config.sensor, exposure_s) ** 2)
        bright = mean_e > AUTO_SPP_BRIGHT_FRACTION * mean_e.max()
        if not bright.any() or mean_e.max() <= 0:
            self.ratio_p90 = 0.0
        else:
            self.ratio_p90 = float(np.percentile(sigma_mc[bright] / sigma_sensor[bright], 90))
        self.history.append((n, self.ratio_p90))
        return self.ratio_p90 <= AUTO_SPP_TARGET_RATIO

    def record(self, spp: int, cap: int) -> dict:
        """The decision record for meta.json."""
        stopped = "converged" if self.ratio_p90 <= AUTO_SPP_TARGET_RATIO else f"reached render.max_spp = {cap}"
        return {
            "choice": spp,
            "reason": f"{stopped}: 90th percentile of σ_MC/σ_sensor over pixels > "
                      f"{AUTO_SPP_BRIGHT_FRACTION:g}·max is {self.ratio_p90:.3f} (target ≤ {AUTO_SPP_TARGET_RATIO})",
            "ratio_p90": self.ratio_p90,
            "exposure_s": self.exposure_s,
            "history": [{"passes": n, "ratio_p90": r} for n, r in self.history],
        }


def decide_lens_model(lens: ThinLens, depth_m: np.ndarray) -> tuple[str, dict]:
    """Pinhole when defocus costs ≤ 0.03 of MTF at Nyquist over the depths in view.

    Returns the chosen model and the decision record for ``meta.json``.
    """
    finite = depth_m[np.isfinite(depth_m)]
    if finite.size == 0:
        return "thin", {"choice": "thin", "reason": "nothing in view to measure depth on"}
    near, far = float(finite.min()), float(finite.max())
    cost = lens.defocus_cost(near, far)
    choice = "pinhole" if cost <= MTF_TOLERANCE else "thin"
    relation = "≤" if choice == "pinhole" else ">"
    return choice, {
        "choice": choice,
        "reason": f"defocus costs {cost:.3f} of MTF at Nyquist over {near:.3g}–{far:.3g} m "
                  f"({relation} {MTF_TOLERANCE})",
        "mtf_cost_at_nyquist": cost,
        "depth_range_m": [near, far],
        "max_coc_px": float(max(lens.coc_diameter_px(near), lens.coc_diameter_px(far))),
    }


def decide_diffraction(lens: ThinLens, bands: spectra.BandGrid, mode: str) -> tuple[bool, dict]:
    """Apply the per-band Airy PSF when forced, or (``auto``) when it costs more than 0.03
    of MTF at Nyquist for the longest band (diffraction grows with λ)."""
    longest = float(max(bands.centres_nm))
    cost = lens.diffraction_cost(longest)
    if mode == "auto":
        apply = cost > MTF_TOLERANCE
        reason = (f"diffraction costs {cost:.3f} of MTF at Nyquist at {longest:g} nm "
                  f"({'>' if apply else '≤'} {MTF_TOLERANCE}) at N_w = {lens.working_f_number:.3g}")
    else:
        apply = mode == "on"
        reason = f"render.diffraction = {mode!r} (costs {cost:.3f} of MTF at Nyquist at {longest:g} nm)"
    return apply, {"choice": "airy_psf_per_band" if apply else "skipped", "reason": reason,
                   "mtf_cost_at_nyquist": cost}


def render_depth(mi, config: SceneConfig, lens: ThinLens) -> np.ndarray:
    """Camera-space z (m) per pixel from the first hit's world position.

    Mitsuba's ``depth`` AOV is the ray length, which off axis exceeds z by 1/cos θ, so z is
    taken as (p − camera origin)·(optical axis) from the ``position`` AOV. One sample per
    pixel keeps it the depth of one surface, never a blend across an edge.
    """
    width, height = config.sensor.width_px, config.sensor.height_px
    film = {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
            "pixel_format": "luminance", "component_format": "float32"}
    camera = _camera(mi, lens, "pinhole", film, 1)
    scene, sensor, integrator = _build(mi, config, lens, camera, {"type": "aov", "aovs": "pos:position"})
    image = np.asarray(mi.render(scene, sensor=sensor, integrator=integrator,
                                 seed=_pass_seed(config.render.seed, 1 << 20), spp=1))
    position = image.reshape(height, width, -1)[..., :3].astype(np.float64)
    to_world = np.asarray(sensor.world_transform().matrix, dtype=np.float64).reshape(4, 4, -1)[..., 0]
    origin, axis = to_world[:3, 3], to_world[:3, 2] / np.linalg.norm(to_world[:3, 2])
    z = (position - origin) @ axis
    hit = np.any(position != 0.0, axis=-1)  # the AOV is all zero where a ray escapes
    return np.where(hit & (z > 0), z, np.inf).astype(np.float32)
