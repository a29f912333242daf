"""``spectral-cam sequence``: frames over time (any scene key varying per frame, most naturally the
sun and sky over a day) through a camera whose auto exposure and auto white balance are control
loops (:mod:`spectral_cam.control`), and the drift those loops cause (:mod:`.drift`).

:mod:`.spec` reads the spec, :mod:`.run` renders and runs the camera, :mod:`.drift` measures the
plants of a vegetation sequence frame by frame.

References
----------
.. [1] docs/design.md, "Sequences".
"""

from .run import MODES, bayer_stats, render_frames, run_camera, run_sequence
from .spec import CameraControl, SequenceSpec, load_sequence, sequence_from_dict

__all__ = ["MODES", "bayer_stats", "render_frames", "run_camera", "run_sequence", "CameraControl", "SequenceSpec",
           "load_sequence", "sequence_from_dict"]
