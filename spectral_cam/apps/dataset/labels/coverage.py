"""The ``coverage`` label: the soft segmentation under defocus, Cryptomatte's ranked (id, coverage) pairs.

References
----------
.. [1] Friedman, J., & Jones, A. C. (2015). Fully automatic ID mattes with support for motion blur and
   transparency (Cryptomatte). SIGGRAPH Posters.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ....exr import write_exr_channels
from .files import exr_channels, stack
from .instances import Instances, merge_ranks
from .item import Item
from .registry import LABELS


def _read_coverage(path: Path) -> dict[str, np.ndarray]:
    """``coverage`` (H, W, R) int32 ranked ids and ``coverage_fraction`` (H, W, R) their shares."""
    ranks = sum(1 for name in exr_channels(path) if name.startswith("id_"))
    return {"coverage": stack(path, tuple(f"id_{k}" for k in range(ranks))).astype(np.int32),
            "coverage_fraction": stack(path, tuple(f"coverage_{k}" for k in range(ranks)))}


#: The frame's camera the coverage label traces, per lens model the render used (the layered
#: model composites the thin lens's blur: its rays are the thin lens's).
_COVERAGE_CAMERA = {"layered": "thin", "auto": "thin"}


@LABELS.register("coverage", options=("coverage",),
                 description="coverage.exr: the soft segmentation of the thin-lens image under defocus: per pixel "
                             "the three instances (ids as in segmentation.png; channels id_0..id_2) whose surfaces "
                             "take the most of its rays through the aperture, and their fractions (coverage_0.."
                             "coverage_2; Cryptomatte's ranked pairs); meta.json: the camera traced and the rays",
                 files=("coverage.exr",), reader=_read_coverage, bytes_per_pixel=24.0)
def _coverage(item: Item, folder: Path) -> list[Path]:
    from ....render import render_coverage_map
    from ....render.depth import COVERAGE_RANKS

    t0 = time.perf_counter()
    lens_model = item.sim.radiance.meta.get("lens_model", item.config.lens.model)
    camera = _COVERAGE_CAMERA.get(lens_model, lens_model)
    passes = 64
    ids, coverage, shapes = render_coverage_map(item.config, lens=item.sim.lens, model=camera, passes=passes)
    objects = Instances.of(item.config, item.sim.lens, shapes, item.class_map)  # segmentation.png's ids
    ids, coverage = merge_ranks(objects.ids(ids), coverage)
    channels = {}
    for rank in range(COVERAGE_RANKS):
        channels[f"id_{rank}"] = ids[..., rank].astype(np.float32)  # segmentation.png's ids: 0 none
        channels[f"coverage_{rank}"] = coverage[..., rank]
    path = write_exr_channels(channels, folder / "coverage.exr",
                              {"spectral_cam_units": "id_k: instance id (segmentation.png's; 0 none); coverage_k: "
                                                     "fraction of the pixel's rays"})
    item.records["coverage"] = {
        "file": "coverage.exr", "channels": list(channels), "ranks": COVERAGE_RANKS, "rays_per_pixel": passes,
        "camera": camera, "ids": "segmentation.png's instance ids (the parts of one object merged; 0: none)",
        "instances": {str(k): objects.records[k - 1]["name"] for k in np.unique(ids).tolist() if k},
        "definition": "coverage_k: the fraction of the pixel's rays (random points of the pixel and of the "
                      "aperture) whose first surface is instance id_k, ranked by coverage; rays that escape "
                      "and lower ranks hold the rest"}
    item.timings["coverage"] = time.perf_counter() - t0
    return [path]
