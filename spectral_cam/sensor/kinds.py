"""The sensor kinds (``sensor.kind``): one registry entry each, the one place a kind is named.

An entry (:class:`SensorKind`) declares everything the rest of the package asks of a kind:

- ``capture``: radiance → what the job writes (:class:`SensorCapture`: the RAW the ISP develops,
  plus the kind's own outputs such as a QIS's count frames or an event stream);
- ``keys``: the ``sensor.*`` keys it owns, their defaults and checks (:class:`~spectral_cam.keys.Key`,
  :func:`kind_key`): ``[sensor]`` is assembled from them (:mod:`spectral_cam.scene`), and the keys
  whose non-zero value belongs to it alone (``exclusive_keys``);
- ``files``: its extra result files (:class:`SensorFile`: file names, writer, reader, size);
- ``memory_bytes_per_pixel`` (and ``memory_remedy``): what its outputs hold in memory;
- ``sequences``: whether a time-lapse sequence (:mod:`spectral_cam.apps.sequence`) takes it.

The entry types and the registry live in :mod:`.kind_registry` (importable from here too); this
module registers the bundled kinds: cmos, qis, spad, event. :func:`capture` is the one capture function of the render job (:func:`spectral_cam.job.simulate`)
and the sequence; :func:`validate_sensor_keys` is what ``SensorSection`` calls. Adding a kind is
one :meth:`SensorKinds.add_kind` call, its new ``sensor.*`` keys included (docs/design.md, "Where to
make a change").

References
----------
.. [1] colour-science, method mappings (``colour.SPECTRAL_SHAPES``-style named entries with
   their functions): one mapping per extension point.
.. [2] docs/design.md, "Sensor (`sensor/`)" (its "Sensor kinds" entry).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import ConfigError
from .kind_registry import (SENSOR_KINDS, SensorCapture, SensorFile, SensorKind, SensorKinds, capture, kind_key,
                            sensor_file, validate_sensor_keys)

__all__ = ["SensorKind", "SensorKinds", "SensorFile", "SensorCapture", "kind_key", "SENSOR_KINDS", "capture",
           "validate_sensor_keys", "sensor_file", "PHOTON_COUNTING_BYTES_PER_PIXEL",
           "SPAD_BYTES_PER_PIXEL_PER_LEVEL", "NPZ_CHUNK_BYTES", "EVENT_WORK_BYTES_PER_PIXEL"]

#: Bytes a single-photon capture holds per jot besides its frames: rates, per-frame means and draws,
#: the reconstruction and its RAW (measured 280–1180 B at 128 × 128, the larger with SciPy's first
#: import); a SPAD with a dead time adds its survival table, 8 B per count level and its comparison.
PHOTON_COUNTING_BYTES_PER_PIXEL = 320.0
SPAD_BYTES_PER_PIXEL_PER_LEVEL = 16.0
#: NumPy writes an array into an NPZ in buffered chunks of at most this (``numpy.lib.format.write_array``).
NPZ_CHUNK_BYTES = 16.0 * 2 ** 20
#: Bytes per pixel of the event model's working arrays (levels, thresholds, times: ~20 float64 planes),
#: besides the frames' log intensities (8 B a pixel a frame).
EVENT_WORK_BYTES_PER_PIXEL = 160.0
#: A result file's tags, attributes and offset tables (as :func:`spectral_cam.budget.estimate_result_bytes`).
_HEADER_BYTES = 16e3


# ----------------------------------------------------------------------------- cmos
def _capture_cmos(radiance, config, *, frame_seed=None, render_pose=None) -> SensorCapture:
    from . import expose

    return SensorCapture(expose(radiance, config, frame_seed=frame_seed))


SENSOR_KINDS.add_kind(SensorKind("cmos", _capture_cmos, description="integrating, the EMVA 1288 model"))


# ----------------------------------------------------------------------------- qis, spad
def _capture_photon_counting(radiance, config, *, frame_seed=None, render_pose=None) -> SensorCapture:
    """Its frames, and their reconstruction as the RAW the ISP develops."""
    from .photon_counting import expose_photon_counting

    counts = expose_photon_counting(radiance, config, frame_seed=frame_seed)
    return SensorCapture(counts.to_raw(), {"photon_counts": counts})


def _photon_counts_bytes(config) -> float:
    """packed bits (or a byte a count) of every frame with the crop margin, before compression"""
    sensor = config.sensor
    margin = 2 * sensor.crop_margin_px
    per_frame = (sensor.width_px + margin) * (sensor.height_px + margin) / (8.0 if sensor.jot_bits == 1 else 1.0)
    return _HEADER_BYTES + sensor.jot_frames * per_frame


def _read_photon_counts(folder) -> dict:
    """photon_counts.npz: ``counts`` (frames, H, W) uint8 (unpacked) and ``meta`` (its record)."""
    with np.load(Path(folder) / "photon_counts.npz") as npz:
        meta = json.loads(str(npz["meta"]))
        if "bits" in npz:
            counts = np.unpackbits(npz["bits"], axis=-1, count=meta["shape"][1])
        else:
            counts = npz["counts"]
    return {"counts": counts, "meta": meta}


def _jot_bytes_per_frame(sensor) -> float:
    return 1.0 + (0.125 if sensor.jot_bits == 1 else 0.0)


def _photon_counting_memory(config) -> float:
    """``jot_frames`` count frames (1 B a jot a frame, and the packed bits written for one bit) with their
    working arrays."""
    sensor = config.sensor
    return float(sensor.jot_frames) * _jot_bytes_per_frame(sensor) + PHOTON_COUNTING_BYTES_PER_PIXEL


def _spad_memory(config) -> float:
    """A QIS's, and with a dead time and several bits the survival table of every count level."""
    sensor = config.sensor
    table = sensor.dead_time_s > 0 and sensor.jot_bits > 1
    return _photon_counting_memory(config) + (SPAD_BYTES_PER_PIXEL_PER_LEVEL * (2 ** int(sensor.jot_bits) - 1)
                                              if table else 0.0)


