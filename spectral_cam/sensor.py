"""Image sensor: band radiance → irradiance → photons → electrons → noise → ADC → RAW.

The stages, each a plain function so tests and other programs can use them alone:

1. camera equation (:func:`camera_equation_irradiance`): band irradiance on the sensor
   ``E_b = π·L_b·T(λ_b) / (1 + 4·N_w²) · cos⁴θ`` (W·m⁻²), from the band integrals of
   radiance ``L_b`` (W·m⁻²·sr⁻¹) that :func:`spectral_cam.render.render` returns;
2. photons and electrons (:func:`band_weights`, :func:`electron_rates`):
   ``μ_e,c = Σ_b E_b·A_pix·t·(λ_b·10⁻⁹ / (h·c))·η_c(λ_b)`` — no extra Δλ, ``L_b`` is
   already a band integral — with the quantum efficiency ``η_c ∝ S_c(λ)/λ`` of the
   measured per-energy curves (:func:`quantum_efficiency`), sampled through the CFA;
3. the EMVA 1288 linear chain (:func:`simulate_frame`): Poisson(photo-signal·(1 + PRNU)
   + I_d·t) → + DSNU offset → clip at full well → + Gaussian read noise → × K → + black
   level → round → clip to [0, 2^bits − 1];
4. :func:`expose` composes them into a :class:`~spectral_cam.raw.RawImage` with the
   metadata a DNG and an ISP need (ColorMatrix1, AsShotNeutral, NoiseProfile, K, ...).

Fixed patterns (PRNU, DSNU) come from ``sensor.seed`` and are cached per seed and shape;
temporal noise comes from the frame seed. Every noise term can be switched off
(``sensor.shot_noise = false``, or a zero ``read_noise_e`` / ``dark_current_e_per_s`` /
``dsnu_e`` / ``prnu``).

References
----------
.. [1] EMVA Standard 1288, Release 4.0 Linear (2021). Standard for Characterization of
   Image Sensors and Cameras, §2 (the linear camera model), §3 (the noise model).
.. [2] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 17 (image illuminance,
   E = π·L·T / (4·N_w²) in the paraxial limit, and the exact 1/(1 + 4·N_w²) form; cos⁴ law).
.. [3] Janesick, J. R. (2007). Photon Transfer: DN → λ. SPIE Press, ch. 2–4.
.. [4] Farrell, J. E., Catrysse, P. B., & Wandell, B. A. (2012). Digital camera simulation.
   Applied Optics 51(4), A80–A90 (ISETCam; normal approximation of shot noise for large
   electron counts).
.. [5] Adobe (2023). DNG Specification 1.7.1.0, tag NoiseProfile (51041).
"""

from __future__ import annotations

import functools
import math
import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.constants as const

from . import spectra
from .errors import ConfigError, SensorError
from .raw import RawImage

if TYPE_CHECKING:  # pragma: no cover
    from .render import SpectralImage
    from .scene import SceneConfig, SensorSection

__all__ = [
    "expose",
    "cfa_layout",
    "quantum_efficiency",
    "camera_equation_irradiance",
    "photons_per_joule",
    "band_weights",
    "electron_rates",
    "max_channel_rates",
    "system_gain",
    "saturation_electrons",
    "dark_noise_electrons",
    "noise_profile",
    "fixed_patterns",
    "auto_exposure_time",
    "simulate_frame",
    "validate_radiance",
    "signal_model",
    "SignalModel",
    "film_curves",
    "expected_electrons",
    "CAMERA_CHANNELS",
    "FILM_REFERENCE_NM",
    "CFA_LAYOUTS",
    "SHOT_NOISE_METHODS",
    "HYBRID_POISSON_BELOW_E",
]

#: Channel index (0 = r, 1 = g, 2 = b) of each pixel of the 2×2 Bayer tile, row by row
#: from the top-left pixel.
CFA_LAYOUTS = {
    "RGGB": ((0, 1), (1, 2)),
    "BGGR": ((2, 1), (1, 0)),
    "GRBG": ((1, 0), (2, 1)),
    "GBRG": ((1, 2), (0, 1)),
}
#: ``"poisson"``: exact Poisson shot noise everywhere; ``"hybrid"``: exact Poisson below
#: :data:`HYBRID_POISSON_BELOW_E` mean electrons and near full well, the normal
#: approximation N(μ, μ) elsewhere (mean and variance exact; the Poisson skewness 1/√μ ≤ 0.1
#: and excess kurtosis 1/μ ≤ 0.01 are dropped; ISETCam switches at 25 e⁻).
SHOT_NOISE_METHODS = ("hybrid", "poisson")
#: Mean electron count below which the hybrid method draws exact Poisson numbers.
HYBRID_POISSON_BELOW_E = 100.0
#: Pixels per work unit of the chunked, threaded stages (fixed so results do not depend
#: on the number of threads).
CHUNK_PIXELS = 1 << 16
#: Row step of the pixel sample the 99th-percentile auto exposure looks at when a frame
#: has more than :data:`_AUTO_FULL_BELOW` pixels (whole rows: contiguous in memory).
_AUTO_STEP = 8
_AUTO_FULL_BELOW = 1 << 21


