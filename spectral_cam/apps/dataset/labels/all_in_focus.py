"""The ``all_in_focus`` label: the item's pose through an ideal pinhole, and the blur measured against depth.

References
----------
.. [1] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10 (blur against depth).
"""

from __future__ import annotations

import time
from pathlib import Path

from ....job import simulate, write_files
from .files import IMAGE_SUFFIXES, read_image
from .item import Item
from .physics import BLUR_PRESETS, clean_camera_rgb, measure_scene_blur
from .registry import LABELS


@LABELS.register("all_in_focus", options=("all_in_focus", "blur"),
                 description="all_in_focus.<isp.outputs>: the same pose through an ideal pinhole (no blur, "
                             "distortion or motion) at the same exposure",
                 files=("all_in_focus.*",), read_from=tuple(f"all_in_focus{s}" for s in IMAGE_SUFFIXES),
                 reader=lambda p: {"all_in_focus": read_image(p)}, bytes_per_pixel=3.0)
def _all_in_focus(item: Item, folder: Path) -> list[Path]:
    t0 = time.perf_counter()
    config, exposure_s = item.config, item.exposure_s
    # the ideal pinhole: no blur, no aperture shape, no distortion (the undistortion label maps the
    # item's image onto it), no motion
    sharp_config = config.replace(**{"lens.model": "pinhole", "exposure.time_s": exposure_s, "lens.blades": 0,
                                     "lens.distortion": [0.0] * 5, "motion.camera_velocity_mps": [0.0] * 3,
                                     "motion.camera_angular_velocity_dps": [0.0] * 3,
                                     "motion.object_velocity_mps": [0.0] * 3})
    sharp = simulate(sharp_config, lens=item.sim.lens, with_depth=False)
    files = write_files(sharp, folder, ["image"], image_stem="all_in_focus")
    item.timings["all_in_focus"] = time.perf_counter() - t0
    item.records["all_in_focus"] = {
        "lens_model": "pinhole", "exposure_s": exposure_s, "files": sorted(p.name for p in files),
        "render": {k: v for k, v in sharp.radiance.meta.items() if k not in ("optics", "timings_s", "model_decisions")},
        "model_decisions": sharp.radiance.meta.get("model_decisions", {})}
    if item.measure_blur and config.scene.preset in BLUR_PRESETS and not config.scene.mitsuba_xml:
        t0 = time.perf_counter()
        pinhole = clean_camera_rgb(sharp.radiance, sharp_config, exposure_s=exposure_s).sum(axis=-1)
        item.records["blur"] = measure_scene_blur(config, item.sim.radiance.depth_m, pinhole,
                                                  item.clean_rgb.sum(axis=-1), lens=item.sim.lens)
        item.timings["blur_measurement"] = time.perf_counter() - t0
    return files
