"""What a capture will cost: the result files' sizes, and the wall time and peak memory.

:func:`estimate_result_bytes` sizes the files a job writes (checked against the free disk
before rendering, :func:`spectral_cam.io.check_free_disk`); :func:`measured_budget` turns a
scene's measured cost (:func:`spectral_cam.render.plan.measure_cost`) into the time and peak
memory a capture plan's budget states. A budget from the config alone cannot say the time: a
least-squares fit of time to samples and the depth probe's seconds over the bundled scenes
erred by 43 % (median), 94 % at worst, since scenes differ 12× in cost per sample.

References
----------
.. [1] docs/design.md, "The capture plan".
"""

from __future__ import annotations

from typing import Iterable

from .scene import SceneConfig

__all__ = ["estimate_result_bytes", "measured_budget", "MEASURED_MODEL"]


#: Bytes per pixel of each developed-image format, uncompressed (an upper bound: PNG and JPEG
#: compress, an EXR is three float32 channels).
_IMAGE_BYTES_PER_PIXEL = {"png": 3, "png16": 6, "jpeg": 3, "tiff": 6, "exr": 12}


def estimate_result_bytes(config: SceneConfig, names: Iterable[str]) -> dict[str, float]:
    """Bytes each named result file (:data:`spectral_cam.job.RESULT_FILES`) will take, from the config alone,
    before rendering: radiance.exr uncompressed (bands × ``render.radiance_precision``), depth
    float32, the DNG's 16-bit mosaic with its crop margin, the developed images uncompressed, a
    sensor kind's own files as its entry sizes them (:data:`spectral_cam.sensor.kinds.SENSOR_KINDS`).
    An upper bound within a few percent for the EXR and DNG (tests/test_output_size.py)."""
    from .sensor.kinds import sensor_file
    from .spectra import parse_bands

    sensor = config.sensor
    pixels = float(sensor.width_px) * sensor.height_px
    header = 16e3  # a file's tags, attributes and offset tables (a 96 × 64 DNG: 2.3 kB)
    margin = 2 * sensor.crop_margin_px
    sizes: dict[str, float] = {}
    for name in names:
        if name == "radiance":
            bands = len(parse_bands(config.render.spectral_bands))
            sizes[name] = header + pixels * bands * (2 if config.render.radiance_precision == "half" else 4)
        elif name == "depth":
            sizes[name] = header + pixels * 4
        elif name == "raw":
            sizes[name] = header + (sensor.width_px + margin) * (sensor.height_px + margin) * 2.0
        elif name == "image":
            sizes[name] = pixels * sum(_IMAGE_BYTES_PER_PIXEL.get(f, 12) for f in config.isp.outputs)
        elif sensor_file(name) is not None:  # a sensor kind's own files, as its entry sizes them
            sizes[name] = float(sensor_file(name).size_bytes(config))
        else:
            sizes[name] = 64e3  # scene.toml and a light's CSV
    return sizes


#: What a measured budget adds to a scene's probed cost (:func:`measured_budget`), fitted by
#: ``benchmarks/bench_plan.py --fit`` to whole jobs of the bundled scenes: the process's start
#: (Python, imports) in seconds, the sensor, ISP and file writing in seconds per megapixel, and
#: the job's memory beyond the probe's resident set in bytes per pixel-channel and per pixel. The
#: adaptive median of means adds its median (seconds per megapixel) and holds its K group means
#: and this many more cubes while it takes it.
MEASURED_MODEL = {"start_s": 0.57, "pipeline_s_per_mp": 0.96, "amon_s_per_mp": 8.0, "bytes_per_pixel_channel": 4.0,
                  "bytes_per_pixel": 363.0, "amon_extra_cubes": 4}


def measured_budget(cost: dict, pixels: float, spp: int, channels: int, depth_s: float,
                    robust_passes: int = 1, calls: int = 1, sensor_bytes: float = 0.0) -> dict:
    """``time_s`` and ``memory_bytes`` of a job from its scene's measured cost
    (:func:`spectral_cam.render.plan.measure_cost`): start, depth probe, scene load, kernel
    compile, ``calls`` render calls (tiles × passes), the samples at the measured rate and the
    pipeline per pixel; the probe's resident memory plus the frame's arrays, plus ``sensor_bytes``
    per pixel for a single-photon sensor's count frames or an event sensor's events
    (:func:`spectral_cam.render.memory.sensor_bytes_per_pixel`)."""
    model = MEASURED_MODEL
    amon = robust_passes > 1
    per_mp = model["pipeline_s_per_mp"] + (model["amon_s_per_mp"] if amon else 0.0)
    time_s = (model["start_s"] + depth_s + cost["scene_load_s"] + cost["compile_s"] + cost["call_s"] * calls
              + cost["s_per_msample"] * pixels * spp / 1e6 + per_mp * pixels / 1e6)
    cubes = robust_passes + model["amon_extra_cubes"] if amon else 1
    memory = cost["resident_bytes"] + pixels * (model["bytes_per_pixel_channel"] * channels * cubes
                                                + model["bytes_per_pixel"] + sensor_bytes)
    return {"time_s": time_s, "memory_bytes": memory}
