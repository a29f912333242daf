"""RAW files: the :class:`RawImage` type (``image``), DNG and camera-profile (DCP) writing (``dng``), reading any
raw LibRaw opens (``read``), and the camera profile's hue/sat map (``hue_sat_map``).

References
----------
.. [1] Adobe (2023). Digital Negative (DNG) Specification, version 1.7.1.0.
"""

from .dng import DNG_TAGS, write_dcp, write_dng
from .hue_sat_map import HueSatMap
from .image import Calibration, RawImage
from .read import read_raw

__all__ = ["RawImage", "Calibration", "HueSatMap", "write_dng", "write_dcp", "read_raw", "DNG_TAGS"]