def _photon_counting_remedy(config, room_per_pixel: float) -> str | None:
    """The ``jot_frames`` that fit ``room_per_pixel`` bytes."""
    sensor = config.sensor
    per_frame = _jot_bytes_per_frame(sensor)
    frames = int((room_per_pixel - (SENSOR_KINDS[sensor.kind].memory_bytes_per_pixel(config) - float(sensor.jot_frames) * per_frame))
                 / per_frame)
    return f"sensor.jot_frames = {frames} fits ({sensor.jot_frames} asked)" if frames >= 1 else None


_PHOTON_COUNTS = SensorFile("photon_counts", ("photon_counts.npz",),
                            lambda counts, folder: [counts.save(Path(folder) / "photon_counts.npz")],
                            _read_photon_counts, _photon_counts_bytes,
                            "a QIS or SPAD capture's frames (packed bits) and record")
_PHOTON_COUNTING_USE = ("it counts single photons: expose it with spectral_cam.expose_photon_counting (its "
                        "reconstruction's to_raw() is the RAW)")
_JOT_KEYS = (kind_key("jot_frames", 256, 1, 65536, "", whole=True,
                      rule="the frames of a single-photon capture, a whole number in 1..65536"),
             kind_key("jot_bits", 1, 1, 8, "", whole=True, rule="bits per jot and frame, a whole number in 1..8"))
SENSOR_KINDS.add_kind(SensorKind(
    "qis", _capture_photon_counting, options=("jot_frames", "jot_bits"),
    description="a quanta image sensor: binary or few-bit jots", keys=_JOT_KEYS, files=(_PHOTON_COUNTS,),
    memory_bytes_per_pixel=_photon_counting_memory, memory_remedy=_photon_counting_remedy,
    outputs_noun="count frames", direct_use=_PHOTON_COUNTING_USE))
