"""Memory a render needs, estimated before Mitsuba starts, against what the machine has.

A frame too large for memory crashes Mitsuba's process (measured: 20000 × 20000 px segfaults;
4000 × 3000 at 1 spp under a 6 GB limit too), so :func:`check_render_memory` refuses it
first, with the estimate and the remedy.

References
----------
.. [1] Linux kernel documentation, ``/proc/meminfo`` (MemAvailable) and cgroup v2
   ``memory.max``/``memory.current``; POSIX ``getrlimit(RLIMIT_AS)``.
"""

from __future__ import annotations

from ..errors import ConfigError
from ..machine import available_bytes
from ..sensor.events import BYTES_PER_EVENT, expected_events_per_pixel  # noqa: F401  (named here as before)
from ..sensor.kinds import (  # noqa: F401  (the sensor kinds' memory figures, named here as before)
    EVENT_WORK_BYTES_PER_PIXEL, NPZ_CHUNK_BYTES, PHOTON_COUNTING_BYTES_PER_PIXEL, SENSOR_KINDS,
    SPAD_BYTES_PER_PIXEL_PER_LEVEL)

__all__ = ["estimate_render_bytes", "available_bytes", "check_render_memory", "sensor_bytes_per_pixel",
           "expected_events_per_pixel", "sensor_remedy"]

#: The process before the frame: Python, NumPy, Mitsuba's JIT and scene, colour-science
#: (measured 0.45–0.55 GB after a small render).
BASE_BYTES = 0.6e9
#: Mitsuba's own memory per pixel of one render call (film, wavefront, result tensor), 31
#: bands, 16 spp: bare ``mi.render`` peaks at 420–470 MB/MP (docs/bench/bench_render.csv). A
#: call covers one tile (:data:`~spectral_cam.render.scene_dict.TILE_PIXELS`) at most.
MITSUBA_BYTES_PER_CALL_PIXEL = 480.0
#: Bytes per pixel of the frame besides its radiance cube: depth, the sensor's rates and
#: mosaic, the ISP's float images, diffraction's band planes. Measured whole jobs (31 bands,
#: 4 spp, peak RSS): 0.88 GB at 1.06 MP, 1.31 GB at 2.55 MP, 2.93 GB at 12.1 MP, 9.58 GB at
#: 45.7 MP, i.e. 192 B/px beyond the first tile, 124 of them the cube; 100 keeps a margin.
PIPELINE_BYTES_PER_PIXEL = 100.0
#: ``lens.model = "layered"`` holds more per pixel: the depth layers being blurred and
#: composited (measured: 1.83 GB at 1.2 MP, 31 bands, f/2.8 dof_targets, against 0.88 GB
#: thin lens at 1.06 MP: ~780 B/px more), counted as this many radiance cubes plus the
#: 4²-sample depth probe.
LAYERED_EXTRA_CUBES = 6
LAYERED_DEPTH_BYTES_PER_PIXEL = 64.0


def sensor_bytes_per_pixel(config) -> float:
    """Bytes per pixel the sensor's own outputs hold beyond a CMOS frame's, as its kind's entry
    estimates them (:data:`spectral_cam.sensor.kinds.SENSOR_KINDS`, ``memory_bytes_per_pixel``): a
    single-photon capture's ``jot_frames`` count frames (1 B a jot a frame, and the packed bits written
    for one bit) with their working arrays; an event capture's events (:func:`expected_events_per_pixel`
    × ``BYTES_PER_EVENT``) and its frames' log intensities. 0 for a CMOS sensor or a capture whose span
    is metered."""
    return float(SENSOR_KINDS[config.sensor.kind].memory_bytes_per_pixel(config))


def sensor_remedy(config, pixels: float, room_bytes: float) -> str | None:
    """What setting of the sensor fits ``room_bytes`` for its outputs over ``pixels`` pixels (its kind's
    ``memory_remedy``: the ``jot_frames`` or the event capture's ``exposure.time_s``); None when nothing
    of it would."""
    remedy = SENSOR_KINDS[config.sensor.kind].memory_remedy
    return remedy(config, room_bytes / pixels) if remedy else None


