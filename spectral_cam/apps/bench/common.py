"""What every benchmark shares: the Pareto front, best-of timing, the ColorChecker scene it
renders, its CSV and its chart of time against error.

Times are reported as ratios to a baseline measured in the same run (machines differ, ratios
travel); each chart draws every group's Pareto front, the points no other point of the group
beats in both time and error (docs/design.md, "Where to make a change").
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ...records import exact_number, write_csv
from ...scene import SceneConfig, scene_from_dict

__all__ = ["pareto_front", "mark_front", "timed", "chart_scene", "NOISE_FREE", "write_rows", "read_rows",
           "pareto_chart"]

#: Scene overrides that switch off every sensor noise term (the noise-free RAW).
NOISE_FREE = {"sensor.shot_noise": False, "sensor.read_noise_e": 0.0, "sensor.dark_current_e_per_s": 0.0,
              "sensor.dsnu_e": 0.0, "sensor.prnu": 0.0}


def pareto_front(cost, error) -> np.ndarray:
    """Indices of the points no other point beats in both cost and error (lower is better).

    Parameters
    ----------
    cost, error : array_like
        One value per point.

    Returns
    -------
    numpy.ndarray
        Integer indices of the front, sorted by cost (ties: the lower error first).

    Examples
    --------
    >>> pareto_front([1.0, 2.0, 3.0], [2.0, 1.0, 1.5]).tolist()
    [0, 1]
    """
    cost, error = np.asarray(cost, float), np.asarray(error, float)
    order = np.lexsort((error, cost))
    front, best = [], np.inf
    for index in order:
        if error[index] < best:
            front.append(int(index))
            best = error[index]
    return np.asarray(front, dtype=int)


def mark_front(rows: list[dict], x: str, y: str) -> None:
    """Set ``row["pareto"]`` to whether each row is on the Pareto front of ``x`` against ``y``."""
    front = set(pareto_front([r[x] for r in rows], [r[y] for r in rows]).tolist())
    for index, row in enumerate(rows):
        row["pareto"] = index in front


def timed(func: Callable, *args, repeats: int = 1, **kwargs) -> tuple[Any, float]:
    """Call ``func(*args, **kwargs)`` ``repeats`` times.

    Returns
    -------
    (object, float)
        The last result and the shortest wall-clock time, seconds.
    """
    best, result = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = func(*args, **kwargs)
        best = min(best, time.perf_counter() - t0)
    return result, best


def chart_scene(width: int, height: int, **overrides) -> SceneConfig:
    """The benchmarks' scene: the ``colorchecker`` preset through a pinhole, no vignetting,
    no diffraction, ``width`` × ``height`` pixels; ``overrides`` are dotted scene keys."""
    base = {
        "scene": {"preset": "colorchecker", "fill": 0.95, "gap": 0.2},
        "lens": {"model": "pinhole"},
        "sensor": {"width_px": width, "height_px": height, "vignetting": False},
        "render": {"diffraction": "off", "max_depth": 2},
    }
    return scene_from_dict(base, overrides=overrides)


def write_rows(rows: Sequence[dict], path: str | Path) -> Path:
    """Write benchmark rows as a CSV (columns in the order of the first row's keys, every
    digit kept), atomically."""
    return write_csv(rows, path, list(rows[0]), number=exact_number)


def read_rows(path: str | Path) -> list[dict]:
    """Read benchmark rows written by :func:`write_rows`: numbers as ``int`` or ``float``,
    ``True``/``False`` as bools, empty cells as ``""``, other text as it is (charts are
    redrawn from the committed CSVs without measuring again)."""
    import csv

    def value(text: str):
        if text in ("True", "False"):
            return text == "True"
        for kind in (int, float):
            try:
                return kind(text)
            except ValueError:
                pass
        return text

    with open(path, newline="", encoding="utf-8") as handle:
        return [{key: value(text) for key, text in row.items()} for row in csv.DictReader(handle)]


def pareto_chart(rows: Sequence[dict], path: str | Path, *, x: str, y: str, label: str, title: str,
                 group: str | None = None, xlabel: str | None = None, ylabel: str | None = None,
                 front: bool = True, higher_is_better: bool = False) -> Path:
    """Chart ``y`` against ``x`` (log scale) for benchmark rows, each point labelled without
    overlaps (:func:`spectral_cam.viz.label_points`), with each group's Pareto front drawn as
    a dashed staircase from its cheapest to its most accurate point and its points ringed (a
    front of one point is its ring); written as a PNG (:mod:`spectral_cam.viz`, no pyplot).

    Parameters
    ----------
    rows : sequence of dict
        One point per row.
    path : path-like
        PNG to write.
    x, y, label : str
        Keys of the cost, the error and the point label.
    title : str
        Chart title.
    group : str, optional
        Key whose values split the points into coloured groups, each with its front.
    xlabel, ylabel : str, optional
        Axis labels (default the keys).
    front : bool
        Draw the fronts.
    higher_is_better : bool
        ``y`` is a quality (e.g. PSNR): the front is computed on −``y`` (as the CSV's
        ``pareto`` flags are) and drawn on ``y``.

    Returns
    -------
    pathlib.Path
    """
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    from ... import viz

    fig = viz.figure(7, 4.5, dpi=110)
    ax = fig.subplots()
    groups = sorted({r[group] for r in rows}) if group else [None]
    ring = {"marker": "o", "ms": 10, "mfc": "none", "mew": 1.0}
    staircase = False  # some front of two points or more: its legend entry shows the dashes
    for number, name in enumerate(groups):
        subset = [r for r in rows if group is None or r[group] == name]
        colour = f"C{number}"
        cost = np.array([r[x] for r in subset], float)
        value = np.array([r[y] for r in subset], float)
        ax.scatter(cost, value, label=name, s=30, zorder=3, color=colour)
        if front:
            on_front = pareto_front(cost, -value if higher_is_better else value)
            staircase |= len(on_front) > 1
            ax.step(cost[on_front], value[on_front], where="post", color=colour, lw=1, ls="--", zorder=2,
                    gid="pareto-front", label=f"_front {name}", **ring)
    ax.set_xscale("log")
    low, high = ax.get_xlim()  # plain tick numbers, as many per decade as the span leaves room for
    subs = (1.0, 2.0, 5.0) if high / low > 30 else (1.0, 2.0, 3.0, 5.0) if high / low > 3 else \
        tuple(float(k) for k in range(1, 10))
    ax.xaxis.set_major_locator(LogLocator(subs=subs))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(xlabel or x)
    ax.set_ylabel(ylabel or y)
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.margins(y=0.15)  # head room for the labels
    handles = ax.get_legend_handles_labels()[0] if group else []
    if front:
        handles.append(Line2D([], [], color="0.35", lw=1, ls="--" if staircase else "none",
                              label="Pareto front (ringed)", **ring))
    if handles:  # beside the axes: it never hides a point or a label
        ax.legend(handles=handles, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    colours = [f"C{groups.index(r[group])}" if group else "black" for r in rows]
    viz.label_points(ax, [r[x] for r in rows], [r[y] for r in rows], [str(r[label]) for r in rows], colors=colours)
    return viz.save_png(fig, path, dpi=110)
