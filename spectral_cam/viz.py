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


def label_points(ax, xs, ys, labels, *, fontsize: int = 7, colors=None) -> list:
    """Label points so that no label overlaps another label, a point, the legend, a text
    already in the axes or the axes' edge.

    The figure's layout is settled first (constrained layout moves the axes), then each
    label takes the nearest free place among candidates right or left of its point, above
    or below it, stepping away in half label heights (a grey leader line joins a label
    placed more than two heights away); markers of the axes' lines (rings, say) count as
    points. Points under one marker that share a label are labelled once, "label (n points)"
    (black where their colours differ). Labels are left out of the layout so that
    the final draw keeps the places found.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Axes of a :func:`figure`.
    xs, ys : sequence of float
        Data coordinates of the points.
    labels : sequence of str
        One label per point.
    fontsize : int
        Points.
    colors : sequence of colours, optional
        One per label (default black), e.g. the colour of the point's group.

    Returns
    -------
    list of matplotlib.text.Annotation
        The labels placed, in the order of the points (one for points sharing a label and a
        marker).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text
    from matplotlib.transforms import Bbox

    fig = ax.figure
    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    fig.draw_without_rendering()
    renderer = fig.canvas.get_renderer()
    scale = fig.dpi / 72.0  # pixels per point
    frame = ax.get_window_extent(renderer)
    centres = ax.transData.transform(np.column_stack([np.asarray(xs, float), np.asarray(ys, float)]))
    radius = 3.0 * scale  # a scatter marker of s=30 has a 2.7-point radius
    obstacles = [Bbox.from_extents(x - radius, y - radius, x + radius, y + radius) for x, y in centres]
    for line in ax.lines:  # markers drawn by lines (rings around points, say)
        if line.get_marker() in (None, "None", "", " ") or not len(line.get_xdata()):
            continue
        reach = (line.get_markersize() + line.get_markeredgewidth()) / 2 * scale
        for x, y in line.get_transform().transform(line.get_xydata()):
            obstacles.append(Bbox.from_extents(x - reach, y - reach, x + reach, y + reach))
    legend = ax.get_legend()
    if legend is not None:
        obstacles.append(legend.get_window_extent(renderer))
    obstacles += [Text.get_window_extent(t, renderer) for t in ax.texts]

    def overlap(a, b) -> float:
        return max(0.0, min(a.x1, b.x1) - max(a.x0, b.x0)) * max(0.0, min(a.y1, b.y1) - max(a.y0, b.y0))

    colors = ["black"] * len(centres) if colors is None else list(colors)
    # the same label on points under one marker is given once: "label (n points)", black
    # where their colours differ
    merged: list[list[int]] = []
    for k, ((px, py), text) in enumerate(zip(centres, labels)):
        home = next((m for m in merged if labels[m[0]] == text
                     and np.hypot(*(centres[m[0]] - (px, py))) < radius), None)
        if home is None:
            merged.append([k])
        else:
            home.append(k)
    notes = []
    for members in merged:
        first = members[0]
        (px, py), x, y = centres[first], xs[first], ys[first]
        text, colour = str(labels[first]), colors[first]
        if len(members) > 1:
            text = f"{text} ({len(members)} points)"
            if len({str(colors[k]) for k in members}) > 1:
                colour = "black"
        probe = ax.annotate(text, (x, y), textcoords="offset points", xytext=(0, 0), fontsize=fontsize,
                            ha="left", va="bottom")
        box = Text.get_window_extent(probe, renderer)
        probe.remove()
        w, h = box.width / scale, box.height / scale  # points
        candidates = []  # (dx, dy) of the label's lower left corner, points
        for dx in (4.0, 7.0, -4.0 - w, -7.0 - w):
            for step in range(25):
                lift = step * h / 2
                candidates += [(dx, 2.0 + lift), (dx, -2.0 - h - lift)]
        # nearest first: the gap between the point and the label's nearest corner
        candidates.sort(key=lambda c: round(np.hypot(c[0] if c[0] > 0 else -c[0] - w,
                                                      c[1] if c[1] > 0 else -c[1] - h), 6))
        best, best_cost = candidates[0], np.inf
        for dx, dy in candidates:
            bounds = Bbox.from_bounds(px + dx * scale, py + dy * scale, w * scale, h * scale).padded(0.5 * scale)
            outside = bounds.width * bounds.height - overlap(bounds, frame)
            cost = outside + sum(overlap(bounds, other) for other in obstacles)
            if cost < best_cost:
                best, best_cost = (dx, dy), cost
            if cost == 0:
                break
        dx, dy = best
        leader = {"arrowstyle": "-", "color": "0.6", "lw": 0.6, "shrinkA": 0, "shrinkB": 3,
                  "relpos": (0.0 if dx > 0 else 1.0, 0.0 if dy > 0 else 1.0)} if abs(dy) > 2.0 * h + 3.0 else None
        note = ax.annotate(text, (x, y), textcoords="offset points", xytext=(dx, dy), fontsize=fontsize,
                           ha="left", va="bottom", annotation_clip=False, arrowprops=leader, color=colour)
        note.set_in_layout(False)
        obstacles.append(Bbox.from_bounds(px + dx * scale, py + dy * scale, w * scale, h * scale))
        notes.append(note)
    return notes
