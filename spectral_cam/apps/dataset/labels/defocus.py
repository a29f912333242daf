"""The ``defocus`` label: the signed thin-lens circle of confusion per pixel (:func:`~.physics.defocus_map_px`).

References
----------
.. [1] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10.
"""

from __future__ import annotations

from pathlib import Path

from ....exr import write_exr_channels
from .files import stack
from .item import Item
from .physics import defocus_map_px
from .registry import LABELS


@LABELS.register("defocus", options=("defocus",),
                 description="defocus.exr: signed thin-lens CoC diameter in pixels, channel CoC",
                 files=("defocus.exr",), reader=lambda p: {"defocus": stack(p, ("CoC",))[..., 0]}, bytes_per_pixel=4.0)
def _defocus(item: Item, folder: Path) -> list[Path]:
    path = write_exr_channels({"CoC": defocus_map_px(item.sim.lens, item.sim.radiance.depth_m)}, folder / "defocus.exr",
                      {"spectral_cam_units": "signed CoC diameter, pixels (+ behind focus)"})
    item.records["defocus"] = {"file": "defocus.exr", "channel": "CoC", "units": "px",
                               "formula": "A*f*(z - z_f)/(z*(z_f - f))/pixel_pitch, A = f/N",
                               "sign": "+ behind the focus plane, - in front"}
    return [path]