# ----------------------------------------------------------------------------- small pieces
def cfa_layout(cfa: str) -> tuple[tuple[int, int], tuple[int, int]] | None:
    """Channel indices of the 2×2 Bayer tile, or None for a monochrome sensor.

    Parameters
    ----------
    cfa : str
        ``"RGGB"``, ``"BGGR"``, ``"GRBG"``, ``"GBRG"`` (read row by row from the top-left
        pixel) or ``"none"``.

    Returns
    -------
    tuple or None
        ``((c00, c01), (c10, c11))`` with 0 = r, 1 = g, 2 = b.

    Raises
    ------
    SensorError
        For any other string.

    References
    ----------
    .. [1] Bayer, B. E. (1976). Color imaging array. US patent 3,971,065.
    """
    if cfa == "none":
        return None
    if cfa not in CFA_LAYOUTS:
        raise SensorError(f"unknown CFA pattern {cfa!r}; valid: {', '.join(CFA_LAYOUTS)}, none")
    return CFA_LAYOUTS[cfa]


def photons_per_joule(wavelength_nm) -> np.ndarray:
    """Photons per joule at a wavelength, λ / (h·c) (J⁻¹).

    Parameters
    ----------
    wavelength_nm : array_like
        Vacuum wavelength (nm).

    References
    ----------
    .. [1] CODATA 2018 values of h and c (scipy.constants).
    """
    return np.asarray(wavelength_nm, dtype=float) * 1e-9 / (const.h * const.c)


def camera_equation_irradiance(band_radiance, *, working_f_number: float, transmission=1.0,
                               cos4=1.0) -> np.ndarray:
    """Band irradiance on the sensor from band radiance in object space.

    ``E_b = π·L_b·T(λ_b) / (1 + 4·N_w²) · cos⁴θ``.

    Parameters
    ----------
    band_radiance : array_like
        Band integrals of radiance L_b (W·m⁻²·sr⁻¹).
    working_f_number : float
        N_w = N·(1 + m) (dimensionless).
    transmission : array_like
        Lens (and filter) transmission T(λ_b) in [0, 1], broadcast against the bands.
    cos4 : array_like
        Natural vignetting factor cos⁴θ of each pixel (1 on axis), broadcast.

    Returns
    -------
    numpy.ndarray
        Band irradiance E_b (W·m⁻²).

    References
    ----------
    .. [1] Ray (2002), Applied Photographic Optics, ch. 17 (image illuminance).
    .. [2] EMVA 1288 Release 4.0, §3.1 (irradiance on the sensor from the f-number).
    """
    if not (math.isfinite(working_f_number) and working_f_number > 0):
        raise SensorError(f"working f-number {working_f_number!r} must be a finite number > 0")
    return (np.pi * np.asarray(band_radiance, dtype=float) * np.asarray(transmission, dtype=float)
            / (1.0 + 4.0 * working_f_number ** 2) * np.asarray(cos4, dtype=float))


def quantum_efficiency(model: str, wavelengths_nm, *, peak_qe: float, monochrome: bool = False
                       ) -> np.ndarray:
    """Quantum efficiency of each channel at band centres.

    Measured curves are per-energy responsivities S_c(λ), so η_c(λ) ∝ S_c(λ)/λ, scaled so
    that the maximum over all channels and tabulated wavelengths is ``peak_qe``; zero
    outside the table. ``model = "ideal"`` is flat: η = peak_qe everywhere.

    Parameters
    ----------
    model : str
        ``"ideal"`` or a measured camera name (:func:`spectral_cam.spectra.camera_names`).
    wavelengths_nm : array_like
        Band centres (nm), shape (B,).
    peak_qe : float
        Largest quantum efficiency, in (0, 1] (electrons per photon).
    monochrome : bool
        One channel (only with ``model = "ideal"``).

    Returns
    -------
    numpy.ndarray
        (B, 3) — or (B, 1) when monochrome — electrons per photon.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1 (η, the total quantum efficiency).
    .. [2] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §5.4.2 (per-energy camera curves).
    """
    if not (isinstance(peak_qe, (int, float)) and not isinstance(peak_qe, bool)
            and 0 < peak_qe <= 1):
        raise SensorError(f"peak quantum efficiency {peak_qe!r} must lie in (0, 1]")
    wl = np.asarray(wavelengths_nm, dtype=float)
    if model == "ideal":
        return np.full((wl.size, 1 if monochrome else 3), float(peak_qe))
    if monochrome:
        raise SensorError(f"a monochrome sensor needs model 'ideal', not {model!r}")
    try:
        msds = spectra.camera_sensitivities(model)
    except ConfigError as exc:
        raise SensorError(str(exc)) from None
    table_wl = np.asarray(msds.wavelengths, dtype=float)
    eta = np.asarray(msds.values, dtype=float) / table_wl[:, None]
    eta *= peak_qe / eta.max()
    return np.stack([np.interp(wl, table_wl, eta[:, c], left=0.0, right=0.0)
                     for c in range(eta.shape[1])], axis=-1)


