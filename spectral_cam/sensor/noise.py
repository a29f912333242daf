"""The EMVA 1288 linear noise chain: electrons → digital numbers.

Poisson(photo-signal·(1 + PRNU) + I_d·t) → + DSNU offset → clip at full well → + Gaussian
read noise → × K → + black level → round → clip to [0, 2^bits − 1]. Fixed patterns (PRNU,
DSNU) come from ``sensor.seed`` and are cached per seed and shape; temporal noise comes from
the frame seed. A new noise term goes here (docs/design.md, "Sensor").

References
----------
.. [1] EMVA Standard 1288, Release 4.0 Linear (2021), §2 (the linear camera model), §3
   (the noise model).
.. [2] Janesick, J. R. (2007). Photon Transfer: DN → λ. SPIE Press, ch. 2–4.
.. [3] Farrell, J. E., Catrysse, P. B., & Wandell, B. A. (2012). Digital camera simulation.
   Applied Optics 51(4), A80–A90 (normal approximation of shot noise for large counts).
.. [4] Adobe (2023). DNG Specification 1.7.1.0, tag NoiseProfile (51041).
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..cfa import check_cfa
from ..errors import SensorError
from .parallel import row_chunks, run_chunks, workers_for

if TYPE_CHECKING:  # pragma: no cover
    from ..scene import SensorSection

#: ``"poisson"``: exact Poisson shot noise everywhere; ``"hybrid"``: exact Poisson below
#: :data:`HYBRID_POISSON_BELOW_E` mean electrons and near full well, the normal
#: approximation N(μ, μ) elsewhere (mean and variance exact; the Poisson skewness 1/√μ ≤ 0.1
#: and excess kurtosis 1/μ ≤ 0.01 are dropped; ISETCam switches at 25 e⁻).
SHOT_NOISE_METHODS = ("hybrid", "poisson")


#: Mean electron count below which the hybrid method draws exact Poisson numbers.
HYBRID_POISSON_BELOW_E = 100.0


def system_gain(sensor: "SensorSection", iso: float) -> float:
    """System gain K (DN/e⁻): ``K_base = (2^bits − 1 − black) / full_well`` at base ISO,
    ``K = K_base · iso / base_iso``.

    Parameters
    ----------
    sensor : SensorSection
        Uses bit_depth, black_level_dn, full_well_e, base_iso.
    iso : float
        Exposure index (ISO).

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.2 (overall system gain K).
    """
    _check_sensor(sensor)
    if not (isinstance(iso, (int, float)) and math.isfinite(iso) and iso > 0):
        raise SensorError(f"exposure.iso = {iso!r} must be a finite number > 0")
    k_base = (2 ** sensor.bit_depth - 1 - sensor.black_level_dn) / sensor.full_well_e
    return k_base * iso / sensor.base_iso


def saturation_electrons(sensor: "SensorSection", gain: float) -> float:
    """Electrons at saturation: ``min(full well, (2^bits − 1 − black) / K)``.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.2 (saturation capacity μ_e.sat).
    """
    return min(float(sensor.full_well_e), (2 ** sensor.bit_depth - 1 - sensor.black_level_dn) / gain)


def dark_noise_electrons(sensor: "SensorSection", exposure_s: float) -> float:
    """Temporal dark noise σ_d = √(σ_read² + I_d·t) (e⁻), without quantisation.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.3 eq. (5) (σ_d² and the dark-current shot noise).
    """
    return math.sqrt(sensor.read_noise_e ** 2 + sensor.dark_current_e_per_s * exposure_s)


def noise_profile(gain: float, sigma_read_e: float, black_level: float, white_level: float
                  ) -> tuple[float, float]:
    """DNG NoiseProfile (S, O) for the signal x = (DN − B)/(W − B) ∈ [0, 1].

    ``var(x) = S·x + O`` with ``S = K/(W − B)`` (shot noise) and
    ``O = (K²·σ_read² + 1/12)/(W − B)²`` (read noise plus quantisation).

    Only the black level B is subtracted, so x still holds the dark signal K·I_d·t, whose
    shot noise S·x already counts: O takes the read noise alone. (O = (K²σ_d² + 1/12)/(W − B)²
    with σ_d² = σ_read² + I_d·t would count the dark-current shot noise twice; the difference
    is K²·I_d·t/(W − B)²; docs/design.md, "RAW".)

    Parameters
    ----------
    gain : float
        K (DN/e⁻).
    sigma_read_e : float
        Read noise σ_read (e⁻).
    black_level, white_level : float
        B and W (DN).

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, NoiseProfile (51041).
    .. [2] EMVA 1288 Release 4.0, §2.3 eq. (6) (σ_y² = K²(σ_d² + μ_e) + σ_q²).
    """
    span = float(white_level) - float(black_level)
    return gain / span, (gain ** 2 * sigma_read_e ** 2 + 1.0 / 12.0) / span ** 2


def _check_sensor(sensor: "SensorSection") -> None:
    """Defensive checks (scene.py validates configs; direct callers may not)."""
    if not (isinstance(sensor.full_well_e, (int, float)) and math.isfinite(sensor.full_well_e)
            and sensor.full_well_e > 0):
        raise SensorError(f"sensor.full_well_e = {sensor.full_well_e!r} must be a number of electrons > 0")
    if not isinstance(sensor.bit_depth, int) or not 8 <= sensor.bit_depth <= 16:
        raise SensorError(f"sensor.bit_depth = {sensor.bit_depth!r} must be a whole number in 8..16")
    if not 0 <= sensor.black_level_dn < 2 ** sensor.bit_depth - 1:
        raise SensorError(f"sensor.black_level_dn = {sensor.black_level_dn!r} must lie in "
                          f"0..{2 ** sensor.bit_depth - 2}")
    if not (isinstance(sensor.peak_qe, (int, float)) and 0 < sensor.peak_qe <= 1):
        raise SensorError(f"sensor.peak_qe = {sensor.peak_qe!r} must lie in (0, 1]")
    check_cfa(sensor.cfa, allow_monochrome=True, allow_extended=True)
    for key in ("read_noise_e", "dark_current_e_per_s", "dsnu_e", "prnu"):
        value = getattr(sensor, key)
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
            raise SensorError(f"sensor.{key} = {value!r} must be a finite number >= 0 (0 switches it off)")
    if not (isinstance(sensor.base_iso, (int, float)) and sensor.base_iso > 0):
        raise SensorError(f"sensor.base_iso = {sensor.base_iso!r} must be > 0")


# ----------------------------------------------------------------------------- patterns
@functools.lru_cache(maxsize=4)
def _unit_patterns(seed: int, height: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.Generator(np.random.SFC64(np.random.SeedSequence(int(seed), spawn_key=(0x5E45,))))
    patterns = []
    for _ in range(2):
        z = rng.standard_normal((height, width), dtype=np.float32)
        z64 = z.astype(np.float64)
        mean, std = z64.mean(), z64.std()
        z = ((z64 - mean) / (std if std > 0 else 1.0)).astype(np.float32)
        z.setflags(write=False)
        patterns.append(z)
    return patterns[0], patterns[1]


@functools.lru_cache(maxsize=4)
def _scaled_patterns(seed: int, height: int, width: int, prnu: float, dsnu_e: float):
    prnu_unit, dsnu_unit = _unit_patterns(seed, height, width)
    gain = None
    if prnu > 0:
        gain = np.maximum(np.float32(1.0) + np.float32(prnu) * prnu_unit, np.float32(0.0))
        gain.setflags(write=False)
    offset = None
    if dsnu_e > 0:
        offset = np.float32(dsnu_e) * dsnu_unit
        offset.setflags(write=False)
    return gain, offset


def fixed_patterns(seed: int, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The sensor's fixed-pattern noise in unit form: (PRNU, DSNU) standard patterns.

    Each is white Gaussian noise normalised to zero mean and unit standard deviation over
    the frame, so ``1 + prnu·P`` has spatial std exactly ``prnu`` and ``dsnu_e·D`` exactly
    ``dsnu_e`` electrons. Drawn from ``seed`` (the same camera always has the same
    pattern) and cached per seed and shape; the arrays are read-only.

    Parameters
    ----------
    seed : int
        ``sensor.seed``.
    shape : (int, int)
        (height, width) in pixels.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        float32 (H, W) PRNU and DSNU unit patterns.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §8 (DSNU and PRNU as spatial standard deviations).
    """
    return _unit_patterns(int(seed), int(shape[0]), int(shape[1]))