SENSOR_KINDS.add_kind(SensorKind(
    "spad", _capture_photon_counting, options=("jot_frames", "jot_bits", "dead_time_s", "afterpulsing"),
    description="single-photon avalanche diodes: dead time, afterpulsing",
    keys=_JOT_KEYS + (kind_key("dead_time_s", 0.0, 0.0, 1.0, "", rule="a SPAD's dead time in 0..1 s (tens of ns are typical)"),
                      kind_key("afterpulsing", 0.0, 0.0, 1.0, "", rule="a SPAD's afterpulsing probability in 0..1")),
    exclusive_keys=("dead_time_s", "afterpulsing"),
    exclusive_rule="dead time and afterpulsing belong to sensor.kind = 'spad'", files=(_PHOTON_COUNTS,),
    memory_bytes_per_pixel=_spad_memory, memory_remedy=_photon_counting_remedy,
    outputs_noun="count frames", direct_use=_PHOTON_COUNTING_USE))


# ----------------------------------------------------------------------------- event
def _event_stream(config, render_pose: Callable):
    """``sensor.event_frames`` renders spread over ``exposure.time_s`` (each a pose of the motion at its
    time, no blur), their log intensities, and the events between them."""
    from .events import log_intensity, simulate_events

    if config.exposure.time_s == "auto":
        raise ConfigError("an event capture needs exposure.time_s: the span its frames cover, in seconds")
    if render_pose is None:
        raise ConfigError("sensor.kind = 'event' renders its own span of poses: capture it through "
                          "spectral_cam.job.simulate or `spectral-cam render`")
    span, count = float(config.exposure.time_s), int(config.sensor.event_frames)
    times = np.linspace(0.0, span, count)
    logs = []
    for t in times:
        frame = config.replace(**{"exposure.start_s": float(config.exposure.start_s) + t - span / 2,
                                  "exposure.time_s": span / (count - 1), "motion.subframes": 1,
                                  "sensor.kind": "cmos"})
        logs.append(log_intensity(render_pose(frame), frame))
    # the light's clock as the poses': the frames are t − span/2 after exposure.start_s
    return simulate_events(logs, times, config, flicker_origin_s=float(config.exposure.start_s) - span / 2)


def _capture_event(radiance, config, *, frame_seed=None, render_pose=None) -> SensorCapture:
    """The events over the span, and the APS frame a DAVIS gives beside them (the CMOS model's RAW)."""
    from . import expose

    started = time.perf_counter()
    events = _event_stream(config, render_pose)
    took = time.perf_counter() - started
    raw = expose(radiance, config.replace(**{"sensor.kind": "cmos"}), frame_seed=frame_seed)
    return SensorCapture(raw, {"events": events}, {"events": took})


def _write_events(events, folder) -> list:
    """events.npz, and events.png: the event frame as 8-bit RGB (OpenCV's PNG encoder; the ISP's
    encoders are above the sensor, and this frame is no developed image)."""
    import cv2

    from ..io import atomic_path

    folder = Path(folder)
    ok, png = cv2.imencode(".png", np.ascontiguousarray(events.frame_rgb()[..., ::-1]))
    if not ok:
        raise OSError("OpenCV could not encode events.png")
    with atomic_path(folder / "events.png") as tmp:
        tmp.write_bytes(png.tobytes())
    return [events.save(folder / "events.npz"), folder / "events.png"]


def _read_events(folder) -> dict:
    """events.npz: ``x``, ``y`` (px), ``t`` (µs), ``p`` (1 ON, 0 OFF) and ``meta`` (its record)."""
    with np.load(Path(folder) / "events.npz") as npz:
        return {**{k: npz[k] for k in ("x", "y", "t", "p")}, "meta": json.loads(str(npz["meta"]))}


#: Bytes an event takes in events.npz before compression: x, y (uint16), t (int64), p (uint8).
_EVENT_FILE_BYTES = 13.0


