"""One dataset item while its labels are written (:class:`Item`), and the item's folder written
atomically: its labels, then meta.json (:func:`write_item`).

References
----------
.. [1] docs/design.md, "Result folder (job.py)".
.. [2] FIPS 180-4, Secure Hash Standard (SHA-256) (the file checks).
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ....errors import ConfigError
from ....io import staged_directory
from ....job import Simulation, result_meta, simulate
from ....records import write_json
from ....scene import SceneConfig
from .classes import class_table
from .instances import Instances, amodal_pixels, shape_layers
from .physics import clean_camera_rgb
from .registry import LABELS

__all__ = ["Item", "DEFAULT_OUTPUTS", "write_item", "file_check"]


@dataclass
class Item:
    """One dataset item in memory while its labels are written.

    Attributes
    ----------
    sim : Simulation
        The item's scene through render → expose → develop (its ``lens`` built once).
    measure_blur : bool
        Measure blur against depth (a sweep of a :data:`BLUR_PRESETS` scene).
    records : dict
        meta.json entries the labels record (keys declared in their ``options``).
    timings : dict
        Seconds per stage; a label that times itself records ``timings[name]`` (its time
        is then not counted under ``"write"``).
    classes : list of dict, optional
        The dataset's class map (:func:`spec_class_table`); default the item's own scene's
        (:func:`class_table`), which is the same for a dataset of one scene.
    """

    sim: Simulation
    measure_blur: bool = False
    records: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    classes: list | None = None

    @property
    def config(self) -> SceneConfig:
        """The item's scene."""
        return self.sim.config

    @property
    def exposure_s(self) -> float:
        """The exposure the RAW was made with (s)."""
        return float(self.sim.raw.meta["exposure_s"])

    @functools.cached_property
    def clean_rgb(self) -> np.ndarray:
        """The noise-free camera RGB of the main render (:func:`clean_camera_rgb`)."""
        return clean_camera_rgb(self.sim.radiance, self.config, exposure_s=self.exposure_s)

    @functools.cached_property
    def shape_map(self) -> tuple[np.ndarray, list[dict]]:
        """Which shape each pixel sees through the frame's pinhole, and each shape's name and
        material (:func:`spectral_cam.render.render_shape_map`): rendered once for the labels
        that need it (segmentation, flow)."""
        from ....render import render_shape_map

        return render_shape_map(self.config, lens=self.sim.lens, with_materials=True)

    @functools.cached_property
    def class_map(self) -> list[dict]:
        """The class map the item's ids come from (:attr:`classes`, or its scene's own)."""
        return list(self.classes) if self.classes is not None else class_table([self.config])

    @functools.cached_property
    def instances(self) -> tuple[np.ndarray, "Instances"]:
        """(H, W) uint16 instance ids of the pinhole view (0: none), the parts of one object
        merged (:class:`Instances`), and the instances."""
        index, shapes = self.shape_map
        objects = Instances.of(self.config, self.sim.lens, shapes, self.class_map)
        if len(objects.records) >= 65535:
            raise ConfigError(f"{len(objects.records)} objects do not fit a 16-bit segmentation (at most 65534)")
        return objects.ids(index).astype(np.uint16), objects

    @functools.cached_property
    def amodal(self) -> np.ndarray | None:
        """Pixels of each instance's amodal mask (:func:`amodal_pixels`), None where
        :func:`shape_layers` cannot trace them (Mitsuba's scalar variants)."""
        layers = shape_layers(self.config, self.sim.lens)
        return None if layers is None else amodal_pixels(layers, self.instances[1])


#: Outputs of an item unless the spec's ``[dataset] outputs`` says otherwise (the spectral
#: cube, 31 float32 channels, is opt-in).
DEFAULT_OUTPUTS = ("raw", "image", "depth", "defocus", "all_in_focus", "clean_rgb")


def write_item(config: SceneConfig, target: str | Path, *, outputs: Sequence[str], measure_blur: bool = False,
               dataset: Mapping[str, Any] | None = None, classes: Sequence[Mapping] | None = None) -> dict:
    """Render one item and write its folder atomically: the labels, then meta.json.

    Parameters
    ----------
    config
        The item's validated scene.
    target
        The item folder; it appears in one rename when complete (an older one is replaced).
    outputs
        Names of :data:`LABELS` to write.
    measure_blur
        Measure blur against depth when the all-in-focus image is rendered (blur presets).
    dataset
        The item's record in meta.json (``index``, ``id``, ``seed``, ``spec_hash``, ``params``,
        ``outputs``).
    classes
        The dataset's class map (:func:`spec_class_table`), which the segmentation, semantic and
        coverage labels' class ids come from; default the item's scene's own (:func:`class_table`).

    Returns
    -------
    dict
        The meta.json content: :func:`spectral_cam.job.result_meta` with ``dataset`` first
        and each label's records last.
    """
    for name in outputs:
        LABELS.check(name, key="dataset.outputs")
    started = time.perf_counter()
    with staged_directory(target, force=True) as stage:
        item = Item(simulate(config), measure_blur=measure_blur, classes=None if classes is None else list(classes))
        written: list[Path] = []
        by_label: dict[str, list[str]] = {}  # what each output wrote: some write nothing for some scenes
        write_s = 0.0
        for name in outputs:
            t0 = time.perf_counter()
            files = LABELS[name](item, stage)
            by_label[name] = [path.name for path in files]
            written += files
            if name not in item.timings:
                write_s += time.perf_counter() - t0
        timings = {**item.sim.timings_s, "write": write_s, **item.timings}
        timings["total"] = time.perf_counter() - started
        record = dict(dataset or {})
        record["labels"] = by_label
        record["file_checks"] = {path.name: file_check(path) for path in written}
        meta = result_meta(item.sim, written, timings, dataset=record)
        meta.update({key: item.records.get(key) for entry in LABELS.values() for key in entry.options})
        write_json(meta, stage / "meta.json")
    return meta


def file_check(path: Path) -> dict:
    """Size (bytes) and SHA-256 of a written file: what a resumed run verifies, so a truncated
    ``raw.dng`` or a 0-byte ``image.png`` is rendered again instead of counted as done.

    References
    ----------
    .. [1] FIPS 180-4, Secure Hash Standard (SHA-256).
    """
    import hashlib

    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return {"bytes": Path(path).stat().st_size, "sha256": digest.hexdigest()}