def band_weights(wavelengths_nm, qe, *, working_f_number: float, pixel_area_m2: float,
                 transmission=1.0) -> np.ndarray:
    """Electrons per second per unit band radiance, per band and channel, on axis.

    ``w_b,c = π·T_b / (1 + 4·N_w²) · A_pix · λ_b·10⁻⁹/(h·c) · η_c(λ_b)``, so that
    ``μ_e,c = t · cos⁴θ · Σ_b L_b·w_b,c``.

    Parameters
    ----------
    wavelengths_nm : array_like
        Band centres (nm), (B,).
    qe : array_like
        (B, C) quantum efficiency.
    working_f_number : float
        N_w.
    pixel_area_m2 : float
        Pixel area A_pix (m²).
    transmission : array_like
        (B,) or scalar lens × filter transmission.

    Returns
    -------
    numpy.ndarray
        (B, C) in e⁻·s⁻¹ per W·m⁻²·sr⁻¹.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1 eq. (1)–(2) (photons μ_p = A·E·t·λ/(h·c)).
    """
    if not (math.isfinite(pixel_area_m2) and pixel_area_m2 > 0):
        raise SensorError(f"pixel area {pixel_area_m2!r} m² must be > 0")
    wl = np.asarray(wavelengths_nm, dtype=float)
    trans = np.broadcast_to(np.asarray(transmission, dtype=float), wl.shape)
    irradiance_per_radiance = camera_equation_irradiance(np.ones_like(wl), working_f_number=working_f_number,
                                                         transmission=trans)
    photons = irradiance_per_radiance * pixel_area_m2 * photons_per_joule(wl)
    return photons[:, None] * np.asarray(qe, dtype=float)


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
    shot noise S·x already counts: O takes the read noise alone. (DESIGN.md's
    O = (K²σ_d² + 1/12)/(W − B)² with σ_d² = σ_read² + I_d·t counts the dark-current shot
    noise twice; the difference is K²·I_d·t/(W − B)².)

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
    cfa_layout(sensor.cfa)
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


# ----------------------------------------------------------------------------- validation
def validate_radiance(radiance: "SpectralImage", sensor: "SensorSection") -> None:  # noqa: C901
    """Check a SpectralImage's shape against the sensor (cheap; values are checked while
    they are integrated).

    Raises
    ------
    SensorError
        For a wrong shape, a band count that does not match the wavelengths, or
        wavelengths that are not finite and positive.

    References
    ----------
    .. [1] The SpectralImage contract of :mod:`spectral_cam.render`.
    """
    data = getattr(radiance, "data", None)
    if not isinstance(data, np.ndarray) or data.ndim != 3:
        shape = getattr(data, "shape", None)
        raise SensorError(
            f"radiance.data must be an (H, W, B) array of band radiances (W·m⁻²·sr⁻¹); got shape {shape}")
    if not np.issubdtype(data.dtype, np.floating):
        raise SensorError(f"radiance.data must be float32 or float64, not {data.dtype}")
    height, width, bands = data.shape
    if (height, width) != (sensor.height_px, sensor.width_px):
        raise SensorError(
            f"radiance is {width}×{height} pixels but the sensor is {sensor.width_px}×{sensor.height_px}; "
            "set sensor.width_px / sensor.height_px to the radiance's size")
    channels = getattr(radiance, "channels", None)
    if channels:
        if len(channels) != bands:
            raise SensorError(f"radiance has {bands} channels but names {len(channels)}: {tuple(channels)}")
        return
    wl = np.asarray(radiance.wavelengths_nm, dtype=float)
    if wl.shape != (bands,):
        raise SensorError(f"radiance has {bands} bands but {wl.size} wavelengths; they must match")
    if not (np.all(np.isfinite(wl)) and np.all(wl > 0)):
        raise SensorError("radiance.wavelengths_nm must be finite, positive band centres in nm")
    edges = np.asarray(radiance.band_edges_nm, dtype=float)
    if edges.shape != (bands + 1,) or not np.all(np.diff(edges) > 0):
        raise SensorError(f"radiance.band_edges_nm must hold {bands + 1} increasing band edges in nm; "
                          f"got shape {edges.shape}")
    if bands == 0:
        raise SensorError("radiance has no bands")


def _bad_value_message(block: np.ndarray, row0: int) -> str:
    finite = np.isfinite(block)
    if not finite.all():
        y, x, b = np.argwhere(~finite)[0]
        return (f"radiance has a non-finite value ({block[y, x, b]}) at pixel (row {row0 + y}, "
                f"column {x}), band {b}; band radiances must be finite numbers >= 0 W·m⁻²·sr⁻¹")
    negative = np.argwhere(block < 0)
    if len(negative):
        y, x, b = negative[0]
        return (f"radiance is negative ({block[y, x, b]:g}) at pixel (row {row0 + y}, column {x}), band {b}; "
                "band radiances must be finite numbers >= 0 W·m⁻²·sr⁻¹")
    # every value is finite and >= 0, yet the electron rate overflowed float32
    y, x, b = np.unravel_index(np.argmax(block), block.shape)
    return (f"radiance {block[y, x, b]:g} W·m⁻²·sr⁻¹ at pixel (row {row0 + y}, column {x}), band {b} is so "
            "large that the electron rate overflows float32; physical scenes stay many orders of magnitude "
            "below this")


# ----------------------------------------------------------------------------- integration
def _workers(workers: int | None) -> int:
    if workers is not None:
        return max(1, int(workers))
    try:
        return max(1, min(len(os.sched_getaffinity(0)), 8))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, min(os.cpu_count() or 1, 8))


