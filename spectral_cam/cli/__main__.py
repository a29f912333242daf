"""``python -m spectral_cam.cli``: the same as the ``spectral-cam`` command."""

import sys

from . import main

sys.exit(main())
