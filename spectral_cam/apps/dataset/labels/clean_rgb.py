"""The ``clean_rgb`` label: noise-free linear camera RGB (:func:`~.physics.clean_camera_rgb`).

References
----------
.. [1] EMVA Standard 1288, Release 4.0 Linear (2021), §2.
"""

from __future__ import annotations

from pathlib import Path

from ....exr import write_exr_channels
from .files import camera_rgb
from .item import Item
from .registry import LABELS


def _estimate_note(radiance) -> str:
    """What the label's radiance is: the renderer's estimator (mean, or the adaptive median of
    means, with the share of pixels it changed)."""
    record = ((radiance.meta or {}).get("model_decisions") or {}).get("estimator") or {}
    if record.get("choice") == "amon":
        return (f"adaptive median of {record['passes']} pass means (Buisine et al. 2021): fireflies removed; "
                f"{100 * record.get('median_share', 0.0):.3g} % of pixels took the median, the light it removed "
                "spread back over their surroundings (rare bright paths such as a caustic's become a glow; each "
                "channel's total is the mean's); elsewhere the unbiased mean of the samples")
    return "the mean of the samples (unbiased, Monte-Carlo noise and any fireflies included)"


@LABELS.register("clean_rgb", options=("clean_rgb",),
                 description="clean_rgb.exr: noise-free linear camera RGB (1 = white level - black level) of the "
                             "render's radiance estimate: its Monte-Carlo noise stays, fireflies do not where the "
                             "adaptive median of means was chosen (model_decisions.estimator)",
                 files=("clean_rgb.exr",), reader=lambda p: {"clean_rgb": camera_rgb(p)}, bytes_per_pixel=12.0)
def _clean_rgb(item: Item, folder: Path) -> list[Path]:
    sensor = item.config.sensor
    channels = ("Y",) if sensor.cfa == "none" else ("R", "G", "B")
    clean = item.clean_rgb
    path = write_exr_channels({name: clean[..., i] for i, name in enumerate(channels)}, folder / "clean_rgb.exr",
                      {"spectral_cam_units": "linear camera RGB, 1 = white level - black level"})
    item.records["clean_rgb"] = {
        "file": "clean_rgb.exr", "channels": list(channels), "units": "linear camera RGB; 1 = white level - black level",
        "electrons_per_unit": (2 ** sensor.bit_depth - 1 - sensor.black_level_dn) / item.sim.raw.meta["K_dn_per_e"],
        "excludes": "shot, read, dark and fixed-pattern noise, dark signal, clipping, quantisation",
        "radiance_estimate": _estimate_note(item.sim.radiance)}
    return [path]