def _events_bytes(config) -> float:
    """events.npz (the expected events, :func:`~spectral_cam.sensor.events.expected_events_per_pixel`) and
    events.png (8-bit RGB), uncompressed; a metered span has no count yet."""
    from .events import expected_events_per_pixel

    pixels = float(config.sensor.width_px) * config.sensor.height_px
    events = 0.0 if config.exposure.time_s == "auto" else expected_events_per_pixel(config)
    return 2 * _HEADER_BYTES + pixels * (events * _EVENT_FILE_BYTES + 3.0)


def _event_memory(config) -> float:
    """The events (:func:`expected_events_per_pixel` × ``BYTES_PER_EVENT``) and the frames' log
    intensities; 0 for a metered span."""
    from .events import BYTES_PER_EVENT, expected_events_per_pixel

    if config.exposure.time_s == "auto":
        return 0.0
    return (expected_events_per_pixel(config) * BYTES_PER_EVENT + 8.0 * float(config.sensor.event_frames)
            + EVENT_WORK_BYTES_PER_PIXEL)


def _event_remedy(config, room_per_pixel: float) -> str | None:
    """The longest ``exposure.time_s`` whose events fit ``room_per_pixel`` bytes (the count is monotone in it)."""
    from .events import BYTES_PER_EVENT, expected_events_per_pixel

    if config.exposure.time_s == "auto":
        return None
    span = float(config.exposure.time_s)
    rate = expected_events_per_pixel(config, upper=False) / span
    fixed = 8.0 * float(config.sensor.event_frames) + EVENT_WORK_BYTES_PER_PIXEL
    lo, hi = 0.0, span
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if expected_events_per_pixel(config, mid) * BYTES_PER_EVENT + fixed <= room_per_pixel:
            lo = mid
        else:
            hi = mid
    if lo <= 0:
        return None
    return (f"exposure.time_s = {lo:.3g} s fits (about {rate:.3g} events a pixel a second from "
            f"event_shot_noise_hz, event_leak_hz and the light's flicker; or lower those)")


SENSOR_KINDS.add_kind(SensorKind(
    "event", _capture_event,
    options=("event_threshold", "event_threshold_sigma", "event_refractory_s", "event_leak_hz",
             "event_shot_noise_hz", "event_frames"),
    description="brightness changes, from a sequence's frames",
    keys=(kind_key("event_threshold", 0.2, 0.01, 5.0, "the contrast threshold in log units"),
          kind_key("event_threshold_sigma", 0.03, 0.0, 1.0, "the threshold's per-pixel σ in log units"),
          kind_key("event_refractory_s", 1e-4, 0.0, 1.0, "the refractory period in seconds"),
          kind_key("event_leak_hz", 0.1, 0.0, 1e4, "the leak event rate per pixel in Hz"),
          kind_key("event_shot_noise_hz", 0.0, 0.0, 1e4, "the shot-noise event rate per pixel in Hz"),
          kind_key("event_frames", 16, 2, 4096, "", whole=True,
                   rule="the renders an event capture interpolates between, a whole number in 2..4096")),
    files=(SensorFile("events", ("events.npz", "events.png"), _write_events, _read_events, _events_bytes,
                      "an event capture's (x, y, t µs, p) and its event frame"),),
    sequences=False,
    sequence_refusal=("sensor.kind = 'event' in a sequence: its frames are hours apart (a time-lapse); render an "
                      "event capture with `spectral-cam render` over exposure.time_s, or use 'cmos', 'qis' or "
                      "'spad' here"),
    memory_bytes_per_pixel=_event_memory, memory_remedy=_event_remedy,
    outputs_noun="events",
    direct_use=("it reports brightness changes, not a frame: render the capture with spectral_cam.job.simulate or "
                "`spectral-cam render` (its span of poses), or pass log intensities to "
                "spectral_cam.sensor.events.simulate_events")))
