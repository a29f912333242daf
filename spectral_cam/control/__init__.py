"""Camera control loops: auto exposure (:mod:`.exposure`: metering modes, an exposure program
with limits, a damped loop with a dead band) and auto white balance (:mod:`.white_balance`:
grey world, white patch, grey edge, the illuminant locus of the camera's own curves, temporal
smoothing, locked and manual modes). Each controller steps from frame to frame as a camera's
does and reports its state, so a sequence of frames (and the drift it causes) can be studied.

References
----------
.. [1] Nakamura, J. (Ed.) (2005). Image Sensors and Signal Processing for Digital Still
   Cameras, ch. 8 (AE, AWB control loops).
"""

from .exposure_loop import METERING, AutoExposure, ExposureState, meter
from .white_balance_loop import AWB_METHODS, AutoWhiteBalance, estimate_white

__all__ = ["METERING", "meter", "AutoExposure", "ExposureState", "AWB_METHODS", "estimate_white",
           "AutoWhiteBalance"]
