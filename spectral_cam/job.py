"""One render job: scene → radiance → RAW → developed image, written as a result folder.

This is what ``spectral-cam render`` runs:

    OUTDIR/radiance.exr   spectral radiance per nm (Fichet et al. spectral EXR layout)
    OUTDIR/depth.exr      camera-space z (m)
    OUTDIR/raw.dng        the simulated RAW
    OUTDIR/image.png      the developed sRGB image (plus any other isp.outputs)
    OUTDIR/meta.json      resolved config, optics, sensor gain, seeds, timings, model decisions
    OUTDIR/scene.toml     the resolved scene, every key written out (render it again to reproduce)

The folder appears in one rename when every file is complete (:func:`io.staged_directory`).
A dataset item (:mod:`spectral_cam.apps.dataset`) is the same job: :func:`simulate` builds the
lens once and runs render → expose → develop, :func:`write_files` writes its RAW, image,
radiance and depth, and :func:`write_meta` its meta.json (one layout, :func:`result_meta`).

References
----------
.. [1] docs/design.md, "Result folder (job.py)" (the result folder is a contract).
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from .budget import estimate_result_bytes
from .errors import ConfigError
from .io import atomic_path, check_free_disk, staged_directory
from .records import package_versions, write_json
from .scene import SceneConfig

__all__ = ["run_render_job", "simulate", "Simulation", "write_files", "result_meta", "write_meta", "RESULT_FILES"]


@dataclass
class Simulation:
    """One scene through the whole chain, in memory.

    Attributes
    ----------
    config : SceneConfig
        The scene simulated.
    lens : ThinLens
        The lens built once for the job: the render and the sensor used it.
    radiance : SpectralImage
        The render.
    raw : RawImage
        The exposure.
    developed : DevelopedImage
        The ISP's result.
    timings_s : dict
        Seconds per stage (``render_*``, ``sensor``, ``isp``).
    sensor_outputs : dict
        The sensor kind's own outputs by result-file name (:class:`spectral_cam.sensor.kinds.SensorFile`):
        ``photon_counts`` for a QIS or SPAD, ``events`` for an event sensor; empty for a CMOS.
    """

    config: SceneConfig
    lens: "ThinLens"  # noqa: F821
    radiance: "SpectralImage"  # noqa: F821
    raw: "RawImage"  # noqa: F821
    developed: "DevelopedImage"  # noqa: F821
    timings_s: dict
    sensor_outputs: dict = field(default_factory=dict)

    @property
    def photon_counts(self) -> "PhotonCountingCapture | None":  # noqa: F821
        """A QIS or SPAD capture's frames (``sensor_outputs["photon_counts"]``), else None."""
        return self.sensor_outputs.get("photon_counts")

    @property
    def events(self) -> "EventStream | None":  # noqa: F821
        """An event sensor's stream (``sensor_outputs["events"]``), else None."""
        return self.sensor_outputs.get("events")


def simulate(config: SceneConfig, *, lens=None, progress: Callable[[int, int, float], None] | None = None,
             with_depth: bool = True, outputs: Iterable[str] = ()) -> Simulation:
    """Render, expose and develop one scene; per-stage timings in seconds.

    Parameters
    ----------
    config
        The validated scene.
    lens : ThinLens, optional
        The job's lens, built once (default ``ThinLens.from_config(config.lens, config.sensor)``);
        the render and the sensor's camera equation both use it.
    progress
        Render progress callback (spp done, spp total, seconds).
    with_depth
        Also render the depth map.
    outputs
        The result files that will be written (:data:`RESULT_FILES`): their sizes go into the
        plan's budget.

    Returns
    -------
    Simulation
        Its ``config`` is the capture plan's resolved config (:func:`spectral_cam.render.plan.make_plan`).

    Notes
    -----
    ``exposure.time_s = "auto"`` exposes for the ColorChecker's white patch where the scene has
    one (the render's ``white_reference``), else for the 99th percentile: the same rule as
    :func:`spectral_cam.expose` on a rendered image.
    """
    from .render.plan import make_plan
    from .render.variants import deterministic_threads

    # the sensor has a ring of real pixels around the frame (sensor.crop_margin_px): the RAW
    # carries them with a default crop, every other output is the frame
    with deterministic_threads(config.render.deterministic):  # the probes' decisions too
        plan = make_plan(config, with_margin=True, with_depth=with_depth, lens=lens, outputs=outputs)
        return _simulate_plan(plan, progress)


