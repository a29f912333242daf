"""The ``normals`` label: unit surface normals in camera space (OpenCV axes) and their 8-bit preview.

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3, ``SurfaceInteraction.sh_frame`` (shading normal).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ....exr import write_exr_channels
from .files import stack
from .item import Item
from .registry import LABELS


@LABELS.register("normals", options=("normals",),
                 description="normals.exr: unit surface normal per pixel in camera space, OpenCV axes as camera.json's "
                             "(channels X right, Y down, Z forward), facing the camera (n · view ray < 0), the same "
                             "one ray per pixel as the depth label (0, 0, 0 where no surface); normals.png: its 8-bit "
                             "preview, RGB = 255 (n + 1) / 2 (black where no surface)",
                 files=("normals.exr", "normals.png"), reader=lambda p: {"normals": stack(p, ("X", "Y", "Z"))},
                 bytes_per_pixel=15.0)
def _normals(item: Item, folder: Path) -> list[Path]:
    import cv2

    from ....render import render_normal_map

    t0 = time.perf_counter()
    normals, z = render_normal_map(item.config, lens=item.sim.lens)
    exr = write_exr_channels({axis: normals[..., k] for k, axis in enumerate("XYZ")}, folder / "normals.exr",
                             {"spectral_cam_units": "unit normal, camera space, OpenCV axes: X right, Y down, "
                                                    "Z forward; facing the camera; 0 where no surface"})
    hit = np.isfinite(z)
    preview = np.where(hit[..., None], np.round((normals + 1.0) * 127.5), 0).astype(np.uint8)
    png = folder / "normals.png"
    if not cv2.imwrite(str(png), np.ascontiguousarray(preview[..., ::-1])):  # OpenCV writes BGR
        raise OSError(f"could not write {png}")
    item.records["normals"] = {
        "files": ["normals.exr", "normals.png"], "channels": ["X", "Y", "Z"],
        "axes": "camera space, OpenCV (camera.json's world_to_camera_opencv): +x right, +y down, +z forward",
        "orientation": "facing the camera: n · (point - camera centre) < 0 (a surface seen from its back is flipped)",
        "normal": "Mitsuba's shading normal (sh_normal): a mesh's interpolated vertex normal, an analytic shape's exact "
                  "one; no normal or bump map is modelled",
        "view": "ideal pinhole through the frame, one ray per pixel through a random point of it, the depth label's ray",
        "png": "RGB = round(255 (n + 1) / 2), black (0, 0, 0) where no surface", "pixels_no_surface": int((~hit).sum())}
    item.timings["normals"] = time.perf_counter() - t0
    return [exr, png]
