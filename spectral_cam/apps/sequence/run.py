"""Run a sequence: render every frame's radiance (in parallel on the dataset's executor,
resumable), then run the camera over the frames in order — its auto exposure and auto white
balance are control loops whose state passes from frame to frame — and write each frame's RAW,
developed image and meta.

The radiance does not depend on the exposure, so the renders are independent and the camera
pass is cheap: one render serves every camera mode (auto, locked, manual) of a study. Frame k
is taken with the exposure and balanced with the white the controllers held after frame k − 1
(causal, as in a camera); frame 0 with a one-shot auto exposure and its own white. A locked
mode holds the settings the auto controllers find on ``lock_frame`` (by default the middle one).

Layout of ``OUT``::

    render/NNNN/   radiance.npz, meta.json, scene.toml   (the renders; reused on resume)
    <mode>/NNNN/   raw.dng, image.png, depth.exr, defocus.exr, camera.json, meta.json   (the camera's frames)
                   flow_to_next.exr   (forward flow to frame NNNN + 1 in pixels; not on the last frame)
    <mode>/frames.csv                                      (per frame: hour, exposure, ISO, white, errors)
    sequence.json                                          (the spec and the modes)

References
----------
.. [1] docs/design.md, "Sequences".
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import time
from dataclasses import replace
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from ...control import AutoExposure, AutoWhiteBalance, ExposureState
from ...control.white_balance_loop import WhiteState
from ...errors import ConfigError
from ...io import staged_directory
from ...metering import bayer_luminance
from ...records import write_json
from ...scene import SceneConfig, scene_from_dict
from .spec import SequenceSpec

__all__ = ["render_frames", "run_camera", "run_sequence", "render_frame", "bayer_stats", "MODES"]

#: Camera modes a study can run: the spec's controllers, or both held at the lock frame.
MODES = ("auto", "locked")


# ----------------------------------------------------------------------------- renders
def _frame_hash(config: SceneConfig) -> str:
    return hashlib.sha256(config.to_toml().encode()).hexdigest()[:16]


def render_frame(task: Mapping) -> dict:
    """Render one frame's radiance and depth into ``task["folder"]`` (a worker's task)."""
    from ...render import render

    folder = Path(task["folder"])
    config = scene_from_dict(task["scene"])
    started = time.perf_counter()
    image = render(config, with_depth=True)
    stage = folder.with_name(folder.name + ".partial")
    stage.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(stage / "radiance.npz", data=image.data, wavelengths=image.wavelengths_nm,
                        edges=image.band_edges_nm, depth=image.depth_m if image.depth_m is not None else np.zeros(0))
    resolved = config.replace(**{"illuminant.spd": image.meta["illuminant_spd"],
                                 "illuminant.emitter": image.meta["illuminant_emitter"]})
    (stage / "scene.toml").write_text(resolved.to_toml())
    meta = {k: v for k, v in image.meta.items() if k not in ("pass_seeds",)}
    write_json({"hash": task["hash"], "channels": list(image.channels or []),
                "seconds": time.perf_counter() - started, "render": meta}, stage / "meta.json")
    if folder.exists():
        import shutil

        shutil.rmtree(folder)
    stage.rename(folder)
    return {"frame": task["index"], "seconds": time.perf_counter() - started}


def render_frames(spec: SequenceSpec, output: Path, *, executor=None, scheduler=None, workers=None,
                  log=None) -> dict:
    """Render the frames not yet rendered (a frame whose scene changed is rendered again)."""
    from ..dataset.run import open_executor

    tasks = []
    for index in range(len(spec)):
        config = spec.frame_config(index)
        folder = output / "render" / f"{index:04d}"
        digest = _frame_hash(config)
        try:
            done = json.loads((folder / "meta.json").read_text())["hash"] == digest
        except (OSError, ValueError, KeyError):
            done = False
        if not done:
            tasks.append({"index": index, "scene": config.to_dict(), "folder": str(folder), "hash": digest})
    if not tasks:
        return {"rendered": 0, "resumed": len(spec)}
    with open_executor(executor, scheduler, workers) as (pool, _, _threads):
        futures = [pool.submit(render_frame, task) for task in tasks]
        for future in futures:
            result = future.result()
            if log:
                log(f"frame {result['frame']} rendered in {result['seconds']:.1f} s")
    return {"rendered": len(tasks), "resumed": len(spec) - len(tasks)}


def _load_frame(folder: Path):
    from ...image import SpectralImage
    from ...optics import ThinLens
    from ...scene import load_scene

    config = load_scene(folder / "scene.toml")
    arrays = np.load(folder / "radiance.npz")
    meta = json.loads((folder / "meta.json").read_text())
    depth = arrays["depth"] if arrays["depth"].size else None
    image = SpectralImage(arrays["data"], arrays["wavelengths"], arrays["edges"], depth, meta["render"],
                          tuple(meta["channels"]) or None, ThinLens.from_config(config.lens, config.sensor))
    return config, image


# ----------------------------------------------------------------------------- the camera
def bayer_stats(raw) -> np.ndarray:
    """(H/2, W/2, 3) camera RGB from the RAW's 2 × 2 Bayer cells (the two greens averaged),
    black-subtracted and divided by the white level's headroom: the statistics a camera's AE and
    AWB read (1 = saturation)."""
    from ...cfa import tile_layout

    mosaic = (raw.mosaic.astype(np.float64) - raw.black_level) / (raw.white_level - raw.black_level)
    h, w = (mosaic.shape[0] // 2) * 2, (mosaic.shape[1] // 2) * 2
    if raw.cfa == "none":  # a monochrome sensor: each cell's mean in all three (issue 25 #11)
        cells = mosaic[:h, :w].reshape(h // 2, 2, w // 2, 2).mean(axis=(1, 3))
        return np.repeat(cells[..., None], 3, axis=-1)
    layout = tile_layout(raw.cfa)
    planes = {0: [], 1: [], 2: []}
    for a in (0, 1):
        for b in (0, 1):
            planes[layout[a][b]].append(mosaic[a:h:2, b:w:2])
    return np.stack([np.mean(planes[c], axis=0) for c in range(3)], axis=-1)


def _capture(image, config: SceneConfig, *, frame_seed: int):
    """The frame's RAW: the sensor kind's capture (:func:`spectral_cam.sensor.kinds.capture`, the render
    job's too): the CMOS model's, or a single-photon sensor's reconstruction (its frames are a capture's,
    the RAW what the camera loop reads). A kind whose entry takes no sequence (an event sensor: a
    sequence's frames are hours apart, an event capture is a render job's span of poses) is refused."""
    from ...sensor.kinds import capture

    return capture(image, config, frame_seed=frame_seed, sequence=True).raw


def _initial_exposure(image, config: SceneConfig, ae: AutoExposure) -> ExposureState:
    """A one-shot exposure for the first frame: the sensor's own auto exposure (the same camera
    meter) scaled to the controller's reading of the RAW cells, so the loop starts at its goal."""
    probe = _capture(image, config.replace(**{"exposure.time_s": "auto", "exposure.iso": ae.base_iso,
                                              "exposure.metering": ae.metering,
                                              "exposure.auto_fraction": ae.highlight_target}), frame_seed=0)
    time_s = float(probe.meta["exposure_s"])
    from ...control.exposure_loop import meter

    metered = meter(bayer_luminance(bayer_stats(probe)), ae.metering, highlight_target=ae.highlight_target)
    scale = ae.target / metered if metered > 0 else 1.0
    t, iso = ae.split(math.log2(time_s * scale))
    return ExposureState(t, iso)