def _simulate_plan(plan, progress) -> Simulation:
    """:func:`simulate` after its plan: render, expose (the sensor kind's capture,
    :func:`spectral_cam.sensor.kinds.capture`), develop."""
    from .isp import develop
    from .render import render
    from .render.plan import make_plan
    from .sensor.kinds import capture

    config, lens = plan.config, plan.lens  # the resolved config: what was done, what scene.toml writes
    timings: dict[str, float] = {}
    captured = render(plan, progress=progress)
    timings.update({f"render_{k}": v for k, v in captured.meta["timings_s"].items()})

    def render_pose(frame: SceneConfig):
        """One more pose of the scene through the job's lens (an event sensor's span): no margin, no depth."""
        return render(make_plan(frame, with_margin=False, with_depth=False, lens=lens), progress=progress)

    t0 = time.perf_counter()
    sensed = capture(captured, config, render_pose=render_pose)
    radiance = captured.framed()
    timings.update(sensed.timings_s)
    timings["sensor"] = time.perf_counter() - t0 - sum(sensed.timings_s.values())
    t0 = time.perf_counter()
    developed = develop(sensed.raw, config.isp)
    timings["isp"] = time.perf_counter() - t0
    return Simulation(config, lens, radiance, sensed.raw, developed, timings, sensed.outputs)


def _write_radiance(sim: Simulation, folder: Path, stem: str) -> list[Path]:
    from .spectral_exr import write_spectral_exr

    precision = sim.config.render.radiance_precision
    return [write_spectral_exr(sim.radiance, folder / "radiance.exr", precision=precision)]


def _write_depth(sim: Simulation, folder: Path, stem: str) -> list[Path]:
    from .spectral_exr import write_depth_exr

    return [write_depth_exr(sim.radiance.depth_m, folder / "depth.exr")]


def _write_raw(sim: Simulation, folder: Path, stem: str) -> list[Path]:
    from .raw import write_dng

    return [write_dng(sim.raw, folder / "raw.dng")]


def _write_image(sim: Simulation, folder: Path, stem: str) -> list[Path]:
    from .isp.encode import write_outputs

    isp = sim.config.isp
    return write_outputs(sim.developed, folder, isp.outputs, stem=stem, quality=isp.jpeg_quality)


#: The name of a light spectrum a result folder keeps beside its scene.toml (:func:`_write_scene`).
_LIGHT_COPY = re.compile(r"light_[0-9a-f]{16}\.csv")


def _write_scene(sim: Simulation, folder: Path, stem: str) -> list[Path]:
    """scene.toml, the resolved scene; a light spectrum the render read from a scene's emitter
    (kept in the user's cache folder, or beside an earlier result's scene.toml that this job
    renders again) is copied beside it and named relatively, so the folder renders again
    anywhere (issue 25 #2: deleting the cache broke it) and a re-render writes the same
    scene.toml bytes (issue 39 #17: it named the earlier folder's copy)."""
    import json
    import shutil

    text, written = sim.config.to_toml(), []
    spd = sim.config.illuminant.spd
    if spd.lower().endswith(".csv") and Path(spd).is_file() and Path(spd).resolve().parent != folder.resolve():
        from .render.variants import probe_cache_path

        cached = Path(spd).resolve().is_relative_to(probe_cache_path().parent.resolve())
        if cached or _LIGHT_COPY.fullmatch(Path(spd).name):
            local = folder / (f"light_{Path(spd).name}" if cached else Path(spd).name)
            with atomic_path(local) as tmp:
                shutil.copyfile(spd, tmp)
            text = text.replace(f"spd = {json.dumps(spd, ensure_ascii=False)}", f"spd = {json.dumps(local.name)}")
            written.append(local)
    with atomic_path(folder / "scene.toml") as tmp:  # the resolved scene: re-render with it
        tmp.write_text(text, encoding="utf-8")
    return written + [folder / "scene.toml"]