# ----------------------------------------------------------------------------- noise chain
def simulate_frame(
    rate: np.ndarray,
    sensor: "SensorSection",
    *,
    exposure_s: float,
    gain: float,
    frame_seed: int,
    shot_noise_method: str = "hybrid",
    workers: int | None = None,
) -> tuple[np.ndarray, dict]:
    """The EMVA 1288 chain from mean photo-electron rate to digital numbers.

    Per pixel: ``n = Poisson(rate·t·(1 + PRNU) + I_d·t)`` (if shot noise is on) →
    ``+ DSNU`` → ``min(·, full well)`` → ``+ N(0, σ_read²)`` → ``× K`` → ``+ black`` →
    round → clip to [0, 2^bits − 1].

    With ``shot_noise_method = "hybrid"`` the Poisson draw is exact below
    :data:`HYBRID_POISSON_BELOW_E` electrons and within reach of the full well, and the
    normal approximation N(μ, μ) elsewhere; where the well cannot clip, shot and read noise
    are drawn together as one N(μ, μ + σ_read²), which is exact for that approximation.

    Parameters
    ----------
    rate : numpy.ndarray
        (H, W) mean photo-electron rate of each pixel (e⁻/s), vignetting included.
    sensor : SensorSection
        Noise parameters, bit depth, black level, full well, seed.
    exposure_s : float
        Exposure time t (s).
    gain : float
        System gain K (DN/e⁻).
    frame_seed : int
        Seed of the temporal noise.
    shot_noise_method : {"hybrid", "poisson"}
        See :data:`SHOT_NOISE_METHODS`.
    workers : int, optional
        Threads.

    Returns
    -------
    (numpy.ndarray, dict)
        uint16 (H, W) mosaic, and per-sub-stage CPU seconds summed over threads.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2 (the linear model and its noise sources).
    .. [2] Farrell, Catrysse & Wandell (2012), ISETCam shot-noise approximation.
    """
    if shot_noise_method not in SHOT_NOISE_METHODS:
        raise SensorError(f"shot_noise_method {shot_noise_method!r}; valid: {', '.join(SHOT_NOISE_METHODS)}")
    if not (isinstance(frame_seed, (int, np.integer)) and frame_seed >= 0):
        raise SensorError(f"frame seed {frame_seed!r} must be a whole number >= 0")
    if not (math.isfinite(exposure_s) and exposure_s > 0):
        raise SensorError(f"exposure time {exposure_s!r} s must be a finite number > 0")
    height, width = rate.shape
    prnu_gain, dsnu_offset = _scaled_patterns(int(sensor.seed), height, width,
                                              float(sensor.prnu), float(sensor.dsnu_e))
    chain = _Chain.of(sensor, exposure_s, gain, dsnu_offset)
    electrons = _SHOT_NOISE[shot_noise_method] if sensor.shot_noise else _electrons_without_shot_noise
    out = np.empty((height, width), dtype=np.uint16)

    def work(index_span):
        index, (r0, r1) = index_span
        times = dict.fromkeys(_STAGES, 0.0)
        t0 = time.perf_counter()
        rng = np.random.Generator(np.random.SFC64(np.random.SeedSequence(int(frame_seed), spawn_key=(index,))))
        lam = rate[r0:r1].ravel() * chain.t
        if prnu_gain is not None:
            lam *= prnu_gain[r0:r1].ravel()
        if chain.dark_e > 0:
            lam += chain.dark_e
        dsnu = None if dsnu_offset is None else dsnu_offset[r0:r1].ravel()
        t1 = time.perf_counter()
        times["signal"] += t1 - t0
        e = electrons(lam, dsnu, chain, rng)
        t2 = time.perf_counter()
        times["shot_read_noise"] += t2 - t1
        out[r0:r1] = _digitise(e, chain).reshape(r1 - r0, width)
        times["adc"] += time.perf_counter() - t2
        return times

    results = run_chunks(work, list(enumerate(row_chunks(height, width))), workers_for(workers))
    stage_cpu = {key: float(sum(r[key] for r in results)) for key in _STAGES}
    return out, stage_cpu