def _expose(image, config: SceneConfig, state: ExposureState, index: int):
    """The frame's RAW at the controller's exposure (the same noise for the same frame)."""
    return _capture(image, config.replace(**{"exposure.time_s": state.time_s, "exposure.iso": state.iso}),
                    frame_seed=index)


def _develop(raw, config: SceneConfig, white):
    from ...isp import develop

    return develop(raw, replace(config.isp, white_balance="manual", wb_gains=tuple(1.0 / w for w in white)))


def _write_labels(image, folder: Path) -> None:
    """The frame's depth (m) and signed thin-lens defocus (px) labels, as a dataset item has."""
    from ...exr import write_exr_channels
    from ...spectral_exr import write_depth_exr
    from ..dataset.labels import defocus_map_px

    if image.depth_m is not None:
        write_depth_exr(image.depth_m, folder / "depth.exr")
        write_exr_channels({"CoC": defocus_map_px(image.lens, image.depth_m)}, folder / "defocus.exr",
                           {"spectral_cam_units": "signed CoC diameter, pixels (+ behind focus)"})


def _write_camera(image, config, raw, folder: Path) -> dict | None:
    """The frame's camera.json (:func:`spectral_cam.camera_record.camera_record`): intrinsics,
    distortion, pose and the exposure this camera mode chose (frames rendered before camera.json
    existed carry no pose: none is written). Returns the record."""
    from ...camera_record import capture_camera_record

    record = capture_camera_record(image, config, raw)
    if record is not None:
        write_json(record, folder / "camera.json")
    return record


