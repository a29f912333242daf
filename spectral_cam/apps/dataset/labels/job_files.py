"""The labels that are the render job's own result files (:func:`spectral_cam.job.write_files`):
the RAW, the developed image, the spectral cube, depth, the camera and illuminant records, and each
sensor kind's own files (a single-photon sensor's frames, an event stream: :func:`add_sensor_file_labels`
reads them from the kinds' entries). One writer serves them all; each has its own reader.

Their size estimates here are nominal (the defaults: 8-bit image, 31 float32 bands); the dry run
and the disk check size them from the scene itself (:func:`spectral_cam.budget.estimate_result_bytes`).

References
----------
.. [1] docs/design.md, "Result folder (job.py)".
.. [2] Adobe DNG Specification 1.6 (read by tifffile as a TIFF).
"""

from __future__ import annotations

import functools
import json
from pathlib import Path

import numpy as np

from ....errors import RawFormatError
from ....job import write_files
from .files import IMAGE_SUFFIXES, read_image, stack
from .registry import LABELS

__all__ = ["read_raw", "read_radiance", "read_camera", "add_sensor_file_labels"]


def _result_file(item, folder: Path, *, name: str) -> list[Path]:
    """A file of the render job's result folder (:func:`spectral_cam.job.write_files`)."""
    return write_files(item.sim, folder, [name])


def read_raw(path: Path) -> dict:
    """``raw``: the DNG's (H + 2m, W + 2m) uint16 CFA mosaic (m: the crop margin)."""
    import tifffile

    try:
        return {"raw": tifffile.imread(str(path))}
    except Exception as exc:  # tifffile raises several types on corrupt files
        raise RawFormatError(f"{path} is not a readable DNG: {exc}") from None


def read_radiance(path: Path) -> dict:
    """``radiance`` (H, W, B) float32 per nm and ``radiance_nm``, its B wavelengths."""
    from ....spectral_exr import read_spectral_exr

    image = read_spectral_exr(path)
    return {"radiance": np.asarray(image.data, dtype=np.float32),
            "radiance_nm": np.asarray(image.wavelengths_nm, dtype=np.float64)}


def read_camera(path: Path) -> dict:
    """camera.json as a dict, ``K`` and the poses as float64 arrays."""
    record = json.loads(path.read_text(encoding="utf-8"))
    for key in ("K", "distortion", "world_to_camera_opencv", "world_to_camera_opengl", "camera_to_world_opencv"):
        if key in record:
            record[key] = np.asarray(record[key], dtype=np.float64)
    return {"camera": record}


def _read_json(path: Path) -> dict:
    return {path.stem: json.loads(path.read_text(encoding="utf-8"))}


_IMAGES = tuple(f"image{suffix}" for suffix in IMAGE_SUFFIXES)

#: name → (description, files, reader, bytes per pixel, fixed bytes, names the reader takes)
_JOB_LABELS = {
    "raw": ("raw.dng: the simulated RAW: CFA mosaic, uint16 DN with its black and white levels and DNG colour "
            "tags (read by LibRaw, dcraw, darktable, Adobe's SDK)", ("raw.dng",), read_raw, 2.0, 16e3, ()),
    "image": ("image.<isp.outputs>: the developed sRGB image (every isp.outputs format)", ("image.*",),
              lambda p: {"image": read_image(p)}, 3.0, 4096.0, _IMAGES),
    "radiance": ("radiance.exr: spectral radiance per nm, Fichet et al. layout (opt-in)", ("radiance.exr",),
                 read_radiance, 31 * 4.0, 16e3, ()),
    "depth": ("depth.exr: camera-space z, metres (channel Z; inf where no surface)", ("depth.exr",),
              lambda p: {"depth": stack(p, ("Z",))[..., 0]}, 4.0, 4096.0, ()),
    "camera": ("camera.json: intrinsics K (pixels), OpenCV distortion, pose world → camera (OpenCV and "
               "OpenGL axes), focus, aperture, exposure", ("camera.json",), read_camera, 0.0, 8192.0, ()),
    "illuminant": ("illuminant.json: the light's camera RGB (max 1, green 1, unit length), CIE xy, CCT and Duv",
                   ("illuminant.json",), _read_json, 0.0, 4096.0, ()),
}
for _name, (_description, _files, _reader, _per_pixel, _fixed, _read_from) in _JOB_LABELS.items():
    LABELS.add(_name, functools.partial(_result_file, name=_name), description=_description, files=_files,
               reader=_reader, bytes_per_pixel=_per_pixel, fixed_bytes=_fixed, read_from=_read_from)


def add_sensor_file_labels() -> list[str]:
    """A label for every sensor kind's own result files not yet one (:data:`SENSOR_KINDS`' ``SensorFile``
    entries: a QIS's photon_counts, an event sensor's events), written by the job's writer; an item of
    another kind writes nothing for it. Called when this module loads; a kind registered later calls it
    again. Returns the names added."""
    from ....sensor.kinds import SENSOR_KINDS

    added = []
    for name, file in SENSOR_KINDS.files().items():
        if name in LABELS:
            continue
        kinds = [kind for kind, entry in SENSOR_KINDS.items() if file in entry.files]
        description = (f"{' and '.join(file.files)}: {file.description} (sensor.kind {', '.join(kinds)}); nothing "
                       "for the other sensor kinds")
        # the size is the budget's (estimate_result_bytes asks the entry), 0 here as for any unwritten label
        LABELS.add(name, functools.partial(_result_file, name=name), description=description, files=file.files,
                   reader=None, bytes_per_pixel=0.0, fixed_bytes=0.0)
        added.append(name)
    return added


add_sensor_file_labels()