#: The chain's sub-stages, timed per chunk: mean signal, shot and read noise, the ADC.
_STAGES = ("signal", "shot_read_noise", "adc")


@dataclass(frozen=True)
class _Chain:
    """The chain's constants for one frame, in float32 as the per-pixel arithmetic uses them."""

    t: np.float32
    dark_e: np.float32
    full_well: np.float32
    read_var: np.float32
    read_sd: np.float32
    k: np.float32
    black: np.float32
    white: np.float32
    unclipped_below: np.float32
    poisson_cap: np.float32

    @classmethod
    def of(cls, sensor: "SensorSection", exposure_s: float, gain: float, dsnu_offset: np.ndarray | None) -> "_Chain":
        dsnu_reach = 0.0 if dsnu_offset is None else float(np.abs(dsnu_offset).max())
        return cls(
            t=np.float32(exposure_s),
            dark_e=np.float32(sensor.dark_current_e_per_s * exposure_s),
            full_well=np.float32(sensor.full_well_e),
            read_var=np.float32(sensor.read_noise_e ** 2),
            read_sd=np.float32(sensor.read_noise_e),
            k=np.float32(gain),
            black=np.float32(sensor.black_level_dn),
            white=np.float32(2 ** sensor.bit_depth - 1),
            # means below this cannot reach the full well (7 σ of shot noise plus the largest DSNU)
            unclipped_below=np.float32(sensor.full_well_e - dsnu_reach - 7.0 * math.sqrt(sensor.full_well_e)),
            # numpy's Poisson sampler refuses λ ≳ 1e19; anything that large clips at full well anyway
            poisson_cap=np.float32(4 * sensor.full_well_e + 1e6),
        )


