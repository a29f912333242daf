"""One render job: scene → radiance → RAW → developed image, written as a result folder.

This is what ``spectral-cam render`` runs and what dataset generation runs per item:

    OUTDIR/radiance.exr   spectral radiance per nm (Fichet et al. spectral EXR layout)
    OUTDIR/depth.exr      camera-space z (m)
    OUTDIR/raw.dng        the simulated RAW
    OUTDIR/image.png      the developed sRGB image (plus any other isp.outputs)
    OUTDIR/meta.json      resolved config, optics, sensor gain, seeds, timings, model decisions
    OUTDIR/scene.toml     the resolved scene, every key written out (render it again to reproduce)

The folder appears in one rename when every file is complete (:func:`io.staged_directory`).

References
----------
.. [1] ../shared/DESIGN.md, "The scene file and the CLI" (the result folder is a contract).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Callable

import numpy as np

from .io import atomic_path, staged_directory
from .scene import SceneConfig

__all__ = ["run_render_job", "simulate", "Simulation", "result_meta", "write_json", "package_versions"]

_PACKAGES = ("spectral_cam", "mitsuba", "drjit", "colour-science", "numpy", "OpenEXR", "rawpy",
             "tifffile", "opencv-python-headless", "scikit-image", "matplotlib")


def package_versions() -> dict[str, str]:
    """Versions of Python, LibRaw and the packages a result depends on (provenance for
    meta.json, validation reports and stress results)."""
    import platform

    import rawpy

    out = {"python": platform.python_version(), "LibRaw": ".".join(map(str, rawpy.libraw_version))}
    for name in _PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def _json_default(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    if callable(value):
        return getattr(value, "__name__", type(value).__name__)
    raise TypeError(f"cannot serialise {type(value).__name__}")


def write_json(data: dict, path: str | Path) -> Path:
    """Write JSON atomically (numpy values converted)."""
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(data, indent=2, default=_json_default, ensure_ascii=False) + "\n")
    return path


@dataclass
class Simulation:
    """One scene through the whole chain, in memory."""

    radiance: "SpectralImage"  # noqa: F821
    raw: "RawImage"  # noqa: F821
    developed: "DevelopedImage"  # noqa: F821
    timings_s: dict


def simulate(config: SceneConfig, *, progress: Callable[[int, int, float], None] | None = None) -> Simulation:
    """Render, expose (auto exposure on the ColorChecker's white patch where there is one)
    and develop one scene; per-stage timings in seconds."""
    from .isp import develop
    from .presets import white_reference_mask
    from .render import render
    from .sensor import expose

    timings: dict[str, float] = {}
    radiance = render(config, progress=progress)
    timings.update({f"render_{k}": v for k, v in radiance.meta["timings_s"].items()})
    t0 = time.perf_counter()
    raw = expose(radiance, config, white_mask=white_reference_mask(config))
    timings["sensor"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    developed = develop(raw, config.isp)
    timings["isp"] = time.perf_counter() - t0
    return Simulation(radiance, raw, developed, timings)


def result_meta(config: SceneConfig, sim: Simulation, files, timings: dict, **extra) -> dict:
    """The meta.json of a result folder: config, optics, render, sensor and ISP records,
    model decisions, files, timings and package versions (``extra`` keys go first)."""
    radiance, developed = sim.radiance, sim.developed
    return {
        **extra,
        "config": config.to_dict(),
        "optics": radiance.meta["optics"],
        "render": {k: v for k, v in radiance.meta.items() if k not in ("optics", "timings_s", "model_decisions")},
        "sensor": sim.raw.meta,
        "isp": {"timings_s": developed.timings_s, **{k: v for k, v in developed.meta.items() if k != "config"}},
        "model_decisions": radiance.meta.get("model_decisions", {}),
        "files": sorted(Path(p).name for p in files) + ["meta.json"],
        "timings_s": timings,
        "versions": package_versions(),
    }


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
    from .isp.encode import write_outputs
    from .raw import write_dng
    from .spectral_exr import write_depth_exr, write_spectral_exr

    started = time.perf_counter()
    spectral_output = config.render.spectral_output if spectral_output is None else spectral_output
    with staged_directory(output, force=force) as stage:
        sim = simulate(config, progress=progress)
        timings = dict(sim.timings_s)
        t0 = time.perf_counter()
        written = []
        if spectral_output and sim.radiance.channels is None:
            written.append(write_spectral_exr(sim.radiance, stage / "radiance.exr"))
        written.append(write_depth_exr(sim.radiance.depth_m, stage / "depth.exr"))
        written.append(write_dng(sim.raw, stage / "raw.dng"))
        written += write_outputs(sim.developed, stage, config.isp.outputs, stem="image",
                                 quality=config.isp.jpeg_quality)
        timings["write"] = time.perf_counter() - t0
        timings["total"] = time.perf_counter() - started
        with atomic_path(stage / "scene.toml") as tmp:  # the resolved scene: re-render with it
            tmp.write_text(config.to_toml(), encoding="utf-8")
        written.append(stage / "scene.toml")
        scene = str(Path(scene_file).resolve()) if scene_file else None
        meta = result_meta(config, sim, written, timings, scene_file=scene)
        write_json(meta, stage / "meta.json")
    return meta
