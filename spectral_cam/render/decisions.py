"""Model no more than a scene needs: the render's model decisions.

Each returns its choice and a record for ``meta.json`` under ``model_decisions``:
the lens model (pinhole when defocus costs <= 0.03 of MTF at Nyquist; the depth-layered
model where it is exact and cheaper), diffraction (only when it costs > 0.03 of MTF at
Nyquist), the film (camera curves when nothing needs the spectrum), ``spp = "auto"``
(stop when Monte-Carlo noise is <= 0.3 of the sensor's own) and the estimator (the median of
means from 8 passes of 8 spp; with fewer, only where a probe render finds fireflies). See docs/design.md, "Model
decisions".

References
----------
.. [1] Goodman, J. W. (2005). Introduction to Fourier Optics, 3rd ed., §6.3.2 (diffraction MTF).
.. [2] EMVA 1288 Release 4.0, §2.3 (temporal noise model).
.. [3] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §2.1.4 (Monte Carlo variance).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import spectra
from ..errors import ConfigError
from ..image import SpectralImage
from ..optics import MTF_TOLERANCE, ThinLens, defocus_mtf
from ..scene import SPECTRAL_BANDS_DEFAULT, SceneConfig

#: spp = "auto": samples per pass, passes before judging, and the stopping rule.
AUTO_SPP_PER_PASS = 8
#: Samples per pass of ``spp = "auto"`` with a stratified (randomised quasi-Monte-Carlo) sampler:
#: stratification works within a pass, so passes of 8 behave almost like independent sampling
#: (multijitter, bundled ColorChecker: 128 passes of 8 left σ_MC/σ_sensor at 0.45, p90), while
#: one pass of 256 is 7× less noisy than independent sampling's 256 (docs/bench/samplers.csv).
AUTO_SPP_PER_PASS_STRATIFIED = 16


def auto_spp_per_pass(sampler: str) -> int:
    """Samples per pass of ``spp = "auto"`` for ``render.sampler``."""
    return AUTO_SPP_PER_PASS if sampler == "independent" else AUTO_SPP_PER_PASS_STRATIFIED


AUTO_SPP_MIN_PASSES = 4


AUTO_SPP_TARGET_RATIO = 0.3


AUTO_SPP_BRIGHT_FRACTION = 0.1


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
    """Monte-Carlo noise against sensor noise, round by round (``render.spp = "auto"``).

    Each pass's image is turned into noise-free photo-electrons per pixel (through the
    CFA, at the configured exposure). Passes come in rounds of equal size, the size growing
    from round to round; the spread within a round estimates the Monte-Carlo variance of
    that round's mean, and the rounds pool into the variance of the spp-weighted mean (see
    :meth:`_pooled`). The sensor's own noise is σ_sensor² = μ_e + σ_d² (shot + dark noise,
    EMVA 1288). The render stops when, over the pixels brighter than 10 % of the maximum,
    the 90th percentile of σ_MC/σ_sensor is ≤ 0.3.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.3 (temporal noise model).
    .. [2] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §2.1.4 (Monte Carlo variance).
    """

    def __init__(self, config: SceneConfig, wavelengths_nm, edges_nm, channels, lens=None):
        from ..presets import white_reference_mask

        self.config, self.channels, self.lens = config, channels, lens
        self.wavelengths, self.edges = np.asarray(wavelengths_nm), np.asarray(edges_nm)
        self.white_mask = white_reference_mask(config, lens)  # on the rendered area (with any margin)
        self.rounds: list[dict] = []  # per round of equal passes: spp per pass, count, Σ rate, Σ rate²
        self.ratio_p90 = np.inf
        self.exposure_s = None
        self.history: list[tuple[int, float]] = []

    def _image(self, data):
        return SpectralImage(np.asarray(data, dtype=np.float32), self.wavelengths, self.edges, None, {},
                             self.channels, self.lens)

    def add(self, image: np.ndarray, spp: int = AUTO_SPP_PER_PASS) -> bool:
        """Add one pass of ``spp`` samples per pixel; passes of a new size start a new round.
        Returns True when the current round has :data:`AUTO_SPP_MIN_PASSES` passes (time to judge)."""
        from ..sensor import expected_electrons

        rate, _ = expected_electrons(self._image(np.maximum(image, 0.0)), self.config, exposure_s=1.0)
        rate = rate.astype(np.float64)
        if not self.rounds or self.rounds[-1]["spp"] != spp or self.rounds[-1]["n"] >= AUTO_SPP_MIN_PASSES:
            self.rounds.append({"spp": spp, "n": 0, "sum": np.zeros_like(rate), "sum_sq": np.zeros_like(rate)})
        current = self.rounds[-1]
        current["sum"] += rate
        current["sum_sq"] += rate * rate
        current["n"] += 1
        return current["n"] >= AUTO_SPP_MIN_PASSES

    def _pooled(self):
        """(mean rate, variance of the mean rate) of all passes, weighted by their spp. Each round
        r of n_r passes of m_r spp gives its mean μ_r and, from its own spread, var(μ_r) = s_r²/n_r
        (valid for randomised quasi-Monte-Carlo passes too: each seed is an independent
        randomisation); the spp-weighted mean has var = Σ (n_r·m_r/M)²·var(μ_r)."""
        total = sum(r["n"] * r["spp"] for r in self.rounds)
        mean = sum(r["sum"] * (r["spp"] / total) for r in self.rounds)
        variance = np.zeros_like(mean)
        for r in self.rounds:
            n = r["n"]
            if n < 2:
                continue  # no spread yet (a round just started): judged at its end
            mu = r["sum"] / n
            spread = np.maximum(r["sum_sq"] / n - mu ** 2, 0.0) * n / (n - 1)
            variance += (n * r["spp"] / total) ** 2 * spread / n
        return mean, variance, total

    def converged(self, mean_image: np.ndarray) -> bool:
        """Judge the passes so far; ``mean_image`` is their running mean (for the exposure
        time when ``exposure.time_s = "auto"``)."""
        from ..sensor import dark_noise_electrons, expected_electrons

        mean_rate, var_rate, total = self._pooled()
        if self.config.exposure.time_s == "auto":
            _, exposure_s = expected_electrons(self._image(np.maximum(mean_image, 0.0)), self.config,
                                               white_mask=self.white_mask)
        else:
            exposure_s = float(self.config.exposure.time_s)
        self.exposure_s = exposure_s
        mean_e = mean_rate * exposure_s
        sigma_mc = np.sqrt(var_rate) * exposure_s
        sigma_sensor = np.sqrt(mean_e + dark_noise_electrons(self.config.sensor, exposure_s) ** 2)
        bright = mean_e > AUTO_SPP_BRIGHT_FRACTION * mean_e.max()
        if not bright.any() or mean_e.max() <= 0:
            self.ratio_p90 = 0.0
        else:
            self.ratio_p90 = float(np.percentile(sigma_mc[bright] / sigma_sensor[bright], 90))
        self.history.append((total, self.ratio_p90))
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
            "history": [{"spp": n, "ratio_p90": r} for n, r in self.history],
            "passes": [{"spp_per_pass": r["spp"], "passes": r["n"]} for r in self.rounds],
        }


#: Accuracy budget of the depth-layered model's alternative: thin-lens path tracing is
#: replaced when its expected per-pixel relative noise in the blur exceeds this.
LAYERED_NOISE_BUDGET = 0.01
#: CoC bin of the layered model (a ratio): surfaces within one bin share one disc PSF.
LAYERED_COC_RATIO = 1.05


#: Materials of an XML scene (Mitsuba BSDF plugin names) whose specular or glossy lobes can carry
#: rare bright paths; Lambertian-only scenes cannot make fireflies under direct light sampling.
GLOSSY_BSDFS = ("conductor", "roughconductor", "dielectric", "roughdielectric", "thindielectric", "plastic",
                "roughplastic", "principled", "principledthin", "hair", "measured", "blendbsdf")
#: Passes of the adaptive median of means, and the fewest samples in one: the median of means
#: of a few samples each is biased low even where no firefly is (the median of a skewed
#: distribution), so a pass needs some samples.
ROBUST_PASSES = (8, 16, 4)
ROBUST_MIN_PASS_SPP = 4
#: Where ``render.estimator = "auto"`` takes the median without measuring: at least this many
#: passes of at least this many samples. Splitting the samples into passes costs noise even where
#: no pixel takes the median, as each pass is stratified on its own (0.3-0.4 % of the tabletop's
#: pixels took the median): on the tabletop (192×128, against 2048 spp, docs/bench/estimators.csv)
#: the adaptive median's RMS error was 1.72× the mean's at 4 passes of 4 spp, 1.66× at 8 of 4,
#: 1.17× at 8 of 8 and 1.11× at 8 of 16; on the textured glass sphere's caustics (with the removed
#: light spread back) it was 0.10×, 0.49×, 0.46× and 0.30× (fireflies are error too). From 8
#: passes of 8 the split is cheap enough to keep always against fireflies.
AUTO_MIN_PASSES = 8
AUTO_MIN_PASS_SPP = 8
#: Below that, ``auto`` measures: a pinhole probe of the scene this wide (px), at the render's spp,
#: mean estimate; the median only where its firefly share
#: (:func:`spectral_cam.metrics.realism.firefly_share`) reaches :data:`AUTO_FIREFLY_SHARE`
#: (the glass sphere's mean: 4.9e-4 at 16 spp; the tabletop's: 2.9e-5, 0 at 32 spp).
AUTO_PROBE_WIDTH_PX = 160
AUTO_FIREFLY_SHARE = 1e-4


def _can_make_fireflies(config: SceneConfig) -> tuple[bool, str]:
    """Whether a scene holds materials that make fireflies, and why: a preset's as its registry
    entry declares them (:attr:`spectral_cam.presets.common.Preset.sharp_materials`: delta lobes or
    GGX α below :data:`~spectral_cam.presets.common.SHARP_ALPHA`); an XML scene's any glossy
    plugin (:data:`GLOSSY_BSDFS`: its roughness is not read, so a rough lobe counts too)."""
    if config.scene.mitsuba_xml:
        import re

        try:
            text = Path(config.scene.mitsuba_xml).read_text(errors="replace")
        except OSError:
            return True, "an XML scene whose materials could not be read"
        found = sorted(set(re.findall(r'<bsdf[^>]*type\s*=\s*"([a-z_]+)"', text)) & set(GLOSSY_BSDFS))
        if found or "<include" in text:
            return True, f"the XML scene has {', '.join(found) or 'included files'} materials"
        return False, "the XML scene's materials are all Lambertian"
    from ..presets import PRESETS
    from ..presets.common import SHARP_ALPHA

    sharp = PRESETS[config.scene.preset].sharp_materials(config)
    if sharp:
        return True, f"the {config.scene.preset} preset places {', '.join(sorted(set(sharp)))} materials"
    return False, f"the {config.scene.preset} preset's materials are Lambertian or rough (GGX α ≥ {SHARP_ALPHA:g}) only"


def decide_estimator(config: SceneConfig, spp: int | str, *, lens: ThinLens | None = None,
                     probe=None) -> tuple[int, dict]:
    """How the passes become a pixel's radiance: the number K of equal passes whose adaptive
    median of means (:mod:`spectral_cam.render.robust`) removes fireflies, or 1 for the plain
    mean.

    ``render.estimator = "auto"`` takes the adaptive median where the scene can make fireflies
    (:func:`_can_make_fireflies`) and the samples split into at least :data:`AUTO_MIN_PASSES`
    passes of at least :data:`AUTO_MIN_PASS_SPP`; with fewer or smaller passes the split costs
    up to 1.7× the mean's RMS error, so it measures first: the median only where a probe
    render's mean holds fireflies (:func:`firefly_probe`, :data:`AUTO_FIREFLY_SHARE`).
    ``"amon"`` takes the median always (passes of at least :data:`ROBUST_MIN_PASS_SPP`),
    ``"mean"`` never. Either needs a fixed ``spp`` that splits into K passes the sampler keeps
    exactly, and no motion sub-frames.

    Parameters
    ----------
    config : SceneConfig
        The resolved scene.
    spp : int or "auto"
        Samples per pixel.
    lens : ThinLens, optional
        The frame's lens, for the probe's view (default: built from ``config``).
    probe : callable, optional
        ``probe(config, lens) -> firefly share`` (default :func:`firefly_probe`).

    Returns
    -------
    (int, dict)
        K (1 = the mean) and the record for ``model_decisions``.

    References
    ----------
    .. [1] Buisine, J., Delepoulle, S., & Renaud, C. (2021). Firefly removal in Monte Carlo
       rendering with adaptive Median of meaNs. EGSR 2021.
    """
    from .robust import GINI_THRESHOLD
    from .scene_dict import exact_pass_spp

    mode = config.render.estimator
    if mode == "mean":
        return 1, {"choice": "mean", "reason": "render.estimator = 'mean'"}
    if mode == "auto":
        needed, why = _can_make_fireflies(config)
        if not needed:
            return 1, {"choice": "mean", "reason": why + ": no fireflies to remove, so the unbiased mean"}
    else:
        why = "render.estimator = 'amon'"
    if spp == "auto" or config.motion.moving:
        return 1, {"choice": "mean", "reason": f"{why}, but {'spp = auto' if spp == 'auto' else 'motion blur'} "
                                               "renders its own passes: the mean"}
    passes = [k for k in ROBUST_PASSES if spp % k == 0 and spp // k >= ROBUST_MIN_PASS_SPP
              and exact_pass_spp(config.render.sampler, spp // k) == spp // k]
    if not passes:
        return 1, {"choice": "mean", "reason": f"{why}, but {spp} spp does not split into 4, 8 or 16 passes of at "
                                               f"least {ROBUST_MIN_PASS_SPP} spp that the {config.render.sampler} "
                                               "sampler keeps exactly: the mean"}
    enough = [k for k in passes if k >= AUTO_MIN_PASSES and spp // k >= AUTO_MIN_PASS_SPP]
    k = (enough or passes)[0]
    record = {"choice": "amon", "passes": k, "gini_threshold": GINI_THRESHOLD,
              "reason": f"{why}: the adaptive median of {k} pass means of {spp // k} spp removes fireflies "
                        "(the mean where the passes agree) and spreads the light it removed"}
    if mode == "auto" and not enough:
        share = float((probe or firefly_probe)(config, lens or ThinLens.from_config(config.lens, config.sensor)))
        record["probe_firefly_share"] = share
        if share < AUTO_FIREFLY_SHARE:
            return 1, {"choice": "mean", "probe_firefly_share": share,
                       "reason": f"{why}, but {k} passes of {spp // k} spp cost up to 1.7× the mean's noise "
                                 f"(docs/bench/estimators.csv) and a {AUTO_PROBE_WIDTH_PX}-px probe's mean held "
                                 f"{share:.2g} fireflies (< {AUTO_FIREFLY_SHARE:g}): the mean "
                                 "(render.estimator = 'amon' forces the median)"}
        record["reason"] += (f"; measured first, as {k} passes of {spp // k} spp cost noise: a "
                             f"{AUTO_PROBE_WIDTH_PX}-px probe's mean held {share:.2g} fireflies "
                             f"(≥ {AUTO_FIREFLY_SHARE:g})")
    return k, record


def firefly_probe(config: SceneConfig, lens: ThinLens) -> float:
    """Firefly share of the plain mean on a small pinhole render of the frame's view: at most
    :data:`AUTO_PROBE_WIDTH_PX` wide (coarser pixels), the render's spp, sampler, seed and
    integrator depth, its luminance (CIE Y) only.

    Returns
    -------
    float
        :func:`spectral_cam.metrics.realism.firefly_share` of the probe (0 to 1).

    References
    ----------
    .. [1] docs/bench/estimators.csv (the share separating scenes the median helps from those it
       does not).
    """
    import dataclasses

    import mitsuba as mi

    from ..metrics.realism import firefly_share
    from .films import camera_film
    from .scene_dict import build_scene, configured_camera, exact_pass_spp
    from .variants import choose_variant_record

    if mi.variant() is None:  # called outside a capture plan, which sets it first
        mi.set_variant(choose_variant_record(config.render.variant)[0])
    width = min(AUTO_PROBE_WIDTH_PX, lens.width_px)
    height = max(1, round(width * lens.height_px / lens.width_px))
    view = dataclasses.replace(lens, width_px=width, height_px=height, frame_lens=lens.layout_lens)
    spp = exact_pass_spp(config.render.sampler, int(config.render.spp))
    camera = configured_camera(mi, config, view, "pinhole", camera_film(config, width, height, channels=("Y",)), spp)
    scene, sensor, integrator = build_scene(mi, config, view, camera,
                                            {"type": "path", "max_depth": config.render.max_depth})
    image = np.asarray(mi.render(scene, sensor=sensor, integrator=integrator, seed=config.render.seed, spp=spp))
    return firefly_share(image.reshape(height, width, -1)[..., 0])


def thin_lens_noise(lens: ThinLens, depth_m: np.ndarray, spp: int) -> float:
    """Expected relative Monte-Carlo noise per pixel of thin-lens path tracing where the
    scene's objects are blurred: √((1 − p)/(p·spp)), p the fraction of the aperture through
    which a pixel inside a blur disc sees an object, estimated as the objects' pinhole
    footprint (pixels with a finite depth) over the area of the largest blur disc.

    References
    ----------
    .. [1] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §2.1.4 (Monte Carlo variance of a
       Bernoulli-weighted estimator).
    """
    finite = np.isfinite(depth_m)
    if not finite.any():
        return 0.0
    coc = float(np.max(lens.coc_diameter_px(depth_m[finite])))
    disc_px = max(math.pi * coc * coc / 4.0, 1.0)
    p = min(1.0, float(finite.sum()) / disc_px)
    return math.sqrt((1.0 - p) / (p * max(spp, 1)))


def chromatic_blur_px(lens: ThinLens, glass_spec: str) -> float:
    """Diameter (px) of the blur longitudinal colour leaves in the focus plane, for the F and C
    lines, whichever is larger: A·|v(λ) − v_d|/v(λ), with v(λ) the image distance of the focus
    distance for f(λ) of ``glass_spec`` (``lens.glass``; 0 for ``"ideal"``)."""
    if glass_spec == "ideal":
        return 0.0
    from ..optics.glass import LINES_NM, thin_lens_focal_length

    z, v_d = lens.focus_distance_m, lens.image_distance_m
    focal = thin_lens_focal_length(glass_spec, lens.focal_length_m, [LINES_NM["F"], LINES_NM["C"]])
    v = focal * z / (z - focal)
    return float(np.max(2.0 * lens.aperture_radius_m * np.abs(v - v_d) / v) / lens.pixel_pitch_m)


def decide_lens_model(lens: ThinLens, depth_m: np.ndarray, config: SceneConfig | None = None) -> tuple[str, dict]:
    """The cheapest lens model within the accuracy budget, from the depths in view.

    - ``spectral_thin`` when the configuration asks for what only it renders (``lens.blades``,
      ``lens.distortion``) or the glass's longitudinal colour (:func:`chromatic_blur_px`) costs
      more than 0.03 of MTF at Nyquist in the focus plane;

    - ``pinhole`` when defocus costs ≤ 0.03 of MTF at Nyquist over the depths in view;
    - ``layered`` (:func:`spectral_cam.render.layered.render_layered`) when every surface in
      view lies in one CoC bin (no object is blurred over another at a different blur, so
      the layered model has no partial-occlusion error) and thin-lens path tracing at the
      configured spp would leave more than :data:`LAYERED_NOISE_BUDGET` relative noise in
      the blur (:func:`thin_lens_noise`): a small bright source far out of focus;
    - ``thin`` otherwise.

    Returns the chosen model and the decision record for ``meta.json``.
    """
    if config is not None:
        shaped = [k for k, on in (("lens.blades", config.lens.blades), ("lens.distortion", any(config.lens.distortion)))
                  if on]
        if shaped:
            return "spectral_thin", {"choice": "spectral_thin", "reason": f"{' and '.join(shaped)} set: only the "
                                     "spectral thin lens renders them"}
        colour_px = chromatic_blur_px(lens, config.lens.glass)
        colour_cost = float(1.0 - defocus_mtf(lens.nyquist_cyc_per_m, colour_px * lens.pixel_pitch_m))
        if colour_cost > MTF_TOLERANCE:
            return "spectral_thin", {"choice": "spectral_thin", "chromatic_blur_px": colour_px,
                                     "mtf_cost_at_nyquist": colour_cost,
                                     "reason": f"{config.lens.glass}'s longitudinal colour blurs the focus plane by "
                                               f"{colour_px:.2f} px (F/C), costing {colour_cost:.3f} of MTF at "
                                               f"Nyquist (> {MTF_TOLERANCE})"}
    finite = depth_m[np.isfinite(depth_m)]
    if finite.size == 0:
        return "thin", {"choice": "thin", "reason": "nothing in view to measure depth on"}
    near, far = float(finite.min()), float(finite.max())
    cost = lens.defocus_cost(near, far)
    cocs = [float(lens.coc_diameter_px(near)), float(lens.coc_diameter_px(far))]
    record = {"mtf_cost_at_nyquist": cost, "depth_range_m": [near, far], "max_coc_px": max(cocs)}
    if cost <= MTF_TOLERANCE:
        return "pinhole", {"choice": "pinhole", "reason": f"defocus costs {cost:.3f} of MTF at Nyquist over "
                           f"{near:.3g}–{far:.3g} m (≤ {MTF_TOLERANCE})", **record}
    reason = f"defocus costs {cost:.3f} of MTF at Nyquist over {near:.3g}–{far:.3g} m (> {MTF_TOLERANCE})"
    if config is not None and min(cocs) >= 1.0 and max(cocs) <= LAYERED_COC_RATIO * min(cocs):
        spp = config.render.max_spp if config.render.spp == "auto" else int(config.render.spp)
        noise = thin_lens_noise(lens, depth_m, spp)
        record["thin_lens_noise"] = noise
        if noise > LAYERED_NOISE_BUDGET:
            return "layered", {"choice": "layered", "reason": f"{reason}; every surface in one CoC bin and "
                               f"thin-lens noise at {spp} spp ≈ {noise:.2g} > {LAYERED_NOISE_BUDGET}: "
                               "pinhole render + depth-layered disc PSF", **record}
    return "thin", {"choice": "thin", "reason": reason, **record}


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
