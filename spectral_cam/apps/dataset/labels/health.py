"""The ``health`` label: each vegetation pixel's plant, its chlorophyll and health state (:func:`plant_map`).

References
----------
.. [1] Féret, J.-B., et al. (2017). PROSPECT-D. Remote Sensing of Environment 193, 204–215.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ....exr import write_exr_channels
from ....scene import SceneConfig
from .files import stack
from .item import Item
from .registry import LABELS

__all__ = ["HEALTH_CODES", "WEED", "plant_map"]


#: Codes of the health map's ``state`` channel (0: no plant at the pixel).
HEALTH_CODES = {"healthy": 1, "stressed": 2, "dry": 3, "weed": 4}


#: :func:`plant_map`'s owner of a pixel that shows a weed (−1: no plant).
WEED = -2


def plant_map(config: SceneConfig, lens) -> tuple[np.ndarray, list[dict]] | None:
    """Which plant each pixel's ray shows — an index into the returned plants' health
    records (:func:`spectral_cam.presets.vegetation.plant_health`), :data:`WEED` for a weed, −1
    for none — for a vegetation scene of PROSPECT-D plants through ``lens``; None for any
    other scene. The health label and the drift study's classifier both read it.

    References
    ----------
    .. [1] Jakob, W., et al. (2022). Mitsuba 3, plugin ``aov`` (shape_index).
    """
    from ....presets.vegetation import plant_health, vegetation_layout
    from ....render import render_shape_map

    scene = config.scene
    if scene.preset != "vegetation" or scene.mitsuba_xml or scene.plant_reflectances != "prospect":
        return None
    plants = plant_health(config, len(vegetation_layout(config, lens)))
    index, names = render_shape_map(config, lens=lens)
    owner_of = np.full(len(names) + 1, -1, np.int32)  # shape index → owner (the last: a miss, −1)
    for k, name in enumerate(names):
        owner_of[k] = WEED if name.startswith("weed_") else -1
    positions = {name: k for k, name in enumerate(names)}
    for k, plant in enumerate(plants):
        if plant["plant"] in positions:
            owner_of[positions[plant["plant"]]] = k
    return owner_of[index], plants


@LABELS.register("health", options=("health",),
                 description="health.exr: per pixel, the chlorophyll (µg/cm², channel cab) and health state "
                             "(channel state: 0 none, 1 healthy, 2 stressed, 3 dry, 4 a weed) of the plant seen "
                             "there; "
                             "meta.json lists each plant's state and PROSPECT-D traits (vegetation with "
                             "plant_reflectances = 'prospect')",
                 files=("health.exr",), reader=lambda p: {"health": stack(p, ("cab", "state"))}, bytes_per_pixel=8.0)
def _health(item: Item, folder: Path) -> list[Path]:
    found = plant_map(item.config, item.sim.lens)
    if found is None:
        item.records["health"] = {"plants": [], "note": "no plants with a leaf model in this scene"}
        return []
    t0 = time.perf_counter()
    owner, plants = found
    cab = np.zeros(owner.shape, np.float32)
    state = np.zeros(owner.shape, np.float32)
    for k, plant in enumerate(plants):
        here = owner == k
        cab[here], state[here] = plant["traits"]["cab"], HEALTH_CODES[plant["state"]]
        plant["pixels"] = int(here.sum())
    state[owner == WEED] = HEALTH_CODES["weed"]
    path = write_exr_channels({"cab": cab, "state": state}, folder / "health.exr",
                              {"spectral_cam_units": "cab: chlorophyll a+b, ug/cm2; state: 0 none, 1 healthy, "
                                                     "2 stressed, 3 dry, 4 weed"})
    item.records["health"] = {"file": "health.exr", "channels": ["cab", "state"], "codes": HEALTH_CODES,
                              "model": "PROSPECT-D (Feret et al. 2017) via prosail", "plants": plants}
    item.timings["health"] = time.perf_counter() - t0
    return [path]
