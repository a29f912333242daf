"""Event sensors: per-pixel brightness changes from the same spectral radiance, frame to frame.

Each pixel of a dynamic vision sensor compares the log of its photocurrent, L = ln(rate + I_d)
(the electron rate of the CMOS model through the pixel's CFA colour, ``dark_current_e_per_s`` its
floor), with the level it held at its last event; when L moves by its contrast threshold (C⁺ up,
C⁻ down) it emits an event (x, y, t, ±1) and takes the new level. Between two rendered frames L is
interpolated linearly in time and every crossing gets its own interpolated timestamp (ESIM's
adaptive rule without the adaptation: Rebecq et al. 2018). Non-idealities, as v2e models them from
video (Hu et al. 2021): per-pixel threshold mismatch (C drawn from N(C, σ_C) per pixel and polarity),
a refractory period (a pixel that fired stays silent for t_ref; its level is then set to where L has
gone, so a change during the dead time fires once the period ends), leak events (the held level
drifts down at leak_hz·C per second, so a static pixel fires ON events at about leak_hz) and shot-noise
events (Poisson at shot_noise_hz per pixel, random polarity).

References
----------
.. [1] Rebecq, H., Gehrig, D., & Scaramuzza, D. (2018). ESIM: an open event camera simulator. CoRL.
.. [2] Hu, Y., Liu, S.-C., & Delbruck, T. (2021). v2e: from video frames to realistic DVS events.
   CVPR Workshops.
.. [3] Gallego, G., et al. (2022). Event-based vision: a survey. IEEE TPAMI 44(1), 154–180 (the
   generative model, refractory period, noise).
.. [4] Gehrig, M., et al. (2021). DSEC: a stereo event camera dataset. IEEE RA-L 6(3) (the events/x,
   y, t (µs), p layout).
"""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import SensorError

__all__ = ["EventStream", "log_intensity", "simulate_events", "expected_event_count", "check_event_memory",
           "expected_events_per_pixel", "BYTES_PER_EVENT"]


@dataclass
class EventStream:
    """Events as arrays, in time order.

    Attributes
    ----------
    x, y : numpy.ndarray
        uint16 pixel column and row.
    t : numpy.ndarray
        float64 seconds from the first frame.
    p : numpy.ndarray
        int8 polarity, +1 (ON, brighter) or −1 (OFF).
    shape : tuple
        (H, W) of the sensor.
    meta : dict
        The thresholds, refractory period, noise rates and frame times.
    """

    x: np.ndarray
    y: np.ndarray
    t: np.ndarray
    p: np.ndarray
    shape: tuple[int, int]
    meta: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.t.size)

    def frame(self, start_s: float | None = None, stop_s: float | None = None) -> np.ndarray:
        """(H, W) int32 sum of polarities of the events in [start, stop) (all by default)."""
        keep = np.ones(self.t.size, bool)
        if start_s is not None:
            keep &= self.t >= start_s
        if stop_s is not None:
            keep &= self.t < stop_s
        out = np.zeros(self.shape, np.int32)
        np.add.at(out, (self.y[keep].astype(np.intp), self.x[keep].astype(np.intp)), self.p[keep].astype(np.int32))
        return out

    def frame_rgb(self, start_s: float | None = None, stop_s: float | None = None) -> np.ndarray:
        """(H, W, 3) uint8 event frame for looking at: ON events blue, OFF red on white, as event-camera
        papers draw them."""
        counts = self.frame(start_s, stop_s).astype(np.float64)
        scale = max(1.0, float(np.percentile(np.abs(counts[counts != 0]), 99)) if np.any(counts) else 1.0)
        level = np.clip(np.abs(counts) / scale, 0, 1)
        rgb = np.full((*self.shape, 3), 255.0)
        on, off = counts > 0, counts < 0
        rgb[on] = 255.0 - level[on, None] * np.array([255.0, 155.0, 0.0])
        rgb[off] = 255.0 - level[off, None] * np.array([0.0, 200.0, 200.0])
        return rgb.astype(np.uint8)

    def save(self, path) -> Path:
        """An NPZ in DSEC's layout: ``x``, ``y`` (uint16), ``t`` (int64 µs), ``p`` (uint8: 1 ON, 0 OFF), and
        ``meta`` (JSON: shape, time unit, the sensor's parameters)."""
        from ..io import atomic_path

        path = Path(path)
        record = {"shape": list(self.shape), "t_unit": "microseconds from the first frame",
                  "p": "1 ON (brighter), 0 OFF", "layout": "DSEC events/{x, y, t, p}", **self.meta}
        with atomic_path(path) as tmp:
            with open(tmp, "wb") as handle:
                np.savez_compressed(handle, x=self.x, y=self.y, t=np.round(self.t * 1e6).astype(np.int64),
                                    p=(self.p > 0).astype(np.uint8), meta=np.array(json.dumps(record, default=float)))
        return path


