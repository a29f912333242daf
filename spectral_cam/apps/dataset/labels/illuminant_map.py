"""The ``illuminant_map`` label: the light arriving at each pixel's surface and each light's share (LSMI).

References
----------
.. [1] Kim, D., et al. (2021). Large scale multi-illuminant (LSMI) dataset. ICCV.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ....exr import write_exr_channels
from .files import exr_channels, stack
from .item import Item
from .registry import LABELS


def _read_illuminant_map(path: Path) -> dict[str, np.ndarray]:
    """``illuminant_map`` (H, W, 3) and ``light_shares`` (H, W, N), share_0 … share_{N-1} in order."""
    count = sum(1 for name in exr_channels(path) if name.startswith("share_"))
    return {"illuminant_map": stack(path, ("R", "G", "B")),
            "light_shares": stack(path, tuple(f"share_{k}" for k in range(count)))}


@LABELS.register("illuminant_map", options=("illuminant_map",),
                 description="illuminant_map.exr: per pixel, the camera RGB (green 1; channels R, G, B) of the "
                             "light arriving at the surface seen there (a white diffuser's response, interreflections "
                             "included) and each light's share of its green (share_0, share_1, …: LSMI's mixture "
                             "map; an XML scene's emitters, a sunsky's sun and sky apart); meta.json names each "
                             "light with its own camera RGB, xy and CCT; 0 where unlit",
                 files=("illuminant_map.exr",), reader=_read_illuminant_map,
                 bytes_per_pixel=20.0)
def _illuminant_map(item: Item, folder: Path) -> list[Path]:
    from ....render.light_mixture import render_light_mixture

    t0 = time.perf_counter()
    mixture = render_light_mixture(item.config, lens=item.sim.lens)
    rgb = mixture.illuminant_rgb
    channels = {c: rgb[..., i].astype(np.float32) for i, c in enumerate("RGB")}
    channels.update({f"share_{k}": mixture.shares[..., k].astype(np.float32) for k in range(len(mixture.names))})
    path = write_exr_channels(channels, folder / "illuminant_map.exr",
                              {"spectral_cam_units": "R, G, B: camera RGB of the light, green 1; share_k: fraction "
                                                     "of the green signal from light k (0 where unlit)"})
    lights = [{"share_channel": f"share_{k}", "name": name, "camera_rgb_g1": mixture.camera_rgb_g1[k].tolist(),
               **chroma, "pixels_mostly_lit": int((mixture.shares[..., k] > 0.5).sum())}
              for k, (name, chroma) in enumerate(zip(mixture.names, mixture.chromaticities()))]
    item.records["illuminant_map"] = {
        "file": "illuminant_map.exr", "channels": list(channels), "lights": lights,
        "definition": "R, G, B: the camera's response to a white diffuser at the surface each pixel sees (E/pi, "
                      "every light, interreflections included), green 1; share_k = G_k / sum_j G_j with light k "
                      "alone (Kim et al. 2021, LSMI); clean_rgb / (R, G, B) is the image white-balanced per pixel",
        "view": "ideal pinhole through the frame (the all-in-focus view)", "spp_per_light_and_channel": mixture.spp,
        "pixels_unlit": int(mixture.unlit.sum())}
    item.timings["illuminant_map"] = time.perf_counter() - t0
    return [path]