def estimate_render_bytes(width_px: int, height_px: int, channels: int = 31, *, layered: bool = False,
                          robust_passes: int = 1, sensor_bytes: float = 0.0, lens_model: str | None = None) -> float:
    """Peak memory (bytes) of a render → expose → develop job on a ``width_px`` ×
    ``height_px`` frame whose radiance has ``channels`` float32 values per pixel (31 bands by
    default; 6 for ``render.bands = "camera"``); ``lens_model`` the model rendering it, whose entry's
    ``memory_bytes_per_pixel`` adds what it holds beyond the cube (``layered=True``: the ``"layered"``
    model's);
    ``robust_passes`` K > 1 for the adaptive median of means, which holds K pass images of a tile;
    ``sensor_bytes`` per pixel for a single-photon or event sensor's outputs
    (:func:`sensor_bytes_per_pixel`).

    The frame renders in tiles of at most
    :data:`~spectral_cam.render.scene_dict.TILE_PIXELS` pixels, so Mitsuba's share is one
    tile's; the whole frame holds its radiance cube and the pipeline's per-pixel arrays.

    Examples
    --------
    >>> round(estimate_render_bytes(8256, 5504) / 1e9, 1)  # a 45 MP full-frame sensor
    11.3
    """
    from .scene_dict import TILE_PIXELS

    pixels = float(width_px) * float(height_px)
    per_pixel = 4.0 * channels + PIPELINE_BYTES_PER_PIXEL + float(sensor_bytes)
    per_pixel += lens_bytes_per_pixel("layered" if layered else lens_model, channels)
    tile = min(pixels, TILE_PIXELS)
    robust = tile * 4.0 * channels * (robust_passes + 1) if robust_passes > 1 else 0.0
    return BASE_BYTES + pixels * per_pixel + tile * MITSUBA_BYTES_PER_CALL_PIXEL + robust


def lens_bytes_per_pixel(lens_model: str | None, channels: int) -> float:
    """Bytes per pixel the lens model ``lens_model`` holds beyond the radiance cube (its
    :data:`~spectral_cam.render.lens_models.LENS_MODELS` entry's estimate; 0 for None or ``"auto"``)."""
    from .lens_models import LENS_MODELS

    if lens_model in (None, "auto"):
        return 0.0
    return float(LENS_MODELS[lens_model].memory_bytes_per_pixel(channels))


def check_render_memory(width_px: int, height_px: int, *, channels: int = 31, layered: bool = False,
                        what: str = "this frame", robust_passes: int = 1, config=None,
                        lens_model: str | None = None) -> None:
    """Refuse a frame whose job would not fit in memory (:func:`estimate_render_bytes`), with the
    sensor's outputs (:func:`sensor_bytes_per_pixel`) where ``config`` is given.

    Raises
    ------
    ConfigError
        With the estimate, what is available and what to change.
    """
    sensor = sensor_bytes_per_pixel(config) if config is not None else 0.0

    model = "layered" if layered else lens_model

    def need(width, height, channels=channels, model=model, sensor=sensor):
        return estimate_render_bytes(width, height, channels, robust_passes=robust_passes, sensor_bytes=sensor,
                                     lens_model=model)

    have = available_bytes()
    if need(width_px, height_px) > have:
        side = 2
        while need(2 * side, 2 * side) <= have:
            side *= 2
        while need(side + 64, side + 64) <= have:
            side += 64
        remedies = [f"lower sensor.width_px/height_px (about {side} × {side} px fits)"]
        if sensor:
            pixels = float(width_px) * float(height_px)
            fitting = sensor_remedy(config, pixels, have - need(width_px, height_px, sensor=0.0))
            if fitting:
                remedies.insert(0, fitting)
        if lens_bytes_per_pixel(model, channels):
            remedies.append(f"lens.model = \"thin\" (path-traced defocus: about "
                            f"{need(width_px, height_px, model='thin') / 1e9:.1f} GB)")
        if channels > 6:
            remedies.append(f"render.bands = \"camera\" (6 values a pixel instead of {channels}: about "
                            f"{need(width_px, height_px, 6) / 1e9:.1f} GB)")
        outputs = (f" ({sensor * width_px * height_px / 1e9:.3g} GB of it the {config.sensor.kind} sensor's "
                   f"{SENSOR_KINDS[config.sensor.kind].outputs_noun})") if sensor else ""
        raise ConfigError(
            f"{what} ({width_px} × {height_px} px) needs about {need(width_px, height_px) / 1e9:.1f} GB of memory"
            f"{outputs} and {have / 1e9:.1f} GB are available; {', or '.join(remedies)}; or free memory")