def _row_chunks(height: int, width: int) -> list[tuple[int, int]]:
    rows = max(2, (CHUNK_PIXELS // max(width, 1)) // 2 * 2)
    return [(r, min(r + rows, height)) for r in range(0, height, rows)]


def _run(func, items, workers: int):
    if workers == 1 or len(items) == 1:
        return [func(item) for item in items]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(func, items))


def electron_rates(data: np.ndarray, weights: np.ndarray, *, cfa: str, cos4: np.ndarray | None = None,
                   workers: int | None = None) -> np.ndarray:
    """Mean photo-electron rate of every pixel through its CFA filter (e⁻/s).

    ``rate = cos⁴θ · Σ_b L_b · w_b,c(pixel)``, computed for each pixel's own channel only
    (one dot product per pixel); checks the radiance for NaN, ±Inf and negative values
    while reading it (one pass over the cube, chunked and threaded).

    Parameters
    ----------
    data : numpy.ndarray
        (H, W, B) band radiances (W·m⁻²·sr⁻¹).
    weights : numpy.ndarray
        (B, C) from :func:`band_weights`.
    cfa : str
        CFA pattern or ``"none"`` (then C must be 1).
    cos4 : numpy.ndarray, optional
        (H, W) natural vignetting; None for none.
    workers : int, optional
        Threads (default: the CPUs this process may use, at most 8).

    Returns
    -------
    numpy.ndarray
        float32 (H, W) rate through each pixel's filter.

    Raises
    ------
    SensorError
        If the radiance holds a NaN, an infinity or a negative value.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1 (μ_e = η·μ_p).
    """
    layout = cfa_layout(cfa)
    height, width, bands = data.shape
    weights = np.asarray(weights, dtype=np.float32)
    if weights.ndim != 2 or weights.shape[0] != bands:
        raise SensorError(f"weights must be (bands={bands}, channels); got {weights.shape}")
    if layout is None and weights.shape[1] != 1:
        raise SensorError("a monochrome sensor (cfa = 'none') needs one QE channel")
    vectors = [np.ascontiguousarray(weights[:, c]) for c in range(weights.shape[1])]
    rate = np.empty((height, width), dtype=np.float32)

    def work(span):
        r0, r1 = span
        block = data[r0:r1]
        if block.dtype != np.float32:
            block = block.astype(np.float32)
        if not block.min() >= 0:  # also catches NaN
            raise SensorError(_bad_value_message(block, r0))
        if layout is None:
            np.matmul(block, vectors[0], out=rate[r0:r1])
        else:
            for a in (0, 1):
                for b in (0, 1):
                    np.matmul(block[a::2, b::2], vectors[layout[a][b]], out=rate[r0 + a:r1:2, b::2])
        if not np.isfinite(rate[r0:r1]).all():  # an infinity (Inf·w = Inf, Inf·0 = NaN)
            raise SensorError(_bad_value_message(block, r0))
        if cos4 is not None:
            rate[r0:r1] *= cos4[r0:r1]

    _run(work, _row_chunks(height, width), _workers(workers))
    return rate


def _row_dot(x: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """``x @ vector`` for a tall (n, B) float32 array, as a stack of small products (one
    huge BLAS gemv wakes OpenBLAS's thread pool, which on small machines costs ~10×)."""
    n, bands = x.shape
    out = np.empty(n, dtype=np.float32)
    step = 1024
    full = n // step * step
    if full:
        np.matmul(x[:full].reshape(-1, step, bands), vector, out=out[:full].reshape(-1, step))
    if n > full:
        np.matmul(x[full:], vector, out=out[full:])
    return out


def max_channel_rates(data: np.ndarray, weights: np.ndarray, *, cos4: np.ndarray | None = None,
                      mask: np.ndarray | None = None, step: int = 1) -> np.ndarray:
    """Largest channel's photo-electron rate (e⁻/s) at the pixels of a mask or a grid.

    Parameters
    ----------
    data : numpy.ndarray
        (H, W, B) band radiances (W·m⁻²·sr⁻¹), already validated.
    weights : numpy.ndarray
        (B, C) from :func:`band_weights`.
    cos4 : numpy.ndarray, optional
        (H, W) natural vignetting.
    mask : numpy.ndarray, optional
        Boolean (H, W): use these pixels; otherwise every pixel of every ``step``-th row.
    step : int
        Row step without a mask (1 = every pixel).

    Returns
    -------
    numpy.ndarray
        float32 1-D ``max_c cos⁴θ·Σ_b L_b·w_b,c`` of the selected pixels.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1.
    """
    weights = np.asarray(weights, dtype=np.float32)
    vectors = [np.ascontiguousarray(weights[:, c]) for c in range(weights.shape[1])]
    if mask is not None:
        selected = data[mask].astype(np.float32, copy=False)
        best = _row_dot(selected, vectors[0])
        for vector in vectors[1:]:
            np.maximum(best, _row_dot(selected, vector), out=best)
        if cos4 is not None:
            best *= cos4[mask]
        return best
    # Whole rows (contiguous in memory), each row's channels while it sits in cache.
    rows = range(0, data.shape[0], step)
    best = np.empty((len(rows), data.shape[1]), dtype=np.float32)
    for i, row in enumerate(rows):
        line = data[row]
        if line.dtype != np.float32:
            line = line.astype(np.float32)
        np.matmul(line, vectors[0], out=best[i])
        for vector in vectors[1:]:
            np.maximum(best[i], np.matmul(line, vector), out=best[i])
    if cos4 is not None:
        best *= cos4[::step]
    return best.ravel()


def auto_exposure_time(reference_rates: np.ndarray, *, saturation_e: float, fraction: float,
                       dark_current_e_per_s: float = 0.0, percentile: float | None = 99.0
                       ) -> tuple[float, float]:
    """Exposure time that puts the brightest relevant region at a fraction of saturation.

    The reference rate r is the mean of ``reference_rates`` (the white patch's pixels)
    when ``percentile`` is None, else their ``percentile``-th percentile. Then
    ``t = fraction·saturation_e / (r + I_d)``.

    Parameters
    ----------
    reference_rates : numpy.ndarray
        Max-channel photo-electron rates (e⁻/s) of the reference pixels
        (:func:`max_channel_rates`).
    saturation_e : float
        Electrons at saturation.
    fraction : float
        Target fraction of saturation, in (0, 1].
    dark_current_e_per_s : float
        Dark current I_d (e⁻/s), which fills the well too.
    percentile : float or None
        Percentile of the rates to use; None for their mean.

    Returns
    -------
    (float, float)
        Exposure time (s) and the reference rate r (e⁻/s).

    Raises
    ------
    SensorError
        If the reference region receives no light.

    References
    ----------
    .. [1] ISO 12232:2019, Photography — Digital still cameras — Determination of exposure
       index (saturation-based exposure).
    """
    rates = np.asarray(reference_rates, dtype=np.float64).ravel()
    if rates.size == 0:
        raise SensorError("auto exposure needs at least one reference pixel")
    reference = float(rates.mean() if percentile is None else np.percentile(rates, percentile))
    if not reference > 0:
        raise SensorError("exposure.time_s = 'auto' found no light in the reference region; "
                          "give exposure.time_s in seconds")
    return fraction * saturation_e / (reference + dark_current_e_per_s), reference


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
    t = np.float32(exposure_s)
    dark_e = np.float32(sensor.dark_current_e_per_s * exposure_s)
    full_well = np.float32(sensor.full_well_e)
    read_var = np.float32(sensor.read_noise_e ** 2)
    read_sd = np.float32(sensor.read_noise_e)
    k = np.float32(gain)
    black = np.float32(sensor.black_level_dn)
    white = np.float32(2 ** sensor.bit_depth - 1)
    dsnu_reach = 0.0 if dsnu_offset is None else float(np.abs(dsnu_offset).max())
    # Means below this cannot reach the full well (7 σ of shot noise plus the largest DSNU).
    unclipped_below = np.float32(sensor.full_well_e - dsnu_reach - 7.0 * math.sqrt(sensor.full_well_e))
    exact = shot_noise_method == "poisson"
    out = np.empty((height, width), dtype=np.uint16)
    chunks = _row_chunks(height, width)
    timing_keys = ("signal", "shot_read_noise", "adc")

    def work(index_span):
        index, (r0, r1) = index_span
        times = dict.fromkeys(timing_keys, 0.0)
        t0 = time.perf_counter()
        rng = np.random.Generator(np.random.SFC64(np.random.SeedSequence(int(frame_seed), spawn_key=(index,))))
        lam = rate[r0:r1].ravel() * t
        if prnu_gain is not None:
            lam *= prnu_gain[r0:r1].ravel()
        if dark_e > 0:
            lam += dark_e
        dsnu = None if dsnu_offset is None else dsnu_offset[r0:r1].ravel()
        t1 = time.perf_counter()
        times["signal"] += t1 - t0
        if not sensor.shot_noise:
            e = lam.copy()
            if dsnu is not None:
                e += dsnu
            np.minimum(e, full_well, out=e)
            if read_sd > 0:
                e += read_sd * rng.standard_normal(e.size, dtype=np.float32)
        elif exact:
            # numpy's Poisson sampler refuses λ ≳ 1e19; anything that large clips at full well anyway
            e = rng.poisson(np.minimum(lam, np.float32(4 * sensor.full_well_e + 1e6))).astype(np.float32)
            if dsnu is not None:
                e += dsnu
            np.minimum(e, full_well, out=e)
            if read_sd > 0:
                e += read_sd * rng.standard_normal(e.size, dtype=np.float32)
        else:
            # Main path: one normal draw for shot + read noise where the well cannot clip.
            z = rng.standard_normal(lam.size, dtype=np.float32)
            e = lam + read_var if read_var > 0 else lam.copy()
            np.sqrt(e, out=e)
            e *= z
            e += lam
            if dsnu is not None:
                e += dsnu
            special = np.flatnonzero((lam < HYBRID_POISSON_BELOW_E) | (lam >= unclipped_below))
            if special.size:
                sl = lam[special]
                small = sl < HYBRID_POISSON_BELOW_E
                shot = np.empty_like(sl)
                shot[small] = rng.poisson(sl[small])
                big = ~small
                if big.any():
                    sb = sl[big]
                    shot[big] = sb + np.sqrt(sb) * rng.standard_normal(sb.size, dtype=np.float32)
                if dsnu is not None:
                    shot += dsnu[special]
                np.minimum(shot, full_well, out=shot)
                if read_sd > 0:
                    shot += read_sd * rng.standard_normal(shot.size, dtype=np.float32)
                e[special] = shot
        t2 = time.perf_counter()
        times["shot_read_noise"] += t2 - t1
        e *= k
        e += black
        np.rint(e, out=e)
        np.clip(e, 0, white, out=e)
        out[r0:r1] = e.reshape(r1 - r0, width)
        times["adc"] += time.perf_counter() - t2
        return times

    results = _run(work, list(enumerate(chunks)), _workers(workers))
    stage_cpu = {key: float(sum(r[key] for r in results)) for key in timing_keys}
    return out, stage_cpu


# ----------------------------------------------------------------------------- caches
@functools.lru_cache(maxsize=4)
def _cos4(focal_length_mm: float, f_number: float, focus_distance_m: float, pitch_um: float,
          width: int, height: int) -> np.ndarray:
    from .optics import ThinLens

    lens = ThinLens(focal_length_m=focal_length_mm * 1e-3, f_number=f_number,
                    focus_distance_m=focus_distance_m, sensor_width_m=width * pitch_um * 1e-6,
                    sensor_height_m=height * pitch_um * 1e-6, width_px=width, height_px=height)
    cos4 = (lens.pixel_angles_cos() ** 4).astype(np.float32)
    cos4.setflags(write=False)
    return cos4


@functools.lru_cache(maxsize=32)
def _transmission_at(specs: tuple, wavelengths: tuple) -> np.ndarray:
    wl = np.asarray(wavelengths)
    curve = np.ones_like(wl)
    for spec in specs:
        sd = spectra.transmission(spec)
        if sd is not None:
            curve = curve * spectra.sample(sd, wl)
    return curve


@functools.lru_cache(maxsize=32)
def _illuminant_bands(spd: str, edges: tuple) -> np.ndarray:
    wl, irradiance = spectra.absolute_irradiance(spd, 1.0)
    centres = 0.5 * (np.asarray(edges[:-1]) + np.asarray(edges[1:]))
    return spectra.band_integrals(irradiance, wl, spectra.BandGrid(tuple(centres), edges))


@functools.lru_cache(maxsize=32)
def _colour_matrix(model: str, specs: tuple, illuminant: str = "D65") -> np.ndarray | None:
    from . import calibration

    try:
        return calibration.xyz_to_camera_matrix(model, illuminant, transmission=list(specs))
    except ConfigError:
        return None  # channels without three distinct spectral sensitivities ("ideal")


@functools.lru_cache(maxsize=32)
def _fitted_corrections_cached(model: str, illuminant: str, specs: tuple) -> tuple:
    from . import calibration

    linear = calibration.camera_to_xyz_d65(model, illuminant, transmission=list(specs))
    root = calibration.camera_to_xyz_d65(model, illuminant, method="root_polynomial", transmission=list(specs))
    return np.asarray(linear, dtype=float).tolist(), np.asarray(root.ccm, dtype=float).tolist()


def _fitted_corrections(model: str, illuminant: str, specs: tuple) -> dict:
    """White-balanced camera RGB → XYZ(D65) fitted on the ColorChecker under the scene
    illuminant (3×3 and root-polynomial), for the ISP's ``colour_matrix = "fitted"`` /
    ``"root_polynomial"``; the ISP reads them from ``RawImage.meta`` (it never sees spectra)."""
    linear, root = _fitted_corrections_cached(model, illuminant, specs)
    return {"camera_to_xyz_d65": linear, "camera_to_xyz_d65_root_polynomial": root}


# ----------------------------------------------------------------------------- signal model
#: Reference wavelength of the photon-weighted camera film: a film value times
#: λ_ref/(h·c) is photo-electrons per (s·m²·sr) before the camera equation's geometry.
FILM_REFERENCE_NM = 555.0
#: Channel names of a camera-channel SpectralImage (render.bands = "camera").
CAMERA_CHANNELS = ("camera_r", "camera_g", "camera_b", "X", "Y", "Z")


@dataclass(frozen=True)
class SignalModel:
    """How a radiance image becomes photo-electron rates on this sensor.

    Attributes
    ----------
    weights
        (B, C) e⁻·s⁻¹ per unit input value on axis (band radiance W·m⁻²·sr⁻¹, or camera
        film value).
    cos4
        (H, W) natural vignetting, or None.
    qe
        (B, C) quantum efficiency at the band centres (ones for camera channels, whose
        film already holds η).
    camera_channels
        True when the input holds the photon-weighted camera film channels.
    """

    weights: np.ndarray
    cos4: np.ndarray | None
    qe: np.ndarray
    working_f_number: float
    pixel_area_m2: float
    transmission_specs: tuple
    camera_channels: bool


def film_curves(config: "SceneConfig", wavelengths_nm) -> np.ndarray:
    """Photon-weighted camera curves for a ``specfilm``: η_c(λ)·T(λ)·λ/λ_ref.

    Integrating radiance against them gives, times λ_ref·10⁻⁹/(h·c), the photon-weighted
    channel signal, so a 3-channel render integrates the camera's response exactly (no
    band discretisation); lens transmission and IR cut are inside.

    Parameters
    ----------
    config : SceneConfig
        Uses sensor.model, sensor.peak_qe, lens.transmission, sensor.ir_cut.
    wavelengths_nm : array_like
        Where to tabulate (nm).

    Returns
    -------
    numpy.ndarray
        (n, 3) dimensionless curves.

    References
    ----------
    .. [1] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §5.4.2 (sensor response
       integrated against measured curves).
    """
    wl = np.asarray(wavelengths_nm, dtype=float)
    qe = quantum_efficiency(config.sensor.model, wl, peak_qe=config.sensor.peak_qe)
    transmission = _transmission_at((config.lens.transmission, config.sensor.ir_cut), tuple(wl.tolist()))
    return qe * (transmission * wl / FILM_REFERENCE_NM)[:, None]


def _illuminant_film_response(config: "SceneConfig") -> np.ndarray:
    """Film response (relative) of the three camera channels to the illuminant's white."""
    wl, irradiance = spectra.absolute_irradiance(config.illuminant.spd, 1.0)
    return irradiance @ film_curves(config, wl)


def signal_model(radiance: "SpectralImage", config: "SceneConfig") -> SignalModel:
    """The :class:`SignalModel` of a radiance image (spectral bands or camera channels).

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1 (photons from irradiance, area and time).
    """
    from .optics import ThinLens

    sensor, lens_cfg = config.sensor, config.lens
    lens = ThinLens.from_config(lens_cfg, sensor)
    n_w = lens.working_f_number
    area = (sensor.pixel_pitch_um * 1e-6) ** 2
    trans_specs = (lens_cfg.transmission, sensor.ir_cut)
    cos4 = (_cos4(lens_cfg.focal_length_mm, lens_cfg.f_number, lens_cfg.focus_distance_m,
                  sensor.pixel_pitch_um, sensor.width_px, sensor.height_px) if sensor.vignetting else None)
    channels = getattr(radiance, "channels", None)
    if channels:
        if tuple(channels) != CAMERA_CHANNELS:
            raise SensorError(f"radiance channels {tuple(channels)} are not the camera film's {CAMERA_CHANNELS}")
        if sensor.cfa == "none":
            raise SensorError("camera-channel radiance needs a colour sensor (sensor.cfa != 'none')")
        geometry = float(camera_equation_irradiance(1.0, working_f_number=n_w)) * area
        weights = np.zeros((len(CAMERA_CHANNELS), 3))
        weights[:3, :3] = np.eye(3) * geometry * float(photons_per_joule(FILM_REFERENCE_NM))
        qe = np.zeros_like(weights)
        qe[:3, :3] = np.eye(3)
        return SignalModel(weights, cos4, qe, n_w, area, trans_specs, True)
    wavelengths = np.asarray(radiance.wavelengths_nm, dtype=float)
    transmission = _transmission_at(trans_specs, tuple(wavelengths.tolist()))
    qe = quantum_efficiency(sensor.model, wavelengths, peak_qe=sensor.peak_qe, monochrome=sensor.cfa == "none")
    weights = band_weights(wavelengths, qe, working_f_number=n_w, pixel_area_m2=area, transmission=transmission)
    return SignalModel(weights, cos4, qe, n_w, area, trans_specs, False)


def expected_electrons(radiance: "SpectralImage", config: "SceneConfig", *, exposure_s: float | None = None,
                       white_mask: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """Noise-free photo-electrons of every pixel through its CFA filter, and the exposure.

    Parameters
    ----------
    radiance, config
        As for :func:`expose`.
    exposure_s
        Exposure time (s); default the config's (``"auto"`` resolved as :func:`expose` does).
    white_mask
        Auto-exposure reference, as for :func:`expose`.

    Returns
    -------
    (numpy.ndarray, float)
        float32 (H, W) mean electrons (no dark current) and the exposure time (s).

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1 (μ_e = η·μ_p).
    """
    model = signal_model(radiance, config)
    rate = electron_rates(radiance.data, model.weights, cfa=config.sensor.cfa, cos4=model.cos4)
    if exposure_s is None:
        exposure = config.exposure
        if exposure.time_s != "auto":
            exposure_s = float(exposure.time_s)
        else:
            saturation_e = saturation_electrons(config.sensor, system_gain(config.sensor, exposure.iso))
            if white_mask is not None:
                reference = max_channel_rates(radiance.data, model.weights, cos4=model.cos4, mask=white_mask)
                percentile = None
            else:
                reference = max_channel_rates(radiance.data, model.weights, cos4=model.cos4)
                percentile = 99.0
            exposure_s, _ = auto_exposure_time(reference, saturation_e=saturation_e, fraction=exposure.auto_fraction,
                                               dark_current_e_per_s=config.sensor.dark_current_e_per_s,
                                               percentile=percentile)
    return rate * np.float32(exposure_s), float(exposure_s)


# ----------------------------------------------------------------------------- expose
def expose(
    radiance: "SpectralImage",
    config: "SceneConfig",
    *,
    frame_seed: int | None = None,
    white_mask: np.ndarray | None = None,
    shot_noise_method: str = "hybrid",
    workers: int | None = None,
) -> RawImage:
    """Simulate the sensor's exposure to a spectral radiance image.

    Parameters
    ----------
    radiance : SpectralImage
        (H, W, B) band integrals of radiance (W·m⁻²·sr⁻¹) matching the sensor's size; any
        SpectralImage works, a synthetic uniform one included.
    config : SceneConfig
        Uses ``sensor``, ``lens`` (working f-number, transmission, vignetting geometry),
        ``exposure`` (time or ``"auto"``, ISO, auto_fraction), ``illuminant.spd`` (for
        AsShotNeutral) and ``render.seed`` (the default frame seed).
    frame_seed : int, optional
        Seed of the temporal noise (default ``config.render.seed``).
    white_mask : numpy.ndarray, optional
        Boolean (H, W) white reference for ``exposure.time_s = "auto"``; without it the
        99th percentile of the max-channel electron rate is used.
    shot_noise_method : {"hybrid", "poisson"}
        See :data:`SHOT_NOISE_METHODS`.
    workers : int, optional
        Threads for the chunked stages.

    Returns
    -------
    RawImage
        uint16 mosaic, CFA, black/white levels, ColorMatrix1 (XYZ(D65) → camera; None for
        an ``"ideal"`` sensor's identical channels), AsShotNeutral (the simulated sensor's
        own response to the illuminant's white, max 1), NoiseProfile and ``meta`` with K
        (DN/e⁻), exposure, ISO, saturation, σ_d, QE, seeds and per-stage timings.

    Raises
    ------
    SensorError
        For radiance of the wrong shape or with NaN, infinite or negative values, or an
        invalid sensor.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2–3.
    .. [2] Adobe (2023). DNG Specification 1.7.1.0 (ColorMatrix1, AsShotNeutral, NoiseProfile).
    """
    started = time.perf_counter()
    timings: dict[str, float] = {}
    sensor, exposure = config.sensor, config.exposure
    _check_sensor(sensor)
    validate_radiance(radiance, sensor)
    frame_seed = config.render.seed if frame_seed is None else frame_seed
    if not (isinstance(frame_seed, (int, np.integer)) and not isinstance(frame_seed, bool) and frame_seed >= 0):
        raise SensorError(f"frame_seed {frame_seed!r} must be a whole number >= 0")
    if shot_noise_method not in SHOT_NOISE_METHODS:
        raise SensorError(f"shot_noise_method {shot_noise_method!r}; valid: {', '.join(SHOT_NOISE_METHODS)}")
    monochrome = sensor.cfa == "none"
    model = signal_model(radiance, config)
    weights, cos4, qe = model.weights, model.cos4, model.qe
    n_w, area, trans_specs = model.working_f_number, model.pixel_area_m2, model.transmission_specs
    timings["setup"] = time.perf_counter() - started

    t0 = time.perf_counter()
    auto = exposure.time_s == "auto"
    rate = electron_rates(radiance.data, weights, cfa=sensor.cfa, cos4=cos4, workers=workers)
    timings["electron_rates"] = time.perf_counter() - t0

    gain = system_gain(sensor, exposure.iso)
    saturation_e = saturation_electrons(sensor, gain)
    t0 = time.perf_counter()
    reference_rate = None
    if auto:
        if white_mask is not None:
            mask = np.asarray(white_mask, dtype=bool)
            if mask.shape != rate.shape or not mask.any():
                raise SensorError(f"white_mask must be a boolean {rate.shape} array with at least one True pixel")
            reference_rates = max_channel_rates(radiance.data, weights, cos4=cos4, mask=mask)
            percentile = None
        else:
            step = 1 if rate.size <= _AUTO_FULL_BELOW else _AUTO_STEP
            reference_rates = max_channel_rates(radiance.data, weights, cos4=cos4, step=step)
            percentile = 99.0
        exposure_s, reference_rate = auto_exposure_time(
            reference_rates, saturation_e=saturation_e, fraction=exposure.auto_fraction,
            dark_current_e_per_s=sensor.dark_current_e_per_s, percentile=percentile)
    else:
        exposure_s = float(exposure.time_s)
    timings["auto_exposure"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    mosaic, chain_cpu = simulate_frame(rate, sensor, exposure_s=exposure_s, gain=gain, frame_seed=int(frame_seed),
                                       shot_noise_method=shot_noise_method, workers=workers)
    timings["noise_chain"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    black, white = sensor.black_level_dn, 2 ** sensor.bit_depth - 1
    sigma_d = dark_noise_electrons(sensor, exposure_s)
    if monochrome:
        neutral = matrix = matrix_a = None
    else:
        if model.camera_channels:
            response = _illuminant_film_response(config)
        else:
            edges = tuple(np.asarray(radiance.band_edges_nm, float).tolist())
            response = _illuminant_bands(config.illuminant.spd, edges) @ weights
        neutral = response / response.max() if response.max() > 0 else None
        matrix = _colour_matrix(sensor.model, trans_specs) if sensor.model != "ideal" else None
        matrix_a = _colour_matrix(sensor.model, trans_specs, "A") if matrix is not None else None
    timings["colour"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - started

    peak_per_channel = qe.max(axis=0)
    meta = {
        "K_dn_per_e": gain,
        "exposure_s": exposure_s,
        "exposure_auto": auto,
        "auto_reference_e_per_s": reference_rate,
        "auto_fraction": exposure.auto_fraction if auto else None,
        "iso": exposure.iso,
        "base_iso": sensor.base_iso,
        "saturation_e": saturation_e,
        "full_well_e": sensor.full_well_e,
        "sigma_dark_e": sigma_d,
        "read_noise_e": sensor.read_noise_e,
        "dark_current_e_per_s": sensor.dark_current_e_per_s,
        "dsnu_e": sensor.dsnu_e,
        "prnu": sensor.prnu,
        "peak_qe": sensor.peak_qe,
        "peak_qe_per_channel": [float(v) for v in peak_per_channel],
        "input": "camera channels (photon-weighted film)" if model.camera_channels else
                 f"{len(radiance.wavelengths_nm)} spectral bands",
        "bit_depth": sensor.bit_depth,
        "working_f_number": n_w,
        "pixel_area_m2": area,
        "vignetting": bool(sensor.vignetting),
        "shot_noise": bool(sensor.shot_noise),
        "shot_noise_method": shot_noise_method,
        "seeds": {"sensor": int(sensor.seed), "frame": int(frame_seed)},
        "model": sensor.model,
        "timings_s": timings,
        "noise_chain_cpu_s": chain_cpu,
    }
    if matrix is not None:
        meta.update(_fitted_corrections(sensor.model, config.illuminant.spd, trans_specs))
    return RawImage(
        mosaic=mosaic,
        cfa=sensor.cfa,
        black_level=float(black),
        white_level=int(white),
        color_matrix=matrix,
        as_shot_neutral=neutral,
        noise_profile=noise_profile(gain, sensor.read_noise_e, black, white),
        camera_model=f"spectral_cam {sensor.model}",
        meta=meta,
        color_matrix_2=matrix_a,
    )
