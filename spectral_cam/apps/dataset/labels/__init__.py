"""Dataset labels: what an item writes beside its RAW, one module and one :data:`LABELS` entry each.

``[dataset] outputs`` names entries of :data:`LABELS`; an item renders its scene once
(:func:`spectral_cam.job.simulate`) and every entry it names writes its files into the item's
staging folder. Each entry (:class:`~.registry.Label`) carries the label's writer, its reader (what
:func:`~spectral_cam.apps.dataset.read_item` serves), a one-line description with units, the files
it writes and its size per pixel (:meth:`~.registry.Label.estimate_bytes`, the dry run's total).
Adding a label is one module here and its import below (two files; a label registered from
your own module touches none of the package's)::

    from spectral_cam.apps.dataset.labels import LABELS
    from spectral_cam.apps.dataset.labels.files import stack

    @LABELS.register("speed", options=("speed",), description="speed.exr: ... m/s (channel V)",
                     files=("speed.exr",), reader=lambda p: {"speed": stack(p, ("V",))[..., 0]},
                     bytes_per_pixel=4.0)
    def _speed(item, folder):
        ...                                                    # write folder / "speed.exr"
        item.records["speed"] = {"file": "speed.exr", ...}     # its meta.json entry
        return [folder / "speed.exr"]

An entry's ``options`` are the meta.json keys it records (each None in an item without the label).
The shared machinery has its own modules: :mod:`.registry` (the entry type), :mod:`.item` (the
item being written, :func:`write_item`), :mod:`.physics` (defocus map, clean camera RGB, blur
against depth), :mod:`.classes` (the class map, classes.json), :mod:`.instances` (shapes merged
per object) and :mod:`.files` (readers' helpers).

References
----------
.. [1] docs/design.md, "Registries", "Dataset layouts" and "Result folder (job.py)".
"""

from __future__ import annotations

# the labels, in the order of outputs in dataset.json and meta.json (registration order)
from . import job_files, defocus, all_in_focus, clean_rgb, undistortion, health  # noqa: F401  (registers)
from . import segmentation, semantic, coverage, flow, albedo, illuminant_map, normals  # noqa: F401  (registers)
from .classes import (CLASS_LABELS, PRESET_CLASSES, SHAPE_RULES, USER_CLASS_BASE, ShapeClass, class_table,
                      shape_class, shape_reflectance, sky_visible, spec_class_table, write_classes)
from .health import HEALTH_CODES, WEED, plant_map
from .instances import VISIBILITY_NOTE, Instances, amodal_pixels, instance_boxes, merge_ranks, shape_layers
from .item import DEFAULT_OUTPUTS, Item, file_check, write_item
from .physics import (BLUR_PRESETS, COC_BAND_FACTOR, COC_BAND_MIN_PIXELS, clean_camera_rgb, defocus_map_px,
                      measure_scene_blur)
from .registry import LABELS, Label, LabelRegistry

#: The former private name of :func:`~.instances.merge_ranks`.
_merge_ranks = merge_ranks

__all__ = ["LABELS", "Label", "LabelRegistry", "DEFAULT_OUTPUTS", "BLUR_PRESETS", "Item", "write_item", "file_check",
           "defocus_map_px", "clean_camera_rgb", "measure_scene_blur", "PRESET_CLASSES", "USER_CLASS_BASE",
           "SHAPE_RULES", "CLASS_LABELS", "ShapeClass", "class_table", "spec_class_table", "write_classes",
           "shape_class", "shape_reflectance", "sky_visible", "Instances", "instance_boxes", "amodal_pixels",
           "shape_layers", "VISIBILITY_NOTE", "merge_ranks", "HEALTH_CODES", "WEED", "plant_map",
           "COC_BAND_FACTOR", "COC_BAND_MIN_PIXELS"]
