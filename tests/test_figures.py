"""The committed charts and the README picture as a reader meets them (issue 25 #20): each chart
redrawn from its committed CSV has no overlapping tick or point labels, every legend entry has
something drawn for it and none is a git revision; the README picture is what its script makes."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

import spectral_cam
from spectral_cam import viz
from spectral_cam.apps.bench.common import pareto_chart, read_rows

pytestmark = pytest.mark.timeout(300)

REPO = Path(spectral_cam.__file__).resolve().parents[1]
BENCH = REPO / "docs" / "bench"


def _script(path: Path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def figures(monkeypatch):
    """The figures the code under test saves, drawn at their own dpi afterwards."""
    saved = []
    original = viz.save_png

    def keep(fig, path, **kwargs):
        saved.append(fig)
        return original(fig, path, **kwargs)

    monkeypatch.setattr(viz, "save_png", keep)
    return saved


def _shown_tick_labels(axis, low, high):
    """The tick labels a draw shows: visible, with text, at a tick inside the view."""
    low, high = min(low, high), max(low, high)
    span = (high - low) * 1e-9
    labels = []
    for tick in [*axis.get_major_ticks(), *axis.get_minor_ticks()]:
        label = tick.label1
        if label.get_visible() and label.get_text().strip() and low - span <= tick.get_loc() <= high + span:
            labels.append(label)
    return labels


def _overlaps(texts, renderer):
    from matplotlib.text import Text

    boxes = [(t.get_text(), Text.get_window_extent(t, renderer)) for t in texts]
    return [(a, b) for i, (a, box_a) in enumerate(boxes) for b, box_b in boxes[i + 1:]
            if box_a.overlaps(box_b) and min(box_a.x1, box_b.x1) - max(box_a.x0, box_b.x0) > 0.5
            and min(box_a.y1, box_b.y1) - max(box_a.y0, box_b.y0) > 0.5]


def _drawn(ax, label: str) -> bool:
    """Something in ``ax`` is drawn for the legend entry ``label``."""
    if label.startswith("Pareto front"):
        return any(line.get_gid() == "pareto-front" and len(line.get_xdata()) and line.get_marker() not in
                   (None, "None", "") for line in ax.lines)
    return (any(line.get_label() == label and len(line.get_xdata()) and line.get_visible() for line in ax.lines)
            or any(c.get_label() == label and len(c.get_offsets()) for c in ax.collections)
            or any(c.get_label() == label and len(c) for c in ax.containers))


def _check(fig) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text

    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        for axis, (low, high) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
            shown = _shown_tick_labels(axis, low, high)
            assert not _overlaps(shown, renderer), f"{ax.get_title()!r}: tick labels overlap"
        notes = [t for t in ax.texts if t.get_text()]
        assert not _overlaps(notes, renderer), f"{ax.get_title()!r}: point labels overlap"
        frame = ax.get_window_extent(renderer)
        for note in notes:
            box = Text.get_window_extent(note, renderer)
            assert frame.x0 - 1 <= box.x0 and box.x1 <= frame.x1 + 1 and frame.y0 - 1 <= box.y0 \
                and box.y1 <= frame.y1 + 1, f"label {note.get_text()!r} leaves the axes"
        legend = ax.get_legend()
        if legend is None:
            continue
        for text in legend.get_texts():
            label = text.get_text()
            assert _drawn(ax, label), f"legend entry {label!r} has nothing drawn"
            tokens = (token.strip("@()[],") for token in label.split())
            assert not any(re.fullmatch(r"[0-9a-f]{7,40}", t) and not t.isdigit() for t in tokens), \
                f"legend entry {label!r} names a git revision"
        legend_box = legend.get_window_extent(renderer)
        for note in notes:
            assert not Text.get_window_extent(note, renderer).overlaps(legend_box), note.get_text()


def test_samplers_chart_ticks_do_not_collide(tmp_path, figures):
    bench = _script(REPO / "benchmarks" / "bench_samplers.py")
    bench.chart(read_rows(BENCH / "samplers.csv"), tmp_path / "samplers.png")
    (fig,) = figures
    _check(fig)
    spp_axis = fig.axes[0].xaxis
    assert [t.get_text() for t in _shown_tick_labels(spp_axis, *fig.axes[0].get_xlim())] == ["16", "64", "256"]


def test_bench_isp_chart_draws_delta_e_from_zero_without_collisions(tmp_path, figures):
    bench = _script(REPO / "benchmarks" / "bench_isp.py")
    rows = read_rows(BENCH / "bench_isp.csv")
    bench.chart(rows, tmp_path / "bench_isp.png")
    (fig,) = figures
    _check(fig)
    time_ax, error_ax = fig.axes
    assert error_ax.get_xlim()[0] == 0.0  # the 0.007 spread is drawn at its size
    assert [t.get_text() for t in time_ax.get_yticklabels()] == [r["pipeline"] for r in rows]


@pytest.mark.parametrize("y", ["delta_e2000_mean", "bias_max_abs_pct"])
def test_bands_charts_draw_their_front_and_label_the_31_bands_once(tmp_path, figures, y):
    rows = read_rows(BENCH / "bands.csv")
    pareto_chart(rows, tmp_path / "bands.png", x="time_ratio", y=y, label="bands", group="illuminant", title="t")
    (fig,) = figures
    _check(fig)
    (ax,) = fig.axes
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["D65", "FL11", "Pareto front (ringed)"]
    # each illuminant's front is the camera film alone: one ring each, drawn
    fronts = [line for line in ax.lines if line.get_gid() == "pareto-front"]
    assert [len(line.get_xdata()) for line in fronts] == [1, 1]
    labels = [t.get_text() for t in ax.texts]
    assert sum(label.startswith("31 bands") for label in labels) == 1 and "31 bands (2 points)" in labels


@pytest.mark.parametrize("table, args", [
    ("spp.csv", {"x": "time_ratio", "y": "mc_noise_rel", "label": "spp", "group": "variant"}),
    ("rawpy.csv", {"x": "time_ratio", "y": "psnr_db", "label": "pipeline", "higher_is_better": True}),
])
def test_other_pareto_charts_have_no_collisions(tmp_path, figures, table, args):
    pareto_chart(read_rows(BENCH / table), tmp_path / "chart.png", title="t", **args)
    (fig,) = figures
    _check(fig)
    assert any(len(line.get_xdata()) > 1 for line in fig.axes[0].lines if line.get_gid() == "pareto-front")


def test_demosaic_speed_legend_names_methods_not_revisions(tmp_path, figures):
    bench = _script(REPO / "benchmarks" / "bench_demosaic.py")
    rows = read_rows(BENCH / "demosaic_speed.csv")
    assert any(re.search(r" @[0-9a-f]{7}", r["method"]) for r in rows)  # the CSV keeps the revision
    bench.chart(rows, tmp_path / "demosaic_speed.png")
    (fig,) = figures
    _check(fig)
    warm_labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "menon2007 (previous)" in warm_labels and "opencv EA 16-bit" in warm_labels


def test_readme_figure_is_what_its_script_makes():
    """docs/scenes.png is reproduced by docs/make_readme_figure.py: the Mitsuba variant is
    pinned (each variant draws its own Monte-Carlo samples; auto would pick CUDA on a GPU
    machine), and a fresh figure matches the committed one to float rounding."""
    from spectral_cam.errors import RenderError
    from spectral_cam.render import choose_variant

    script = _script(REPO / "docs" / "make_readme_figure.py")
    assert script.OVERRIDES == {"render.variant": "llvm_ad_spectral"}
    try:
        choose_variant("llvm_ad_spectral")
    except RenderError as error:
        pytest.skip(f"the figure's variant cannot run here: {error}")
    figure = script.make_figure()
    assert figure.shape == (320, 968, 3)
    assert script.difference(figure) <= script.TOLERANCE
