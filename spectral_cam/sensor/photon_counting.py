"""Single-photon sensors: quanta image sensors (QIS) and SPAD arrays, from the same spectral radiance.

A jot (a QIS pixel) or a SPAD counts photo-detections in each of F short frames. Its mean number of
detections per frame, H = (rate·η + DCR)·t_f, comes from the camera equation with the photon
detection efficiency η(λ) of the sensor's spectral curves (the CMOS model's QE, ``peak_qe`` included)
and the dark count rate DCR (``sensor.dark_current_e_per_s``: thermal carriers trigger counts as they
add dark current). Per frame the detections are Poisson(H), read out with ``jot_bits`` bits (a count
saturating at 2^b − 1; one bit: "any photon"). A SPAD (``kind = "spad"``) has a dead time τ after
each detection (a non-paralysable counter: P(N ≥ n) = P(Γ(n, λ) ≤ t_f − (n − 1)τ), λ = H/t_f) and
afterpulses (each detection adds one more with probability p_ap).

Reconstruction: the per-jot mean count S/F inverts the expected count E[N](H) of the model (for one
bit 1 − e^(−H), so Ĥ = −ln(1 − S/F): the maximum-likelihood estimate of binary frames), minus the dark
counts; its standard error for one bit is √((e^H − 1)/F) (the Fisher information of F Bernoulli
frames). The reconstruction is also a RawImage (linear, the CFA's, black 0) that the ISP develops.

References
----------
.. [1] Fossum, E. R. (2005). What to do with sub-diffraction-limit (SDL) pixels? — A proposal for a
   gigapixel digital film sensor (DFS). IEEE Workshop on CCDs and Advanced Image Sensors.
.. [2] Yang, F., Lu, Y. M., Sbaiz, L., & Vetterli, M. (2012). Bits from photons: oversampled image
   acquisition using binary Poisson statistics. IEEE Trans. Image Process. 21(4), 1421–1436 (the
   MLE −ln(1 − S/F)).
.. [3] Müller, J. W. (1973). Dead-time problems. Nucl. Instrum. Methods 112, 47–57 (counting with a
   non-paralysable dead time).
.. [4] Ma, S., Gupta, S., Ulku, A. C., Bruschini, C., Charbon, E., & Gupta, M. (2020). Quanta burst
   photography. ACM Trans. Graph. 39(4) (SPAD binary frames, dark counts).
"""

from __future__ import annotations

import functools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ConfigError, SensorError

__all__ = ["PhotonCountingCapture", "expose_photon_counting", "expected_count", "saturation_count",
           "metered_frame_time"]

# the ``sensor.kind`` choices are the registry's: spectral_cam.sensor.kinds.SENSOR_KINDS


def expected_count(h, *, bits: int, frame_s: float, dead_time_s: float = 0.0) -> np.ndarray:
    """E[min(N, 2^b − 1)] of one frame for a mean of ``h`` detections without dead time.

    P(N ≥ n) = P(Γ(n, λ) ≤ t_f − (n − 1)·τ) with λ = h/t_f (Poisson counts when τ = 0).
    """
    from scipy.special import gammainc

    h = np.asarray(h, dtype=np.float64)
    rate = h / frame_s
    total = np.zeros_like(h)
    for n in range(1, 2 ** bits):
        window = frame_s - (n - 1) * dead_time_s
        if window <= 0:
            break
        total += gammainc(n, rate * window)
    return total


def saturation_count(*, bits: int, frame_s: float, dead_time_s: float = 0.0) -> int:
    """The most detections a jot or SPAD can register in one frame: 2^b − 1 (its bits), and with a
    dead time τ the n with (n − 1)·τ < t_f, i.e. ⌈t_f/τ⌉ (a SPAD whose dead time exceeds the frame counts
    at most 1).

    References
    ----------
    .. [1] Müller, J. W. (1973). Dead-time problems. Nucl. Instrum. Methods 112, 47–57.
    """
    cap = 2 ** int(bits) - 1
    if dead_time_s > 0:
        cap = min(cap, max(1, math.ceil(frame_s / dead_time_s)))
    return cap