def log_intensity(radiance, config) -> np.ndarray:
    """(H, W) ln(electron rate + dark current) of every pixel through its CFA colour (the CMOS model's
    rates: camera equation, QE, vignetting)."""
    from .radiometry import electron_rates, signal_model, validate_radiance

    validate_radiance(radiance, config.sensor)
    model = signal_model(radiance, config)
    rate = electron_rates(radiance.data, model.weights, cfa=config.sensor.cfa, cos4=model.cos4,
                          olpf_px=model.olpf_px, channel_gain=model.channel_gain)
    return np.log(rate.astype(np.float64) + log_floor(config.sensor))


def log_floor(sensor) -> float:
    """The photocurrent's floor I_d (e⁻/s) under L = ln(rate + I_d): the dark current, at least 1e-3."""
    return max(float(sensor.dark_current_e_per_s), 1e-3)


#: Largest error of the piecewise-linear log intensity under a flickering light, as a share of the
#: smallest threshold: the flicker is sampled densely enough that ln(w) between samples strays from
#: its chords by less (a missed extremum would drop or add a crossing).
FLICKER_LOG_TOLERANCE = 0.01
#: Samples per flicker period of a PWM light (a step: the timing resolution of its events).
PWM_SAMPLES_PER_PERIOD = 64


def flicker_samples_per_period(light, threshold: float) -> int:
    """Samples per period of the light's waveform for the event model's piecewise-linear log intensity.

    The chord of ln(1 + m·cos θ) over a step h errs by at most h²/8·max|∂²/∂θ²| = h²/8·m/(1 − m) (at the
    trough); h is chosen so this stays under :data:`FLICKER_LOG_TOLERANCE`·C (16 to 4096 samples; a
    depth of 1 is taken as 0.999: the dark floor bounds the trough). A PWM light gets
    :data:`PWM_SAMPLES_PER_PERIOD`.

    References
    ----------
    .. [1] Rebecq, Gehrig & Scaramuzza (2018), ESIM (adaptive sampling of the log intensity).
    """
    if light.flicker_waveform == "pwm":
        return PWM_SAMPLES_PER_PERIOD
    depth = min(float(light.flicker_depth), 0.999)
    curvature = depth / (1.0 - depth)
    step = math.sqrt(8.0 * FLICKER_LOG_TOLERANCE * threshold / curvature)
    return int(min(max(math.ceil(2.0 * math.pi / step), 16), 4096))


