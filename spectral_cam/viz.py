"""One chart style: matplotlib ``Figure`` objects, never pyplot's global state.

Importing spectral_cam never changes a user's matplotlib backend: figures are made with
:func:`figure` (constrained layout) and written with :func:`save_png` (atomically, through
the Agg canvas) or embedded with :func:`png_data_uri`.

References
----------
.. [1] matplotlib documentation, "Embedding Matplotlib in graphical user interfaces" /
   ``matplotlib.figure.Figure`` (figures without pyplot).
"""

from __future__ import annotations

import base64
import io
from pathlib import Path

import numpy as np

from .io import atomic_path

__all__ = ["figure", "save_png", "png_bytes", "png_data_uri", "label_points"]


def figure(width_in: float, height_in: float, *, dpi: int = 100):
    """A constrained-layout :class:`matplotlib.figure.Figure` of the given size (inches)."""
    from matplotlib.figure import Figure

    return Figure(figsize=(width_in, height_in), dpi=dpi, layout="constrained")


def png_bytes(fig, *, dpi: int = 100, palette: bool = False) -> bytes:
    """The figure as PNG bytes; ``palette`` stores 256 adaptive colours (image panels of
    noise then take about a third of the space)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    buffer = io.BytesIO()
    if not palette:
        FigureCanvasAgg(fig)
        fig.savefig(buffer, format="png", dpi=dpi)
        return buffer.getvalue()
    from PIL import Image

    canvas = FigureCanvasAgg(fig)
    fig.set_dpi(dpi)
    canvas.draw()
    rgb = np.asarray(canvas.buffer_rgba())[..., :3]
    Image.fromarray(rgb).quantize(256, method=Image.Quantize.MEDIANCUT).save(buffer, format="png", optimize=True)
    return buffer.getvalue()


def save_png(fig, path: str | Path, *, dpi: int = 100, palette: bool = False) -> Path:
    """Write the figure as a PNG file, atomically."""
    path = Path(path)
    data = png_bytes(fig, dpi=dpi, palette=palette)
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return path


def png_data_uri(fig, *, dpi: int = 100) -> str:
    """The figure as a ``data:image/png;base64,...`` URI (for self-contained HTML)."""
    return "data:image/png;base64," + base64.b64encode(png_bytes(fig, dpi=dpi)).decode("ascii")


def label_points(ax, xs, ys, labels, *, fontsize: int = 7) -> None:
    """Label scatter points without overlaps: each label is nudged vertically (in points)
    away from labels already placed within its reach."""
    placed: list[tuple[float, float]] = []
    for x, y, text in zip(xs, ys, labels):
        px, py = ax.transData.transform((x, y))
        dy = 4.0
        while any(abs(px - qx) < 6.0 * len(text) and abs(py + dy - qy) < fontsize + 2 for qx, qy in placed):
            dy += fontsize + 2
        placed.append((px, py + dy))
        ax.annotate(text, (x, y), textcoords="offset points", xytext=(4, dy), fontsize=fontsize)