def metered_frame_time(rate_hz: float, *, share: float, bits: int, dead_time_s: float = 0.0) -> float:
    """The frame time t_f that puts a jot of detection rate ``rate_hz`` at ``share`` of the count's
    saturation: E[count](rate·t_f) = share·n_sat(t_f) (:func:`expected_count`, :func:`saturation_count`).

    The count's saturation is to a single-photon sensor what the full well is to an integrating one: the
    meter (:func:`spectral_cam.sensor.metered_exposure.resolve_exposure`) puts its grey, or its reference,
    at its share of it, so the white stays below the count that every frame reads. With a dead time
    n_sat depends on t_f: the shortest t_f whose own n_sat is the one it was solved for.

    Parameters
    ----------
    rate_hz : float
        Detections per second of the reference (light and dark counts), > 0.
    share : float
        Target mean count over n_sat, in (0, 1).
    bits, dead_time_s
        The sensor's.

    Returns
    -------
    float
        t_f (s).
    """
    from scipy.optimize import brentq

    if not (rate_hz > 0 and 0 < share < 1):
        raise SensorError(f"metering a single-photon sensor needs a positive rate and a share in (0, 1); got "
                          f"{rate_hz!r} Hz, {share!r}")
    def frame_time(count: int) -> float:
        target = share * count

        def excess(t):
            return float(expected_count(rate_hz * t, bits=bits, frame_s=t, dead_time_s=dead_time_s)) - target

        high = target / rate_hz
        while excess(high) < 0:
            high *= 2.0
        return float(brentq(excess, 1e-12 * high, high, xtol=1e-15 * high, rtol=1e-12))

    # the shortest exposure that holds: the least n whose frame time's n_sat is n (n_sat(t(n)) grows with n,
    # from at least 1 to at most 2^b − 1, so the first n with n_sat(t(n)) ≤ n has n_sat = n)
    for count in range(1, 2 ** int(bits)):
        frame_s = frame_time(count)
        if saturation_count(bits=bits, frame_s=frame_s, dead_time_s=dead_time_s) <= count:
            return frame_s
    return frame_s


