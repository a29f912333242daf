"""EMVA 1288 photon-transfer analysis of RAW frames (ours or any camera's).

From pairs of flat-field frames over an illumination (or exposure-time) series and the
matching dark pairs, the photon-transfer method estimates, per CFA colour:

- the system gain K (DN/e⁻): slope of the temporal variance σ²_y − σ²_y.dark against the
  mean μ_y − μ_y.dark, fitted through the origin from the darkest point up to 70 % of
  saturation;
- the responsivity R (DN/photon) and quantum efficiency η = R/K, given the photons per
  pixel μ_p of each point;
- the temporal dark noise σ_d = √(σ²_y.dark − σ_q²)/K with σ_q² = 1/12 DN², checked against
  the intercept of a free linear fit of σ²_y against μ_y − μ_y.dark;
- saturation: the point where the temporal variance peaks (μ_y.sat), in electrons
  (μ_y.sat − μ_y.dark)/K (a colour counts as saturated only when its variance has
  collapsed to below half the peak by the brightest point);
- DSNU and PRNU from the spatial variance of frames averaged over a stack of L frames,
  corrected for the residual temporal variance σ²_stack/L (EMVA 1288 4.0 §8.2);
- the SNR curve (μ_y − μ_y.dark)/σ_y against μ_p, and its model.

The temporal variance of a pair is σ²_y = ⟨((y_A − μ_A) − (y_B − μ_B))²⟩ / 2, which removes
every fixed pattern.

References
----------
.. [1] EMVA Standard 1288, Release 4.0 Linear (2021). Standard for Characterization of
   Image Sensors and Cameras. §6 (sensitivity, linearity, noise: the photon transfer
   method), §8 (spatial nonuniformity: DSNU, PRNU).
.. [2] Janesick, J. R. (2007). Photon Transfer: DN → λ. SPIE Press.
.. [3] EMVA1288 reference implementation, https://github.com/EMVA1288/emva1288
   (``process/results.py``: fits through the origin, saturation at the variance maximum).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from ..cfa import MONOCHROME, check_cfa

__all__ = ["PhotonTransferResult", "photon_transfer", "pair_statistics", "spatial_nonuniformity",
           "snr_model", "plot_photon_transfer", "channel_pixels"]

#: Variance of uniform quantisation noise, DN² (EMVA 1288 §2.3).
QUANTISATION_VAR_DN2 = 1.0 / 12.0
#: Upper end of the linear range used for K and R, as a fraction of μ_y.sat − μ_y.dark.
LINEAR_FRACTION = 0.7


# ----------------------------------------------------------------------------- pixels
def channel_pixels(frame: np.ndarray, cfa: str) -> dict[str, np.ndarray]:
    """Split a mosaic into its colours: ``{"R": ..., "G": ..., "B": ...}`` (1-D, G holds
    both green sites) or ``{"Y": frame.ravel()}`` for ``cfa = "none"``.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §1.4 (colour cameras: each channel is analysed alone).
    """
    frame = np.asarray(frame)
    if frame.ndim != 2:
        raise ValueError(f"a frame must be a 2-D mosaic; got shape {frame.shape}")
    cfa = check_cfa(cfa, allow_monochrome=True)
    if cfa == MONOCHROME:
        return {"Y": frame.ravel()}
    groups: dict[str, list[np.ndarray]] = {"R": [], "G": [], "B": []}
    for index, colour in enumerate(cfa):
        a, b = divmod(index, 2)
        groups[colour].append(frame[a::2, b::2].ravel())
    return {name: np.concatenate(parts) for name, parts in groups.items()}


def _as_frame(item) -> tuple[np.ndarray, str | None]:
    mosaic = getattr(item, "mosaic", None)
    if mosaic is not None:
        return np.asarray(mosaic), getattr(item, "cfa", None)
    return np.asarray(item), None


def pair_statistics(frame_a, frame_b, *, cfa: str = "none") -> tuple[dict[str, float], dict[str, float]]:
    """Mean μ_y and temporal variance σ²_y (DN, DN²) of a frame pair, per colour.

    ``μ_y = (⟨y_A⟩ + ⟨y_B⟩)/2`` and ``σ²_y = ⟨((y_A − ⟨y_A⟩) − (y_B − ⟨y_B⟩))²⟩ / 2``.

    Returns
    -------
    (dict, dict)
        Means and variances keyed by colour.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §6.1 eqs. (for μ_y and σ²_y from two frames).
    """
    a = channel_pixels(np.asarray(frame_a, dtype=np.float64), cfa)
    b = channel_pixels(np.asarray(frame_b, dtype=np.float64), cfa)
    means, variances = {}, {}
    for name in a:
        mean_a, mean_b = a[name].mean(), b[name].mean()
        diff = (a[name] - mean_a) - (b[name] - mean_b)
        means[name] = 0.5 * (mean_a + mean_b)
        variances[name] = 0.5 * float(np.mean(diff * diff))
    return means, variances


def spatial_nonuniformity(stack, *, cfa: str = "none") -> tuple[dict[str, float], dict[str, float],
                                                                   dict[str, float]]:
    """Mean, spatial variance corrected for temporal noise, and temporal variance of a stack.

    ``s²_y = s²_y.measured − σ²_y.stack / L`` where s²_y.measured is the spatial variance of
    the average of the L frames and σ²_y.stack the mean over pixels of each pixel's
    temporal variance.

    Parameters
    ----------
    stack : array_like
        (L, H, W) frames (DN), L ≥ 2, of one flat (or dark) field.
    cfa : str
        CFA pattern or ``"none"``.

    Returns
    -------
    (dict, dict, dict)
        μ_y (DN), s²_y (DN²) and σ²_y.stack (DN²) per colour.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §8.2 (spatial variances from averaged images, corrected
       by σ²_y.stack / L).
    """
    frames = np.stack([_as_frame(item)[0] for item in stack]).astype(np.float64)
    if frames.ndim != 3 or frames.shape[0] < 2:
        raise ValueError("a stack needs at least two frames of shape (H, W)")
    count = frames.shape[0]
    average = frames.mean(axis=0)
    temporal = frames.var(axis=0, ddof=1)
    avg_by = channel_pixels(average, cfa)
    tmp_by = channel_pixels(temporal, cfa)
    means, spatial, temporal_var = {}, {}, {}
    for name in avg_by:
        measured = float(np.var(avg_by[name], ddof=1))
        temporal_var[name] = float(tmp_by[name].mean())
        spatial[name] = measured - temporal_var[name] / count
        means[name] = float(avg_by[name].mean())
    return means, spatial, temporal_var


def snr_model(photons_per_pixel, *, quantum_efficiency: float, sigma_d_e: float, gain: float) -> np.ndarray:
    """Model SNR of the linear camera: ``η·μ_p / √(σ_d² + σ_q²/K² + η·μ_p)``.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.4 eq. (SNR).
    """
    signal = quantum_efficiency * np.asarray(photons_per_pixel, dtype=float)
    return signal / np.sqrt(sigma_d_e ** 2 + QUANTISATION_VAR_DN2 / gain ** 2 + signal)


# ----------------------------------------------------------------------------- result
@dataclass
class PhotonTransferResult:
    """EMVA 1288 photon-transfer results.

    Per-point arrays have shape (P, C) for P exposure points and C colours
    (``channels``); per-colour arrays (C,). Pooled values combine all colours.

    Attributes
    ----------
    channels : tuple of str
        ``("R", "G", "B")`` or ``("Y",)``.
    photons_per_pixel : numpy.ndarray or None
        (P, C) μ_p of each point and colour, if given.
    mean_dn, mean_dark_dn : numpy.ndarray
        (P, C) μ_y and μ_y.dark (DN).
    var_dn2, var_dark_dn2 : numpy.ndarray
        (P, C) temporal σ²_y and σ²_y.dark (DN²).
    linear : numpy.ndarray
        (P, C) bool, points used for the K and R fits.
    gain : float
        Pooled system gain K (DN/e⁻).
    gain_per_channel : numpy.ndarray
        (C,) K of each colour.
    sigma_d_e : float
        Temporal dark noise σ_d (e⁻) from the dark variance.
    sigma_d_e_intercept : float
        σ_d (e⁻) from the intercept of σ²_y against μ_y − μ_y.dark (a check).
    saturation_index : numpy.ndarray
        (C,) point index of the variance maximum (−1 where a colour never peaks).
    saturation_e : float
        Pooled saturation capacity (e⁻), (μ_y.sat − μ_y.dark)/K, median over colours that peak.
    saturation_e_per_channel : numpy.ndarray
        (C,) (NaN where a colour does not reach saturation).
    saturation_photons : numpy.ndarray or None
        (C,) μ_p.sat.
    responsivity : numpy.ndarray or None
        (C,) R (DN/photon).
    quantum_efficiency : numpy.ndarray or None
        (C,) η = R/K.
    dsnu_e, prnu : float or None
        Pooled DSNU_1288 (e⁻) and PRNU_1288 (fraction, not %).
    dsnu_e_per_channel, prnu_per_channel : numpy.ndarray or None
        (C,).
    snr : numpy.ndarray
        (P, C) measured (μ_y − μ_y.dark)/σ_y.
    """

    channels: tuple[str, ...]
    photons_per_pixel: np.ndarray | None
    mean_dn: np.ndarray
    mean_dark_dn: np.ndarray
    var_dn2: np.ndarray
    var_dark_dn2: np.ndarray
    linear: np.ndarray
    gain: float
    gain_per_channel: np.ndarray
    sigma_d_e: float
    sigma_d_e_intercept: float
    saturation_index: np.ndarray
    saturation_e: float
    saturation_e_per_channel: np.ndarray
    saturation_photons: np.ndarray | None
    responsivity: np.ndarray | None
    quantum_efficiency: np.ndarray | None
    dsnu_e: float | None
    dsnu_e_per_channel: np.ndarray | None
    prnu: float | None
    prnu_per_channel: np.ndarray | None
    snr: np.ndarray
    extra: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """JSON-friendly scalars (units in the keys)."""
        def listed(value):
            return None if value is None else [float(v) for v in np.ravel(value)]

        return {
            "channels": list(self.channels),
            "K_dn_per_e": self.gain,
            "K_dn_per_e_per_channel": listed(self.gain_per_channel),
            "sigma_d_e": self.sigma_d_e,
            "sigma_d_e_intercept": self.sigma_d_e_intercept,
            "saturation_e": self.saturation_e,
            "saturation_e_per_channel": listed(self.saturation_e_per_channel),
            "quantum_efficiency_per_channel": listed(self.quantum_efficiency),
            "dsnu_e": self.dsnu_e,
            "prnu": self.prnu,
        }


# ----------------------------------------------------------------------------- analysis
def _fit_origin(x: np.ndarray, y: np.ndarray) -> float:
    """Least-squares slope of y = a·x (EMVA's fits with zero offset)."""
    denominator = float(np.sum(x * x))
    return float(np.sum(x * y) / denominator) if denominator > 0 else float("nan")


def _saturation_index(variance: np.ndarray) -> int:
    """Index of the variance maximum, or −1 if the colour never saturates: a saturated
    channel's temporal variance collapses once its pixels clip, so the brightest point's
    variance must have fallen below half the maximum."""
    index = int(np.argmax(variance))
    if index == len(variance) - 1 or not variance[-1] < 0.5 * variance[index]:
        return -1
    return index


def _pairs(items, name: str) -> list[tuple[np.ndarray, np.ndarray, str | None]]:
    out = []
    for item in items:
        if len(item) != 2:
            raise ValueError(f"{name}: each entry must be a pair of frames (A, B)")
        a, cfa_a = _as_frame(item[0])
        b, cfa_b = _as_frame(item[1])
        if a.shape != b.shape or a.ndim != 2:
            raise ValueError(f"{name}: the frames of a pair must be 2-D and of one shape; got {a.shape}, {b.shape}")
        out.append((a, b, cfa_a or cfa_b))
    return out


def photon_transfer(
    pairs: Sequence,
    dark_pairs: Sequence,
    *,
    cfa: str | None = None,
    photons_per_pixel=None,
    bright_stack=None,
    dark_stack=None,
) -> PhotonTransferResult:
    """EMVA 1288 photon-transfer analysis of flat-field frame pairs.

    Parameters
    ----------
    pairs : sequence of (frame, frame)
        One pair of flat fields per exposure point, darkest to brightest, reaching past
        saturation; frames are (H, W) arrays (DN) or RawImage objects.
    dark_pairs : sequence of (frame, frame)
        Dark pairs: one per point (for an exposure-time series), or a single pair used for
        every point (for an illumination series at fixed exposure time).
    cfa : str, optional
        ``"RGGB"``, ``"BGGR"``, ``"GRBG"``, ``"GBRG"`` or ``"none"``; default from RawImage
        frames, else ``"none"``.
    photons_per_pixel : array_like, optional
        μ_p of each point, (P,) or (P, C); needed for R, η and μ_p.sat.
    bright_stack : sequence of frames, optional
        L ≥ 2 flat fields near 50 % of saturation, for PRNU.
    dark_stack : sequence of frames, optional
        L ≥ 2 dark frames at the same exposure time, for DSNU (and PRNU).

    Returns
    -------
    PhotonTransferResult

    Raises
    ------
    ValueError
        For mismatched pairs, fewer than three points or a wrong photon array.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §6.2–6.4 (K, R, η, σ_d, μ_e.sat), §8 (DSNU, PRNU).
    """
    bright = _pairs(pairs, "pairs")
    dark = _pairs(dark_pairs, "dark_pairs")
    if len(bright) < 3:
        raise ValueError("photon transfer needs at least three exposure points")
    if len(dark) not in (1, len(bright)):
        raise ValueError(f"give one dark pair or one per point ({len(bright)}); got {len(dark)}")
    cfa = cfa or bright[0][2] or "none"
    cfa = check_cfa(cfa, allow_monochrome=True)

    channels, mean, var, dark_mean, dark_var = _series_statistics(bright, dark, cfa)
    signal = mean - dark_mean
    noise = var - dark_var
    sat_index, sat_signal, limit = _saturation(signal, var)
    linear = _linear_range(signal, limit, channels)
    gain_per_channel = np.array([_fit_origin(signal[linear[:, c], c], noise[linear[:, c], c])
                                 for c in range(len(channels))])
    gain = _fit_origin(signal[linear], noise[linear])

    # Dark noise: the dark variance (mean over the dark pairs), and the intercept check.
    dark_var_mean = float(np.mean(dark_var))
    sigma_d = float(np.sqrt(max(dark_var_mean - QUANTISATION_VAR_DN2, 0.0)) / gain)
    # Weighted by 1/σ²_y: the standard error of a variance estimate is proportional to it,
    # so the dark end, which fixes the intercept, is not drowned by the bright points.
    slope, intercept = np.polyfit(signal[linear], var[linear], 1, w=1.0 / np.maximum(var[linear], 1e-12))
    sigma_d_intercept = float(np.sqrt(max(intercept - QUANTISATION_VAR_DN2, 0.0)) / gain)

    sat_e_channel = sat_signal / gain
    saturation_e = float(np.nanmedian(sat_e_channel)) if (sat_index >= 0).any() else float("nan")
    photons, responsivity, eta, sat_photons = _photon_terms(photons_per_pixel, signal, linear, sat_index, gain)
    dsnu, dsnu_channel, prnu, prnu_channel = _nonuniformity(dark_stack, bright_stack, cfa, channels, gain)

    with np.errstate(divide="ignore", invalid="ignore"):
        snr = np.where(var > 0, signal / np.sqrt(var), np.nan)
    return PhotonTransferResult(
        channels=channels,
        photons_per_pixel=photons,
        mean_dn=mean,
        mean_dark_dn=dark_mean,
        var_dn2=var,
        var_dark_dn2=dark_var,
        linear=linear,
        gain=float(gain),
        gain_per_channel=gain_per_channel,
        sigma_d_e=sigma_d,
        sigma_d_e_intercept=sigma_d_intercept,
        saturation_index=sat_index,
        saturation_e=saturation_e,
        saturation_e_per_channel=sat_e_channel,
        saturation_photons=sat_photons,
        responsivity=responsivity,
        quantum_efficiency=eta,
        dsnu_e=dsnu,
        dsnu_e_per_channel=dsnu_channel,
        prnu=prnu,
        prnu_per_channel=prnu_channel,
        snr=snr,
        extra={"intercept_dn2": float(intercept), "free_fit_slope": float(slope)},
    )


def _series_statistics(bright: list, dark: list, cfa: str) -> tuple[tuple, np.ndarray, np.ndarray, np.ndarray,
                                                                       np.ndarray]:
    """Channels and the (P, C) pair means and temporal variances of the bright and dark pairs,
    a single dark pair repeated for every point (EMVA 1288 §6.1)."""
    dark_stats = [pair_statistics(a, b, cfa=cfa) for a, b, _ in dark]
    channels = tuple(dark_stats[0][0])
    n_points, n_channels = len(bright), len(channels)
    mean = np.empty((n_points, n_channels))
    var = np.empty((n_points, n_channels))
    for i, (a, b, _) in enumerate(bright):
        means, variances = pair_statistics(a, b, cfa=cfa)
        mean[i] = [means[c] for c in channels]
        var[i] = [variances[c] for c in channels]
    dark_mean = np.array([[m[c] for c in channels] for m, _ in dark_stats])
    dark_var = np.array([[v[c] for c in channels] for _, v in dark_stats])
    if len(dark) == 1:
        dark_mean = np.repeat(dark_mean, n_points, axis=0)
        dark_var = np.repeat(dark_var, n_points, axis=0)
    return channels, mean, var, dark_mean, dark_var


def _saturation(signal: np.ndarray, var: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per channel: the saturation point's index (−1: none), its signal μ_y.sat − μ_y.dark (DN,
    NaN where none) and the top of the linear range, :data:`LINEAR_FRACTION` of it (a channel
    that never saturates takes the others' median; with none saturated, no limit)."""
    n_channels = signal.shape[1]
    sat_index = np.array([_saturation_index(var[:, c]) for c in range(n_channels)])
    peaked = sat_index >= 0
    if not peaked.any():
        return sat_index, np.full(n_channels, np.nan), np.full(n_channels, np.inf)
    sat_signal = np.array([signal[sat_index[c], c] if peaked[c] else np.nan for c in range(n_channels)])
    pooled_sat_signal = float(np.nanmedian(sat_signal))
    return sat_index, sat_signal, np.where(peaked, sat_signal, pooled_sat_signal) * LINEAR_FRACTION


def _linear_range(signal: np.ndarray, limit: np.ndarray, channels: tuple) -> np.ndarray:
    """(P, C) the points of the linear range: a positive signal up to ``limit``; at least two
    per channel."""
    linear = (signal <= limit[None, :]) & (signal > 0)
    for c in range(len(channels)):
        if linear[:, c].sum() < 2:
            raise ValueError(f"channel {channels[c]}: fewer than two points below 70 % of saturation; "
                             "add darker exposure points")
    return linear


def _photon_terms(photons_per_pixel, signal: np.ndarray, linear: np.ndarray, sat_index: np.ndarray,
                  gain: float) -> tuple:
    """(μ_p (P, C), R, η, μ_p.sat) per channel, or four Nones without photon counts (EMVA 1288 §6.2–6.4)."""
    if photons_per_pixel is None:
        return None, None, None, None
    n_points, n_channels = signal.shape
    photons = np.asarray(photons_per_pixel, dtype=float)
    if photons.ndim == 1:
        photons = np.repeat(photons[:, None], n_channels, axis=1)
    if photons.shape != (n_points, n_channels):
        raise ValueError(f"photons_per_pixel must be ({n_points},) or ({n_points}, {n_channels}); "
                         f"got {photons.shape}")
    responsivity = np.array([_fit_origin(photons[linear[:, c], c], signal[linear[:, c], c])
                             for c in range(n_channels)])
    sat_photons = np.array([photons[sat_index[c], c] if sat_index[c] >= 0 else np.nan for c in range(n_channels)])
    return photons, responsivity, responsivity / gain, sat_photons


def _nonuniformity(dark_stack, bright_stack, cfa: str, channels: tuple, gain: float) -> tuple:
    """(DSNU e⁻, DSNU per channel, PRNU, PRNU per channel) from the stacks (EMVA 1288 §8); None
    where a stack is missing. PRNU needs the dark stack too."""
    if dark_stack is None:
        if bright_stack is not None:
            raise ValueError("PRNU needs a dark_stack as well as the bright_stack")
        return None, None, None, None
    dark_means_s, dark_spatial, _ = spatial_nonuniformity(dark_stack, cfa=cfa)
    dsnu_channel = np.array([np.sqrt(max(dark_spatial[c], 0.0)) / gain for c in channels])
    dsnu = float(np.sqrt(np.mean([max(dark_spatial[c], 0.0) for c in channels])) / gain)
    if bright_stack is None:
        return dsnu, dsnu_channel, None, None
    bright_means_s, bright_spatial, _ = spatial_nonuniformity(bright_stack, cfa=cfa)
    prnu_channel = np.array([
        np.sqrt(max(bright_spatial[c] - dark_spatial[c], 0.0)) / (bright_means_s[c] - dark_means_s[c])
        for c in channels])
    return dsnu, dsnu_channel, float(np.sqrt(np.mean(prnu_channel ** 2))), prnu_channel


# ----------------------------------------------------------------------------- plot
_COLOURS = {"R": "tab:red", "G": "tab:green", "B": "tab:blue", "Y": "black"}


def plot_photon_transfer(result: PhotonTransferResult, path) -> Path:
    """Plot the photon transfer curve, the sensitivity line and the SNR curve (PNG/PDF/SVG).

    Panels: (1) σ²_y − σ²_y.dark against μ_y − μ_y.dark with the K fit and the linear
    range; (2) μ_y − μ_y.dark against μ_p (or the point index) with the responsivity fit;
    (3) SNR against μ_p (or the signal in electrons), log–log, with the EMVA model and the
    shot-noise limit √(η·μ_p).

    Parameters
    ----------
    result : PhotonTransferResult
        From :func:`photon_transfer`.
    path : str or path-like
        Output image; the format follows the suffix. Written atomically.

    Returns
    -------
    pathlib.Path

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §10 (the figures of a data sheet: photon transfer,
       sensitivity, SNR).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ..io import atomic_path

    path = Path(path)
    figure = Figure(figsize=(14, 4.5), layout="constrained")
    FigureCanvasAgg(figure)
    ptc, sens, snr_ax = figure.subplots(1, 3)
    signal = result.mean_dn - result.mean_dark_dn
    noise = result.var_dn2 - result.var_dark_dn2
    for c, name in enumerate(result.channels):
        colour = _COLOURS.get(name, None)
        below_saturation = np.ones(len(signal), dtype=bool)
        if result.saturation_index[c] >= 0:
            below_saturation[result.saturation_index[c] + 1:] = False
        ptc.plot(signal[:, c], noise[:, c], "o", ms=3, color=colour, alpha=0.5, label=f"{name}")
        used = result.linear[:, c]
        ptc.plot(signal[used, c], noise[used, c], "o", ms=4, color=colour)
        xs = np.linspace(0, np.nanmax(signal[used, c]), 2)
        ptc.plot(xs, result.gain * xs, "-", color="0.3", lw=1)
        if result.saturation_index[c] >= 0:
            i = result.saturation_index[c]
            ptc.plot(signal[i, c], noise[i, c], "x", ms=9, color=colour)
        if result.photons_per_pixel is not None:
            x = result.photons_per_pixel[:, c]
            sens.plot(x, signal[:, c], "o", ms=3, color=colour, label=name)
            xs = np.linspace(0, np.nanmax(x[used]), 2)
            sens.plot(xs, result.responsivity[c] * xs, "-", color="0.3", lw=1)
            eta = result.quantum_efficiency[c]
            good = (x > 0) & np.isfinite(result.snr[:, c]) & (result.snr[:, c] > 0) & below_saturation
            snr_ax.loglog(x[good], result.snr[good, c], "o", ms=3, color=colour, label=f"{name} measured")
            if eta > 0:
                model_x = np.geomspace(max(x[good].min(), 1e-3), x[good].max(), 100)
                snr_ax.loglog(model_x, snr_model(model_x, quantum_efficiency=eta, sigma_d_e=result.sigma_d_e,
                                                 gain=result.gain), "-", color=colour, lw=1)
                snr_ax.loglog(model_x, np.sqrt(eta * model_x), ":", color=colour, lw=1)
        else:
            sens.plot(np.arange(len(signal)), signal[:, c], "o", ms=3, color=colour, label=name)
            electrons = signal[:, c] / result.gain
            good = (electrons > 0) & np.isfinite(result.snr[:, c]) & (result.snr[:, c] > 0) & below_saturation
            snr_ax.loglog(electrons[good], result.snr[good, c], "o", ms=3, color=colour, label=f"{name} measured")
    ptc.set_xlabel("μ_y − μ_y.dark (DN)")
    ptc.set_ylabel("σ²_y − σ²_y.dark (DN²)")
    ptc.set_title(f"Photon transfer: K = {result.gain:.4g} DN/e⁻, σ_d = {result.sigma_d_e:.3g} e⁻")
    ptc.legend(fontsize=8)
    if result.photons_per_pixel is not None:
        sens.set_xlabel("μ_p (photons/pixel)")
        eta_text = ", ".join(f"{n} {v:.3f}" for n, v in zip(result.channels, result.quantum_efficiency))
        sens.set_title(f"Sensitivity: η = {eta_text}")
        snr_ax.set_xlabel("μ_p (photons/pixel)")
    else:
        sens.set_xlabel("exposure point")
        sens.set_title("Sensitivity")
        snr_ax.set_xlabel("μ_e (electrons/pixel)")
    sens.set_ylabel("μ_y − μ_y.dark (DN)")
    sens.legend(fontsize=8)
    snr_ax.set_ylabel("SNR")
    snr_ax.set_title(f"SNR (saturation {result.saturation_e:.4g} e⁻)")
    snr_ax.legend(fontsize=7)
    fmt = path.suffix.lstrip(".").lower() or "png"
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format=fmt, dpi=110)
    return path