def _segments(frames, times, config, origin_s: float):
    """(L₀, L₁, t₀, t₁) between which L is linear in time: the frames' intervals, each cut into the
    flicker's samples when the light flickers (L = ln(rate(t)·w(t) + I_d), rate interpolated as
    ln(rate + I_d) between frames)."""
    from .temporal import flickers, instantaneous_power

    if not flickers(config):
        yield from zip(frames[:-1], frames[1:], times[:-1], times[1:])
        return
    light, floor = config.illuminant, log_floor(config.sensor)
    threshold = max(float(config.sensor.event_threshold) - 3.0 * float(config.sensor.event_threshold_sigma), 0.01)
    per_period = flicker_samples_per_period(light, threshold)
    kwargs = {"waveform": light.flicker_waveform, "frequency_hz": light.flicker_hz, "depth": light.flicker_depth,
              "duty": light.flicker_duty, "origin_s": origin_s}

    def flickered(l0, l1, t0, t1, t):
        base = l0 + (l1 - l0) * ((t - t0) / (t1 - t0))
        rate = np.maximum(np.exp(base) - floor, 0.0)
        return np.log(rate * float(instantaneous_power(t, **kwargs)) + floor)

    previous = None
    for l0, l1, t0, t1 in zip(frames[:-1], frames[1:], times[:-1], times[1:]):
        steps = max(1, math.ceil((t1 - t0) * light.flicker_hz * per_period))
        edges = np.linspace(t0, t1, steps + 1)
        previous = flickered(l0, l1, t0, t1, edges[0]) if previous is None else previous
        for a, b in zip(edges[:-1], edges[1:]):
            level = flickered(l0, l1, t0, t1, b)
            yield previous, level, a, b
            previous = level


#: Bytes an event holds while the event model runs and returns (measured 61.1 for 2·10⁷ shot-noise and
#: 61.4 for 2.5·10⁶ leak events: the per-pass index, time and polarity arrays, their concatenation, the
#: time sort and the uint16 copies).
BYTES_PER_EVENT = 64.0
#: The deepest swing of log light a full-depth flicker is taken to make before the config knows the rates:
#: its trough meets the dark floor, here 10⁻³ of the mean light.
FLICKER_FLOOR = 1e-3


def _flicker_swing(light) -> float:
    """ln(max w / min w) of the light's waveform (the floor :data:`FLICKER_FLOOR` for a full depth)."""
    depth = float(light.flicker_depth)
    low = max(1.0 - depth, FLICKER_FLOOR)
    high = 1.0 + depth if light.flicker_waveform == "sine" else (1.0 - depth) + depth / float(light.flicker_duty)
    return math.log(high / low)


def expected_events_per_pixel(config, span_s: float | None = None, *, upper: bool = True) -> float:
    """Events a pixel of an event sensor fires over ``span_s`` (default ``exposure.time_s``) from what the
    config alone says: shot noise and leak at their rates, and a flickering light's crossings, 2⌈Δ/C⌉ a
    period for its log swing Δ (C less 3σ of the threshold's mismatch); leak and flicker together at most
    one a refractory period. ``upper``: the Poisson mean plus 5 standard deviations of a pixel's count.
    Motion's events (the scene's own changes) need the rendered frames
    (:func:`spectral_cam.sensor.events.expected_event_count`).

    References
    ----------
    .. [1] Hu, Liu & Delbruck (2021), v2e (leak and shot-noise event rates); Gallego et al. (2022), §2.
    """
    sensor, light = config.sensor, config.illuminant
    span = float(config.exposure.time_s) if span_s is None else float(span_s)
    threshold = max(float(sensor.event_threshold) - 3.0 * float(sensor.event_threshold_sigma), 0.01)
    crossings = float(sensor.event_leak_hz) * span
    if light.flicker_hz and light.flicker_depth:
        crossings += 2.0 * math.ceil(_flicker_swing(light) / threshold) * float(light.flicker_hz) * span
    if sensor.event_refractory_s > 0:
        crossings = min(crossings, span / float(sensor.event_refractory_s) + 1.0)
    mean = crossings + float(sensor.event_shot_noise_hz) * span
    return mean + 5.0 * math.sqrt(mean) if upper else mean


