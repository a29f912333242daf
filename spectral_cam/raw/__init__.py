"""RAW files: the :class:`RawImage` type (``image``), DNG and camera-profile (DCP) writing (``dng``) and reading any
raw LibRaw opens (``read``).

References
----------
.. [1] Adobe (2023). Digital Negative (DNG) Specification, version 1.7.1.0.
"""

from .dng import DNG_TAGS, write_dcp, write_dng
from .image import Calibration, RawImage
from .read import read_raw

__all__ = ["RawImage", "Calibration", "write_dng", "write_dcp", "read_raw", "DNG_TAGS"]