def _write_camera(sim: Simulation, folder: Path, stem: str) -> list[Path]:
    """camera.json: intrinsics, distortion and pose (:func:`spectral_cam.camera_record.camera_record`)."""
    from .camera_record import capture_camera_record

    return [write_json(capture_camera_record(sim.radiance, sim.config, sim.raw), folder / "camera.json")]


def _write_illuminant(sim: Simulation, folder: Path, stem: str) -> list[Path]:
    """illuminant.json: the light's camera RGB, chromaticity and CCT
    (:func:`spectral_cam.camera_record.illuminant_record`)."""
    from .camera_record import illuminant_record

    config = sim.config
    if sim.raw.as_shot_neutral is None:  # a monochrome sensor has no colour to record
        return []
    lux = None if config.scene.mitsuba_xml else config.illuminant.illuminance_lux
    record = illuminant_record(config.illuminant.spd, sim.raw.as_shot_neutral, sensor_model=config.sensor.model,
                               emitter=config.illuminant.emitter, illuminance_lux=lux)
    return [write_json(record, folder / "illuminant.json")]


_WRITERS = {"radiance": _write_radiance, "depth": _write_depth, "raw": _write_raw, "image": _write_image,
            "camera": _write_camera, "illuminant": _write_illuminant, "scene": _write_scene}


def result_files() -> tuple[str, ...]:
    """The files :func:`write_files` can write now: :data:`RESULT_FILES` and every registered sensor
    kind's own (:data:`spectral_cam.sensor.kinds.SENSOR_KINDS`, a kind registered later included)."""
    from .sensor.kinds import SENSOR_KINDS

    return tuple(_WRITERS) + tuple(name for name in SENSOR_KINDS.files() if name not in _WRITERS)


#: The files :func:`write_files` can write: radiance.exr, depth.exr, raw.dng,
#: ``<stem>.<isp.outputs>``, camera.json, illuminant.json, scene.toml and the bundled sensor kinds'
#: own files (photon_counts.npz; events.npz and events.png).
RESULT_FILES = result_files()


def write_files(sim: Simulation, folder: str | Path, names: Iterable[str], *, image_stem: str = "image") -> list[Path]:
    """Write the named files of a simulation into a folder.

    Parameters
    ----------
    sim
        From :func:`simulate`.
    folder
        Where the files go (usually a staging folder of :func:`spectral_cam.io.staged_directory`).
    names
        Among :data:`RESULT_FILES`: ``"radiance"`` (radiance.exr; the render must hold a
        spectrum, not camera-film channels), ``"depth"`` (depth.exr), ``"raw"`` (raw.dng),
        ``"camera"`` (camera.json: intrinsics, distortion, pose), ``"illuminant"`` (illuminant.json:
        the light's camera RGB, chromaticity, CCT; none for a monochrome sensor),
        ``"image"`` (``<image_stem>`` in every ``isp.outputs`` format), ``"scene"``
        (scene.toml, the resolved scene).
    image_stem
        File name of the developed image without suffix.

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    ConfigError
        For a name not in :data:`RESULT_FILES`.
    """
    from .sensor.kinds import sensor_file

    folder = Path(folder)
    written: list[Path] = []
    for name in names:
        if name in _WRITERS:
            written += _WRITERS[name](sim, folder, image_stem)
        elif sensor_file(name) is not None:  # a sensor kind's own file: nothing where this kind made none
            if name in sim.sensor_outputs:
                written += sensor_file(name).write(sim.sensor_outputs[name], folder)
        else:
            raise ConfigError(f"unknown result file {name!r}; valid: {', '.join(result_files())}")
    return written