def expected_event_count(log_frames, times_s, config) -> float:
    """Events the frames will make, bounded from above before any is made: each pixel's log intensity
    travels Σ|L_{k+1} − L_k| between the frames, a crossing each C (less 3σ of the mismatch), plus the
    leak, the flicker and the shot noise of the config
    (:func:`expected_events_per_pixel`; leak, flicker and motion together at
    most one event a refractory period)."""
    sensor = config.sensor
    times = np.asarray(times_s, dtype=np.float64)
    span = float(times[-1] - times[0])
    threshold = max(float(sensor.event_threshold) - 3.0 * float(sensor.event_threshold_sigma), 0.01)
    travel = np.zeros(np.shape(log_frames[0]))
    for l0, l1 in zip(log_frames[:-1], log_frames[1:]):
        travel += np.abs(np.asarray(l1, np.float64) - np.asarray(l0, np.float64))
    moving = travel / threshold + 1.0
    if sensor.event_refractory_s > 0:
        moving = np.minimum(moving, span / float(sensor.event_refractory_s) + 1.0)
    return float(moving.sum()) + travel.size * expected_events_per_pixel(config, span)


def check_event_memory(log_frames, times_s, config) -> None:
    """Refuse, before any event is made, frames whose events would not fit in memory
    (:func:`expected_event_count` × :data:`BYTES_PER_EVENT`)."""
    from ..errors import ConfigError
    from .. import machine

    count = expected_event_count(log_frames, times_s, config)
    have = machine.available_bytes()
    if count * BYTES_PER_EVENT > have:
        span = float(times_s[-1] - times_s[0])
        fits = span * have / (count * BYTES_PER_EVENT)
        raise ConfigError(f"the event capture would make up to {count:.3g} events ({count * BYTES_PER_EVENT / 1e9:.3g} "
                          f"GB) and {have / 1e9:.3g} GB are available; a span (exposure.time_s) of about {fits:.3g} s "
                          f"fits, or lower sensor.event_shot_noise_hz/event_leak_hz, the motion or the frame size")


def _thresholds(sensor, shape, rng) -> tuple[np.ndarray, np.ndarray]:
    c = float(sensor.event_threshold)
    sigma = float(sensor.event_threshold_sigma)
    draw = (lambda: np.full(shape, c)) if sigma == 0 else (lambda: np.maximum(rng.normal(c, sigma, shape), 0.01))
    return draw(), draw()


