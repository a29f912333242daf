"""The ``undistortion`` label: cv2.remap maps from the undistorted frame into the image.

References
----------
.. [1] OpenCV, ``initUndistortRectifyMap`` and ``remap`` (Brown-Conrady model).
"""

from __future__ import annotations

from pathlib import Path

from ....exr import write_exr_channels
from .files import stack
from .item import Item
from .registry import LABELS


@LABELS.register("undistortion", options=("undistortion",),
                 description="undistortion.exr: for each undistorted pixel, its column and row in the image "
                             "(cv2.remap's map_x, map_y; identity without lens.distortion)",
                 files=("undistortion.exr",), reader=lambda p: {"undistortion": stack(p, ("map_x", "map_y"))},
                 bytes_per_pixel=8.0)
def _undistortion(item: Item, folder: Path) -> list[Path]:
    from ....optics.distortion import undistortion_map

    coefficients = item.config.lens.distortion
    map_x, map_y = undistortion_map(item.sim.lens, coefficients)
    path = write_exr_channels({"map_x": map_x, "map_y": map_y}, folder / "undistortion.exr",
                              {"spectral_cam_units": "pixel coordinates of the rendered image, centres at integers"})
    item.records["undistortion"] = {"file": "undistortion.exr", "channels": ["map_x", "map_y"],
                                    "model": "Brown-Conrady, OpenCV order [k1, k2, p1, p2, k3]",
                                    "coefficients": list(coefficients),
                                    "use": "cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR)"}
    return [path]