def _write_flow_to_next(image, camera: dict | None, next_camera: dict | None, folder: Path) -> None:
    """flow_to_next.exr: forward flow (px) from this frame to the next
    (:func:`spectral_cam.render.motion.pose_flow_px`), where both have a pose and this one a
    depth."""
    from ...exr import write_exr_channels
    from ...render.motion import pose_flow_px

    if camera is None or next_camera is None or image.depth_m is None:
        return
    flow = pose_flow_px(np.asarray(image.depth_m), camera, next_camera)
    write_exr_channels({"dx": flow[..., 0], "dy": flow[..., 1]}, folder / "flow_to_next.exr",
                       {"spectral_cam_units": "pixels, this frame to the next; x right, y down; static world"})


def run_camera(spec: SequenceSpec, output: Path, mode: str, *, lock_frame: int | None = None) -> list[dict]:
    """Run the camera in ``mode`` over the rendered frames; write ``output/<mode>``; the rows of
    its frames.csv."""
    from ...isp import write_image
    from ...raw import write_dng

    if mode not in MODES:
        raise ConfigError(f"camera mode {mode!r}: valid: {', '.join(MODES)}")
    control = spec.control()
    ae, awb = control.exposure, control.white_balance
    frames = [_load_frame(output / "render" / f"{k:04d}") for k in range(len(spec))]
    lock = len(spec) // 2 if lock_frame is None else lock_frame
    if not 0 <= lock < len(spec):
        raise ConfigError(f"lock_frame = {lock}: give a frame 0..{len(spec) - 1}")
    if mode == "locked":  # what the auto controllers settle on at the lock frame, held for every frame
        config, image = frames[lock]
        state = _initial_exposure(image, config, ae)
        held_white = awb.step(None, bayer_stats(_expose(image, config, state, lock))).white
        ae, awb = replace(ae, mode="locked"), AutoWhiteBalance(mode="manual", manual_white=held_white)
    else:
        state = _initial_exposure(frames[0][1], frames[0][0], ae)
    white_state: WhiteState | None = None
    rows, cameras = [], []
    with staged_directory(output / mode, force=True) as stage:
        for index, (config, image) in enumerate(frames):
            raw = _expose(image, config, state, index)
            if white_state is None:  # the first frame: balanced for its own white
                white_state = awb.step(None, bayer_stats(raw))
            developed = _develop(raw, config, white_state.white)
            stats = bayer_stats(raw)
            folder = stage / f"{index:04d}"
            folder.mkdir()
            write_dng(raw, folder / "raw.dng")
            write_image(developed, folder / "image.png")
            _write_labels(image, folder)
            cameras.append(_write_camera(image, config, raw, folder))
            if index:
                _write_flow_to_next(frames[index - 1][1], cameras[-2], cameras[-1], stage / f"{index - 1:04d}")
            next_state = ae.step(state, bayer_luminance(stats))
            next_white = awb.step(white_state, stats)
            row = {"frame": index, "hour": spec.hours[index], "exposure_s": state.time_s, "iso": state.iso,
                   "ae_error_ev": next_state.error_ev, "ae_adjusted": next_state.adjusted,
                   "white_r": white_state.white[0], "white_b": white_state.white[2],
                   "awb_estimate_r": next_white.estimate[0] if next_white.estimate else None,
                   "awb_estimate_b": next_white.estimate[2] if next_white.estimate else None}
            write_json({"config": config.to_dict(), "mode": mode, "camera": control.to_dict(), "frame": row,
                        "render": image.meta}, folder / "meta.json")
            rows.append(row)
            state, white_state = next_state, next_white
        with (stage / "frames.csv").open("w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    return rows


def spec_fingerprint(spec: SequenceSpec) -> str:
    """SHA-256 of what a sequence is: every frame's resolved scene and the camera table."""
    frames = [spec.frame_config(k).to_dict() for k in range(len(spec))]
    blob = json.dumps({"frames": frames, "camera": spec.camera}, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()


def _claim_output(spec: SequenceSpec, output: Path, force: bool) -> str:
    """The output contract ``render`` and ``dataset`` have (issue 25 #1: a shorter spec deleted an
    earlier run's frames without --force and left stale renders): an existing folder is resumed
    only for the same spec; anything else is refused without ``force``, and with it cleared."""
    import shutil

    fingerprint = spec_fingerprint(spec)
    if output.exists() and any(output.iterdir()):
        record = output / "sequence.json"
        same = False
        if record.is_file():
            try:
                same = json.loads(record.read_text()).get("spec_sha256") == fingerprint
            except (OSError, ValueError):
                same = False
        if not same:
            if not force:
                raise ConfigError(f"{output} holds another run (a different spec, or not a sequence); give --force "
                                  "to replace it, or another -o folder (a run of the same spec resumes)")
            for child in output.iterdir():
                shutil.rmtree(child) if child.is_dir() else child.unlink()
    output.mkdir(parents=True, exist_ok=True)
    return fingerprint


def _check_disk(spec: SequenceSpec, output: Path, modes: Sequence[str]) -> None:
    """Refuse, before any frame renders, a sequence whose files cannot fit on the disk: each
    frame's radiance and depth (stored for the camera runs) and, per camera mode, its RAW and
    image (:func:`spectral_cam.budget.estimate_result_bytes`, uncompressed: an upper bound)."""
    from ...io import check_free_disk
    from ...budget import estimate_result_bytes

    config = spec.frame_config(0)
    frame = sum(estimate_result_bytes(config, ["radiance", "depth"]).values())
    camera = sum(estimate_result_bytes(config, ["raw", "image"]).values()) * len(modes)
    check_free_disk((frame + camera) * len(spec), output, what=f"{len(spec)} frames of about "
                    f"{(frame + camera) / 1e6:.3g} MB each", remedy="free space, choose -o elsewhere, or render "
                    "fewer or smaller frames")


def run_sequence(spec: SequenceSpec, output: str | Path, *, modes: Sequence[str] = ("auto",), executor=None,
                 scheduler=None, workers=None, lock_frame: int | None = None, log=None, force: bool = False) -> dict:
    """Render the frames (resuming a run of the same spec), then run the camera in each of
    ``modes``. An output folder holding anything else is refused unless ``force``.

    Raises
    ------
    ConfigError
        For an output folder of another run without ``force``.
    """
    output = Path(output)
    _check_disk(spec, output, modes)
    fingerprint = _claim_output(spec, output, force)
    write_json({"spec_sha256": fingerprint, "complete": False}, output / "sequence.json")
    renders = render_frames(spec, output, executor=executor, scheduler=scheduler, workers=workers, log=log)
    cameras = {mode: run_camera(spec, output, mode, lock_frame=lock_frame) for mode in modes}
    write_json({"spec_sha256": fingerprint, "complete": True, "hours": list(spec.hours),
                "vary": {k: v if v == "hour" else list(v) for k, v in spec.vary.items()},
                "camera": spec.camera, "modes": list(modes), "renders": renders}, output / "sequence.json")
    return {"renders": renders, "cameras": cameras}