def _well_and_read_noise(e: np.ndarray, dsnu: np.ndarray | None, chain: _Chain, rng) -> np.ndarray:
    """Electrons after shot noise → + DSNU → clipped at the full well → + read noise (in place)."""
    if dsnu is not None:
        e += dsnu
    np.minimum(e, chain.full_well, out=e)
    if chain.read_sd > 0:
        e += chain.read_sd * rng.standard_normal(e.size, dtype=np.float32)
    return e


def _electrons_without_shot_noise(lam: np.ndarray, dsnu, chain: _Chain, rng) -> np.ndarray:
    """``sensor.shot_noise = false``: the mean signal, then DSNU, the well and read noise."""
    return _well_and_read_noise(lam.copy(), dsnu, chain, rng)


def _electrons_poisson(lam: np.ndarray, dsnu, chain: _Chain, rng) -> np.ndarray:
    """Exact Poisson shot noise everywhere (``shot_noise_method = "poisson"``)."""
    e = rng.poisson(np.minimum(lam, chain.poisson_cap)).astype(np.float32)
    return _well_and_read_noise(e, dsnu, chain, rng)


def _electrons_hybrid(lam: np.ndarray, dsnu, chain: _Chain, rng) -> np.ndarray:
    """One normal draw N(μ, μ + σ_read²) for shot and read noise where the well cannot clip;
    exact Poisson below :data:`HYBRID_POISSON_BELOW_E` and N(μ, μ), the well, then read noise
    within reach of the full well."""
    z = rng.standard_normal(lam.size, dtype=np.float32)
    e = lam + chain.read_var if chain.read_var > 0 else lam.copy()
    np.sqrt(e, out=e)
    e *= z
    e += lam
    if dsnu is not None:
        e += dsnu
    special = np.flatnonzero((lam < HYBRID_POISSON_BELOW_E) | (lam >= chain.unclipped_below))
    if special.size:
        sl = lam[special]
        small = sl < HYBRID_POISSON_BELOW_E
        shot = np.empty_like(sl)
        shot[small] = rng.poisson(sl[small])
        big = ~small
        if big.any():
            sb = sl[big]
            shot[big] = sb + np.sqrt(sb) * rng.standard_normal(sb.size, dtype=np.float32)
        e[special] = _well_and_read_noise(shot, None if dsnu is None else dsnu[special], chain, rng)
    return e


#: Each of :data:`SHOT_NOISE_METHODS`' electrons: mean signal (+ DSNU) → electrons read out.
_SHOT_NOISE = {"poisson": _electrons_poisson, "hybrid": _electrons_hybrid}


def _digitise(e: np.ndarray, chain: _Chain) -> np.ndarray:
    """Electrons → DN: × K, + black level, rounded, clipped to [0, 2^bits − 1] (in place)."""
    e *= chain.k
    e += chain.black
    np.rint(e, out=e)
    np.clip(e, 0, chain.white, out=e)
    return e
