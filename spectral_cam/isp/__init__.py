"""The image signal processor: develop any RAW (ours or a real camera's DNG) into sRGB.

One module per stage family, each stage a pure function on float32 arrays:
:mod:`.normalise`, :mod:`.denoise`, :mod:`.white_balance`, :mod:`.demosaic`,
:mod:`.highlights`, :mod:`.colour_correction`, :mod:`.tone`, :mod:`.sharpen`,
:mod:`.encode`; :mod:`.pipeline` composes them from an :class:`ISPConfig`
(:mod:`.config`, light enough for the scene reader to import).

Heavy dependencies (OpenCV, colour-science, scikit-image) load on first use: importing
this package or :mod:`spectral_cam.isp.config` imports none of them.
"""

from __future__ import annotations

import importlib

from .config import ISPConfig

__all__ = ["develop", "ISPConfig", "DevelopedImage", "write_image", "write_outputs"]

_LAZY = {
    "develop": ("pipeline", "develop"),
    "DevelopedImage": ("pipeline", "DevelopedImage"),
    "write_image": ("encode", "write_image"),
    "write_outputs": ("encode", "write_outputs"),
}


def __getattr__(name: str):
    if name in _LAZY:
        module, attribute = _LAZY[name]
        return getattr(importlib.import_module(f".{module}", __name__), attribute)
    raise AttributeError(f"module 'spectral_cam.isp' has no attribute {name!r}")