def simulate_events(log_frames, times_s, config, *, seed: int | None = None,
                    flicker_origin_s: float | None = None) -> EventStream:
    """Events between log-intensity frames (:func:`log_intensity`) at ``times_s``.

    Parameters
    ----------
    log_frames : sequence of numpy.ndarray
        (H, W) ln(photocurrent) per frame, at least two.
    times_s : sequence of float
        Each frame's time (s), increasing.
    config : SceneConfig
        ``sensor.event_threshold`` (C, log units), ``event_threshold_sigma`` (per-pixel σ_C),
        ``event_refractory_s``, ``event_leak_hz``, ``event_shot_noise_hz``, ``seed``.
    seed : int, optional
        Noise seed (default ``config.render.seed``).
    flicker_origin_s : float, optional
        The light's clock at ``times_s = 0`` (s; default ``exposure.start_s``): a flickering light
        (``illuminant.flicker_*``) multiplies each pixel's photocurrent by w(t) between the frames
        (:func:`spectral_cam.sensor.temporal.instantaneous_power`), sampled per
        :func:`flicker_samples_per_period`.

    Returns
    -------
    EventStream

    References
    ----------
    .. [1] Rebecq, Gehrig & Scaramuzza (2018), ESIM; Hu, Liu & Delbruck (2021), v2e.
    """
    frames = [np.asarray(f, dtype=np.float64) for f in log_frames]
    times = np.asarray(times_s, dtype=np.float64)
    if len(frames) < 2 or len(frames) != times.size or not np.all(np.diff(times) > 0):
        raise SensorError("events need at least two frames at increasing times (one time per frame)")
    shape = frames[0].shape
    sensor = config.sensor
    rng = np.random.default_rng([int(sensor.seed), int(config.render.seed if seed is None else seed), 0xE7])
    c_on, c_off = _thresholds(sensor, shape, rng)
    refractory, leak = float(sensor.event_refractory_s), float(sensor.event_leak_hz)
    origin = float(config.exposure.start_s) if flicker_origin_s is None else float(flicker_origin_s)
    check_event_memory(frames, times, config)
    segments = _segments(frames, times, config, origin)
    first = next(segments)
    reference = first[0].copy()
    last_event = np.full(shape, -np.inf)
    out_x, out_y, out_t, out_p = [], [], [], []
    for l0, l1, t0, t1 in itertools.chain([first], segments):
        dt = t1 - t0
        slope = (l1 - l0) / dt
        t = np.full(shape, t0)
        while True:  # each pass emits at most one event per pixel: the next crossing in time
            level = l0 + slope * (t - t0)
            drift = leak * c_on * (t - t0)  # the held level leaks down: the pixel drifts towards ON
            up = reference - drift + c_on
            down = reference - drift - c_off
            # time at which L meets the upper or lower level, moving from t (linear in t; leak moves the levels)
            rate_up = slope + leak * c_on
            with np.errstate(divide="ignore", invalid="ignore"):
                t_up = np.where(rate_up > 0, t + (up - level) / rate_up, np.inf)
                t_down = np.where(rate_up < 0, t + (down - level) / rate_up, np.inf)
            t_up = np.where(level >= up, t, t_up)
            t_down = np.where(level <= down, t, t_down)
            t_next = np.minimum(t_up, t_down)
            t_fire = np.maximum(t_next, last_event + refractory)  # refractory: the earliest it may fire
            fire = (t_fire <= t1) & np.isfinite(t_next)
            if not fire.any():
                break
            ys, xs = np.nonzero(fire)
            when = t_fire[fire]
            polarity = np.where(t_up[fire] <= t_down[fire], 1, -1).astype(np.int8)
            # a fired pixel holds the level L has at its event (after a refractory wait, where L has gone)
            reached = l0[fire] + slope[fire] * (when - t0)
            reference[fire] = reached + leak * c_on[fire] * (when - t0)
            last_event[fire] = when
            t[fire] = when
            out_x.append(xs), out_y.append(ys), out_t.append(when), out_p.append(polarity)
        # the leak over the interval (held levels are kept relative to its start) stays in the held level
        reference -= leak * c_on * dt
    shot = float(sensor.event_shot_noise_hz)
    if shot > 0:  # Poisson noise events, random polarity, over the whole span
        count = rng.poisson(shot * (times[-1] - times[0]) * shape[0] * shape[1])
        out_x.append(rng.integers(0, shape[1], count)), out_y.append(rng.integers(0, shape[0], count))
        out_t.append(rng.uniform(times[0], times[-1], count)), out_p.append(rng.choice(np.array([-1, 1], np.int8), count))
    x = np.concatenate(out_x) if out_x else np.empty(0, int)
    order = np.argsort(np.concatenate(out_t), kind="stable") if out_t else np.empty(0, int)
    meta = {"threshold": float(sensor.event_threshold), "threshold_sigma": float(sensor.event_threshold_sigma),
            "refractory_s": refractory, "leak_hz": leak, "shot_noise_hz": shot, "frame_times_s": times.tolist(),
            "flicker_origin_s": origin}
    if not out_t:
        return EventStream(np.empty(0, np.uint16), np.empty(0, np.uint16), np.empty(0), np.empty(0, np.int8), shape, meta)
    return EventStream(x[order].astype(np.uint16), np.concatenate(out_y)[order].astype(np.uint16),
                       np.concatenate(out_t)[order] - times[0], np.concatenate(out_p)[order].astype(np.int8), shape,
                       meta)