def result_meta(sim: Simulation, files: Iterable[str | Path], timings: dict, **extra) -> dict:
    """The meta.json of a result folder: config, optics, render, sensor and ISP records,
    model decisions, files, timings and package versions (``extra`` keys go first).

    Parameters
    ----------
    sim
        From :func:`simulate`.
    files
        The files of the folder besides meta.json (names or paths).
    timings
        Seconds per stage.
    **extra
        Keys written before the common ones (``scene_file``, ``dataset``).
    """
    radiance, developed = sim.radiance, sim.developed
    return {
        **extra,
        "config": sim.config.to_dict(),
        "optics": radiance.meta["optics"],
        "render": {k: v for k, v in radiance.meta.items() if k not in ("optics", "timings_s", "model_decisions", "plan")},
        "sensor": sim.raw.meta,
        "isp": {"timings_s": developed.timings_s, **{k: v for k, v in developed.meta.items() if k != "config"}},
        "model_decisions": radiance.meta.get("model_decisions", {}),
        "plan": {k: v for k, v in radiance.meta.get("plan", {}).items() if k not in ("decisions", "optics")},
        "files": sorted(Path(p).name for p in files) + ["meta.json"],
        "timings_s": timings,
        "versions": package_versions(),
    }


def write_meta(sim: Simulation, folder: str | Path, files: Iterable[str | Path], timings: dict, **extra) -> dict:
    """Write ``<folder>/meta.json`` (:func:`result_meta`, strict JSON) and return its content."""
    meta = result_meta(sim, files, timings, **extra)
    write_json(meta, Path(folder) / "meta.json")
    return meta


def render_job_files(config: SceneConfig, spectral_output: bool | None = None) -> list[str]:
    """The result files (:data:`RESULT_FILES`) a render job writes: radiance.exr when a spectral
    output is asked (``render.spectral_output``, or ``spectral_output`` given) and the film can
    hold one, then depth, RAW, the sensor kind's own files, image, camera.json, illuminant.json and scene."""
    from .sensor.kinds import SENSOR_KINDS

    spectral_output = config.render.spectral_output if spectral_output is None else spectral_output
    names = ["depth", "raw", "image", "camera", "illuminant", "scene"]
    names[2:2] = [f.name for f in SENSOR_KINDS[config.sensor.kind].files]
    if spectral_output and config.render.bands != "camera":
        names.insert(0, "radiance")
    return names


def plan_render_job(config: SceneConfig, *, spectral_output: bool | None = None, measure: bool = False):
    """The capture plan of :func:`run_render_job` (:func:`spectral_cam.render.plan.make_plan`), with the
    budget of its result files: what ``spectral-cam render --dry-run`` prints (with ``measure``:
    a small radiance probe times the scene). Renders only the probes the decisions need (the
    depth map, an XML scene's emitters, a focus object)."""
    from .render.plan import make_plan

    return make_plan(config, with_margin=True, with_depth=True, outputs=render_job_files(config, spectral_output),
                     measure=measure)


def run_render_job(
    config: SceneConfig,
    output: str | Path,
    *,
    force: bool = False,
    progress: Callable[[int, int, float], None] | None = None,
    scene_file: str | Path | None = None,
    spectral_output: bool | None = None,
) -> dict:
    """Render, expose, develop and write one result folder; returns its meta.json content.

    Parameters
    ----------
    config
        The validated scene.
    output
        Result folder; must not exist unless ``force``.
    progress
        Render progress callback (spp done, spp total, seconds).
    scene_file
        Recorded in meta.json.
    spectral_output
        Write radiance.exr (the spectral cube); default ``render.spectral_output``. A
        camera-film render (``render.bands = "camera"``) has no spectrum to write.
    """
    started = time.perf_counter()
    names = render_job_files(config, spectral_output)
    sizes = estimate_result_bytes(config, names)
    parts = ", ".join(f"{name} {size / 1e9:.2g} GB" for name, size in sizes.items() if size > 1e8)
    check_free_disk(sum(sizes.values()), Path(output).parent,
                    what=f"the result folder {output}" + (f" ({parts})" if parts else ""),
                    remedy="free space or choose -o elsewhere; render.radiance_precision = 'half' halves "
                           "radiance.exr, render.spectral_output = false drops it")
    with staged_directory(output, force=force) as stage:
        sim = simulate(config, progress=progress, outputs=names)
        timings = dict(sim.timings_s)
        t0 = time.perf_counter()
        if "radiance" in names and sim.radiance.channels is not None:
            names.remove("radiance")
        written = write_files(sim, stage, names)
        timings["write"] = time.perf_counter() - t0
        timings["total"] = time.perf_counter() - started
        scene = str(Path(scene_file).resolve()) if scene_file else None
        meta = write_meta(sim, stage, written, timings, scene_file=scene)
    return meta