@functools.lru_cache(maxsize=8)
def _inverse_table(bits: int, frame_s: float, dead_time_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(h, E[count]) on a log grid of h, for inverting the mean count (cached: reconstruct, to_raw and
    standard_error of a capture all invert through it)."""
    h = np.concatenate([[0.0], np.geomspace(1e-6, 60.0 * 2 ** bits, 4000)])
    table = expected_count(h, bits=bits, frame_s=frame_s, dead_time_s=dead_time_s)
    h.setflags(write=False)
    table.setflags(write=False)
    return h, table


@dataclass
class PhotonCountingCapture:
    """The frames of a single-photon sensor and what they were.

    Attributes
    ----------
    counts : numpy.ndarray
        (F, H, W) uint8 detections per frame and jot (0/1 for one bit).
    cfa : str
        The colour filter array over the jots (``"none"``: monochrome).
    kind, bits, frame_s, dark_count_rate_hz, dead_time_s, afterpulsing
        The sensor.
    meta : dict
        The record (the CMOS RAW's fields that apply, and the mean detections per frame).
    colour : dict
        The colour metadata a CMOS RAW of the same light carries (for :meth:`to_raw`; not saved).
    crop : tuple or None
        (top, left, height, width) of the frame in the jots when the radiance held the sensor's crop
        margin (as a CMOS RAW's default crop); :meth:`to_raw` carries it.
    """

    counts: np.ndarray
    cfa: str
    kind: str
    bits: int
    frame_s: float
    dark_count_rate_hz: float
    dead_time_s: float = 0.0
    afterpulsing: float = 0.0
    meta: dict = field(default_factory=dict)
    colour: dict = field(default_factory=dict, repr=False)
    crop: tuple | None = None

    @property
    def frames(self) -> int:
        return int(self.counts.shape[0])

    @property
    def saturation(self) -> int:
        """The most a frame can count (:func:`saturation_count`): the bits' 2^b − 1, or fewer under a
        dead time."""
        return saturation_count(bits=self.bits, frame_s=self.frame_s, dead_time_s=self.dead_time_s)

    def sum(self) -> np.ndarray:
        """(H, W) float64 detections summed over the frames."""
        return self.counts.sum(axis=0, dtype=np.float64)

    def reconstruct(self) -> np.ndarray:
        """(H, W) estimated photo-detections per frame from the light, Ĥ − DCR·t_f (see the module).

        Jots whose every frame saturated are given the estimate of half a frame short of that."""
        cap = self.saturation
        mean = self.sum() / self.frames
        mean = np.minimum(mean, cap * (1.0 - 0.5 / self.frames))
        h, table = _inverse_table(self.bits, self.frame_s, self.dead_time_s)
        estimate = np.interp(mean, table, h)
        return estimate - self.dark_count_rate_hz * self.frame_s

    def standard_error(self) -> np.ndarray:
        """(H, W) predicted standard error of :meth:`reconstruct` for one-bit frames: √((e^H − 1)/F)."""
        if self.bits != 1:
            raise ConfigError("the closed-form standard error holds for one-bit frames (jot_bits = 1)")
        h = self.reconstruct() + self.dark_count_rate_hz * self.frame_s
        return np.sqrt(np.expm1(np.maximum(h, 0.0)) / self.frames)

    def to_raw(self, *, colour: dict | None = None):
        """The reconstruction as a linear RawImage (black 0, white 65535 at the largest estimate the
        frames can give), with the CFA and the colour metadata of a CMOS capture of the same light."""
        from ..raw import RawImage

        cap = self.saturation
        h, table = _inverse_table(self.bits, self.frame_s, self.dead_time_s)
        top = float(np.interp(cap * (1.0 - 0.5 / self.frames), table, h))
        mosaic = np.clip(np.round(self.reconstruct() / top * 65535.0), 0, 65535).astype(np.uint16)
        colour = colour or self.colour or {}
        return RawImage(mosaic=mosaic, cfa=self.cfa, black_level=0.0, white_level=65535,
                        color_matrix=colour.get("matrix"), as_shot_neutral=colour.get("neutral"),
                        color_matrix_2=colour.get("matrix_a"), forward_matrix=colour.get("forward"),
                        forward_matrix_2=colour.get("forward_a"), hue_sat_map=colour.get("hue_sat"),
                        hue_sat_map_2=colour.get("hue_sat_a"),
                        camera_model=self.meta.get("camera_model", ""), crop=self.crop,
                        meta={**self.meta, "reconstruction": "maximum likelihood from the mean count",
                              "detections_per_frame_at_white": top})

    def save(self, path) -> Path:
        """An NPZ: ``bits`` (packed along the frames' rows, NumPy's packbits) or ``counts`` (several
        bits), and ``meta`` (JSON: kind, frames, shape, bits, frame time, DCR, dead time, afterpulsing,
        CFA, the record)."""
        from ..io import atomic_path

        path = Path(path)
        record = {"kind": self.kind, "frames": self.frames, "shape": list(self.counts.shape[1:]), "bits": self.bits,
                  "frame_s": self.frame_s, "dark_count_rate_hz": self.dark_count_rate_hz,
                  "dead_time_s": self.dead_time_s, "afterpulsing": self.afterpulsing, "cfa": self.cfa,
                  "layout": "bits: numpy.packbits(counts.astype(bool), axis=-1); unpack with "
                            "numpy.unpackbits(bits, axis=-1, count=shape[1])" if self.bits == 1 else "counts: uint8",
                  "meta": self.meta}
        # one-bit counts are 0 or 1 already: packed as they are (a bool copy would double the frames' memory)
        arrays = {"bits": np.packbits(self.counts, axis=-1)} if self.bits == 1 else {"counts": self.counts}
        with atomic_path(path) as tmp:
            with open(tmp, "wb") as handle:
                np.savez_compressed(handle, meta=np.array(json.dumps(record, default=float)), **arrays)
        return path


def _draw_counts(light: np.ndarray, frames: int, *, dark: float, bits: int, frame_s: float, dead_time_s: float,
                 afterpulsing: float, rng: np.random.Generator, factors: np.ndarray | None = None) -> np.ndarray:
    """(F, H, W) uint8 detections: Poisson(h) per frame, or the dead-time counter, capped at 2^b − 1.

    h = light·W[f, r] + dark for frame f of row r: ``light`` the (H, W) mean detections per frame from the
    scene's light, ``factors`` W (F, H) its flicker over each frame's window on each row (None: steady),
    ``dark`` the dark counts per frame (not modulated)."""
    cap = 2 ** bits - 1
    out = np.empty((frames, *light.shape), dtype=np.uint8)
    steady = light + dark

    def mean(f: int) -> np.ndarray:
        return steady if factors is None else light * factors[f][:, None] + dark

    if dead_time_s == 0 or bits == 1:
        for f in range(frames):
            out[f] = np.minimum(rng.poisson(mean(f)), cap)
    else:
        survival = None
        for f in range(frames):
            if survival is None or factors is not None:  # P(N >= n), again for each frame of a flickering light
                survival = _survival(mean(f), cap=cap, frame_s=frame_s, dead_time_s=dead_time_s)
            u = rng.random(light.shape)
            out[f] = np.sum(u[None] < survival, axis=0)
    if afterpulsing > 0 and bits > 1:
        for f in range(frames):
            out[f] = np.minimum(out[f] + rng.binomial(out[f], afterpulsing), cap)
    return out


def _survival(h: np.ndarray, *, cap: int, frame_s: float, dead_time_s: float) -> np.ndarray:
    """(cap, H, W) P(N ≥ n) of the non-paralysable counter for a mean of ``h`` detections a frame."""
    from scipy.special import gammainc

    rate = h / frame_s
    return np.stack([gammainc(n, rate * max(frame_s - (n - 1) * dead_time_s, 0.0)) for n in range(1, cap + 1)])


def _metered_frame_s(config, reference_rate: float, dead_time_s: float) -> float:
    """The metered frame time: the meter's rate (its grey-equivalent, or for ``etr`` the reference) at the
    share of the count's saturation the CMOS meter gives the full well (GREY_RAW·2^EV; ``auto_fraction``)."""
    from ..metering import GREY_RAW

    exposure = config.exposure
    if exposure.metering == "etr":  # E[count] reaches n_sat only as H → ∞: a fraction of 1 is held just below
        share = min(float(exposure.auto_fraction), 0.99)
    else:
        share = GREY_RAW * 2.0 ** exposure.compensation_ev
    if not share < 1:
        raise ConfigError(f"exposure.compensation_ev = {exposure.compensation_ev!r} puts a single-photon sensor's "
                          f"metered grey at {share:.3g} of its count's saturation; valid: below "
                          f"{math.log2(1 / GREY_RAW):.2f} EV")
    return metered_frame_time(reference_rate + float(config.sensor.dark_current_e_per_s), share=share,
                              bits=int(config.sensor.jot_bits), dead_time_s=dead_time_s)


def expose_photon_counting(radiance, config, *, frame_seed: int | None = None,
                           white_mask: np.ndarray | None = None) -> PhotonCountingCapture:
    """Expose a single-photon sensor (``sensor.kind = "qis"`` or ``"spad"``) to a radiance image.

    The exposure time (fixed, or ``"auto"`` metered as for the CMOS sensor) is split into
    ``sensor.jot_frames`` frames; each jot's mean detections per frame come from the camera equation
    through its CFA colour (the same rates as :func:`spectral_cam.expose`) plus the dark counts.

    Returns
    -------
    PhotonCountingCapture

    References
    ----------
    .. [1] Yang et al. (2012), IEEE TIP 21(4) (binary Poisson frames); Fossum (2005).
    """
    from . import _colour_metadata, _with_scene_light
    from .metered_exposure import resolve_exposure
    from .radiometry import electron_rates, signal_model, validate_radiance
    from .temporal import frame_row_factors

    from .kind_registry import SENSOR_KINDS

    config = _with_scene_light(config, radiance)
    sensor = config.sensor
    # a kind counts photons when it declares jot frames; a SPAD's dead time and afterpulsing are its own keys
    counting = [name for name, entry in SENSOR_KINDS.items() if "jot_frames" in entry.options]
    if sensor.kind not in counting:
        raise SensorError(f"sensor.kind = {sensor.kind!r}: photon counting needs {' or '.join(map(repr, counting))}")
    own = SENSOR_KINDS[sensor.kind].options
    validate_radiance(radiance, sensor)
    model = signal_model(radiance, config)
    rate = electron_rates(radiance.data, model.weights, cfa=sensor.cfa, cos4=model.cos4, olpf_px=model.olpf_px,
                          channel_gain=model.channel_gain)
    exposure_s, reference_rate = resolve_exposure(radiance, config, model, white_mask=white_mask)
    frames = int(sensor.jot_frames)
    dead = sensor.dead_time_s if "dead_time_s" in own else 0.0
    if config.exposure.time_s == "auto" and reference_rate:
        exposure_s = frames * _metered_frame_s(config, float(reference_rate), dead)
    frame_s = exposure_s / frames
    light = rate.astype(np.float64) * frame_s
    h = light + sensor.dark_current_e_per_s * frame_s
    # a flickering light, per jot frame and row (the rolling shutter's row times): as the CMOS path's rows
    factors = frame_row_factors(config, light.shape[0], frame_s, frames)
    seed = config.render.seed if frame_seed is None else frame_seed
    rng = np.random.default_rng([int(sensor.seed), int(seed), 0x51])
    afterpulsing = sensor.afterpulsing if "afterpulsing" in own else 0.0
    counts = _draw_counts(light, frames, dark=sensor.dark_current_e_per_s * frame_s, bits=int(sensor.jot_bits),
                          frame_s=frame_s, dead_time_s=dead, afterpulsing=afterpulsing, rng=rng, factors=factors)
    colour = _colour_metadata(radiance, config, model)
    meta = {"exposure_s": exposure_s, "frame_s": frame_s, "frames": frames, "kind": sensor.kind,
            "mean_detections_per_frame": float(h.mean()),
            "saturation_count": saturation_count(bits=int(sensor.jot_bits), frame_s=frame_s, dead_time_s=dead), "photon_detection_efficiency_peak": sensor.peak_qe,
            "dark_count_rate_hz": sensor.dark_current_e_per_s, "camera_model": f"spectral_cam {sensor.model}",
            "seeds": {"sensor": int(sensor.seed), "frame": int(seed)}, "model": sensor.model}
    return PhotonCountingCapture(counts, sensor.cfa, sensor.kind, int(sensor.jot_bits), frame_s,
                                 float(sensor.dark_current_e_per_s), dead, afterpulsing, meta, colour,
                                 radiance.frame_window if hasattr(radiance, "frame_window") else None)
