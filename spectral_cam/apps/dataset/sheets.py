"""Dataset summaries drawn from a finished folder: the contact sheet, the label preview and the
blur chart.

Both read only what a run wrote (``manifest.jsonl``, ``dataset.json``, the items' images and
meta.json), so they can be redrawn at any time. Figures are matplotlib ``Figure`` objects
(:mod:`spectral_cam.viz`): drawing one never changes a user's matplotlib backend.

References
----------
.. [1] docs/design.md, "Result folder (job.py)" and "Optics (optics/)" (the thin-lens CoC).
.. [2] Crameri, F., Shephard, G. E. & Heron, P. J. (2020). The misuse of colour in science
   communication. Nat. Commun. 11, 5444 (perceptually uniform maps for data; diverging maps centred
   on a meaningful zero).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import ConfigError
from ...records import exact_number, format_number, read_json, write_csv
from ...viz import figure, save_png

__all__ = ["CONTACT_SHEET_MAX", "PREVIEW_ITEMS", "PREVIEW_LABELS", "write_contact_sheet", "write_label_preview",
           "write_blur_chart", "caption_keys", "id_colours"]

#: Items on the contact sheet of a dataset (the first ones; a sweep's grid is usually smaller).
CONTACT_SHEET_MAX = 64


def _manifest_rows(output: Path) -> list[dict]:
    path = output / "manifest.jsonl"
    if not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]


def _format(value: Any) -> str:
    """A parameter for a label: three significant figures, whole numbers from 100 up."""
    if isinstance(value, list):
        return "[" + ", ".join(_format(v) for v in value) + "]"
    if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
        return format_number(value, digits=max(3, len(f"{abs(value):.0f}")))
    return format_number(value)


def _applies(params: Mapping[str, Any], key: str) -> bool:
    """Whether a drawn parameter means anything for the item's preset (issue 25 #20: a dead_leaves
    tile was labelled with the sun's hour): ``[sky]`` keys only for presets the sun lights,
    ``[scene]`` keys only for presets that read them."""
    from ...presets import PRESETS

    preset = params.get("scene.preset")
    if preset not in PRESETS.names():
        return True
    options = PRESETS[preset].options
    if key.startswith("sky."):
        return "light" in options and params.get("scene.light", "auto") != "illuminant"
    if key.startswith("scene.") and key != "scene.preset":
        return key.split(".", 1)[1] in options
    return True


def _label(params: Mapping[str, Any], keys: Sequence[str], *, per_line: int = 1) -> str:
    """``key=value`` of the given parameters (short key names) that apply to the item,
    ``per_line`` to a line."""
    parts = [f"{key.split('.', 1)[1]}={_format(params.get(key))}" for key in keys if _applies(params, key)]
    return "\n".join("  ".join(parts[i:i + per_line]) for i in range(0, len(parts), per_line))


def caption_keys(spec: Mapping[str, Any], rows: Sequence[Mapping[str, Any]], *, most: int = 6) -> list[str]:
    """The parameters worth a caption: those whose values differ among ``rows`` — sweep axes
    first, then choices (a preset, a camera model), then sampled numbers — at most ``most``.

    Examples
    --------
    >>> spec = {"sweeps": [], "distributions": {"lens.f_number": {"uniform": [2, 8]},
    ...                                         "scene.preset": {"choice": ["a", "b"]}}}
    >>> caption_keys(spec, [{"params": {"lens.f_number": 2.0, "scene.preset": "a"}},
    ...                     {"params": {"lens.f_number": 4.0, "scene.preset": "b"}}])
    ['scene.preset', 'lens.f_number']
    """
    distributions = spec.get("distributions", {})
    swept = [s["key"] for s in spec.get("sweeps", [])]
    choices = sorted(k for k, d in distributions.items() if "choice" in d and k not in swept)
    sampled = sorted(k for k in distributions if k not in swept and k not in choices)

    def varies(key: str) -> bool:
        return len({json.dumps((row.get("params") or {}).get(key), sort_keys=True) for row in rows}) > 1

    return [key for key in swept + choices + sampled if varies(key)][:most]


def _thumbnail(path: Path) -> np.ndarray:
    """An 8-bit RGB array of a developed image (PNG 8/16-bit, JPEG, TIFF)."""
    import cv2

    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ConfigError(f"{path} is not a readable image")
    if image.dtype == np.uint16:
        image = (image // 257).astype(np.uint8)
    if image.ndim == 2:
        return np.repeat(image[..., None], 3, axis=-1)
    return np.ascontiguousarray(image[..., 2::-1])


def write_contact_sheet(output: str | Path, path: str | Path | None = None, *,
                        columns: int | None = None, limit: int = CONTACT_SHEET_MAX,
                        keys: Sequence[str] | None = None) -> Path | None:
    """A PNG grid of the items' developed images, labelled with their swept/sampled values.

    Parameters
    ----------
    output
        The dataset folder (reads manifest.jsonl and dataset.json).
    path
        The PNG (default ``<output>/contact_sheet.png``).
    columns
        Grid columns (default: the last sweep axis' length for a two-axis sweep, else up
        to 6).
    limit
        Items shown at most (the first ones).
    keys
        Parameters in each label (default :func:`caption_keys`: the keys whose values vary
        among the items shown, sweeps and choices first; at most six, one to a line).

    Returns
    -------
    pathlib.Path or None
        The PNG, or None when the items have no developed images.

    References
    ----------
    .. [1] Matplotlib ``Figure.subplots`` and ``Axes.imshow``.
    """
    output = Path(output)
    path = Path(path) if path else output / "contact_sheet.png"
    rows = _manifest_rows(output)[:limit]
    info = read_json(output / "dataset.json") or {}
    sweeps = info.get("spec", {}).get("sweeps", [])
    if keys is None:
        keys = caption_keys(info.get("spec", {}), rows)
    keys = list(keys)[:6]
    images = []
    for row in rows:
        names = {Path(f).name: f for f in row.get("files") or []}
        found = [names[n] for n in ("image.png", "image.jpg", "image.16bit.png", "image.tif") if n in names]
        images.append(output / found[0] if found else None)
    if not any(images):
        return None
    if columns is None:
        two_axes = len(sweeps) == 2 and info.get("per_grid_point") == 1
        columns = len(sweeps[-1]["values"]) if two_axes else min(6, len(rows))
    columns = max(1, min(columns, len(rows)))
    lines = max(1, (len(rows) + columns - 1) // columns)
    sample = _thumbnail(next(p for p in images if p))
    aspect = sample.shape[0] / sample.shape[1]
    fig = figure(2.6 * columns, (2.6 * aspect + 0.14 * (len(keys) + 1) + 0.15) * lines)
    axes = fig.subplots(lines, columns, squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for ax, row, image in zip(axes.ravel(), rows, images):
        if image is not None:
            ax.imshow(_thumbnail(image), interpolation="nearest")
        else:
            ax.text(0.5, 0.5, "failed" if row.get("status") == "failed" else "missing", ha="center",
                    va="center", color="crimson", transform=ax.transAxes)
        title = f"#{row['id']}"
        if keys:
            title += "\n" + _label(row.get("params") or {}, keys)
        ax.set_title(title, fontsize=6.5, linespacing=1.1)
    return save_png(fig, path, dpi=110)


#: Items on the label preview (the first finished ones).
PREVIEW_ITEMS = 4
#: Labels the preview shows, in its column order, where the items hold them.
PREVIEW_LABELS = ("image", "depth", "segmentation", "semantic", "defocus", "normals")
_PREVIEW_TITLES = {"image": "image", "depth": "depth", "segmentation": "instances (segmentation)",
                   "semantic": "classes (semantic)", "defocus": "defocus (signed CoC)", "normals": "normals (camera)"}


def id_colours(ids: np.ndarray, table: Mapping[int, Sequence[int]] | None = None) -> np.ndarray:
    """(…, 3) float RGB of integer ids: black for 0 (nothing), the colour ``table`` gives an id
    (classes.json's sRGB 0–255), else hues a golden angle (≈ 0.382 turn) apart, so consecutive
    ids, the neighbours on a segmentation, differ most.

    References
    ----------
    .. [1] Green-Armytage, P. (2010). A colour alphabet and the limits of colour coding. Colour:
       Design & Creativity 5, 1–23 (distinct colours for categories).
    """
    import matplotlib.colors

    ids = np.asarray(ids, dtype=np.int64)
    unique, inverse = np.unique(ids, return_inverse=True)
    colours = np.zeros((len(unique), 3))
    for k, value in enumerate(unique):
        if value == 0:
            continue
        if table and int(value) in table:
            colours[k] = np.asarray(table[int(value)][:3], dtype=float) / 255.0
        else:
            hue = (value * 0.381966) % 1.0
            colours[k] = matplotlib.colors.hsv_to_rgb((hue, 0.55 + 0.35 * (value % 3) / 2, 0.95 - 0.2 * (value % 2)))
    return colours[inverse.reshape(ids.shape)]


def _preview_items(output: Path, limit: int) -> list[tuple[dict, dict]]:
    """(manifest row, loader item) of the first finished items, each with the preview labels it holds."""
    from .card import written_labels
    from .loader import LOADABLE_LABELS, read_item

    found = []
    for row in _manifest_rows(output):
        if row.get("status") != "done":
            continue
        labels = [name for name in PREVIEW_LABELS if name in LOADABLE_LABELS and name in written_labels(row)]
        found.append((row, read_item(output / row["path"], labels)))
        if len(found) == limit:
            break
    return found


def _class_table(output: Path) -> dict[int, dict]:
    try:
        from .loader import read_classes
    except ImportError:  # a loader without class maps
        return {}
    try:
        return read_classes(output)
    except Exception:  # noqa: BLE001 - no classes.json: ids get their golden-angle colours
        return {}


def _depth_norm(values: list[np.ndarray]):
    """The depth colour scale shared by the rows: 1st–99th percentile of the finite depths,
    logarithmic where they span more than a decade (a room beside a distant sky)."""
    import matplotlib.colors

    finite = np.concatenate([v[np.isfinite(v) & (v > 0)] for v in values] or [np.array([1.0])])
    if finite.size == 0:
        finite = np.array([1.0])
    low, high = np.percentile(finite, [1, 99])
    high = max(high, low * 1.001)
    return matplotlib.colors.LogNorm(low, high) if high / low > 10 else matplotlib.colors.Normalize(low, high)


def _defocus_norm(values: list[np.ndarray]):
    """A diverging scale centred on 0 (in focus), ± the 99th percentile of |CoC|."""
    import matplotlib.colors

    finite = np.concatenate([np.abs(v[np.isfinite(v)]) for v in values] or [np.array([1.0])])
    bound = float(np.percentile(finite, 99)) if finite.size else 1.0
    return matplotlib.colors.Normalize(-max(bound, 0.5), max(bound, 0.5))


def write_label_preview(output: str | Path, path: str | Path | None = None, *,
                        items: int = PREVIEW_ITEMS) -> Path | None:
    """A PNG grid of the first items' labels beside their images: one row per item, one column per
    label the items hold (:data:`PREVIEW_LABELS`).

    Depth in metres on the perceptually uniform ``viridis`` (near dark, far bright; grey where no
    surface was hit), one scale for every row, logarithmic when the depths span more than a decade;
    instance and class ids in distinct colours (classes.json's colours for classes, with a legend
    of the classes shown); signed defocus (CoC diameter, px; + behind the focus plane) on the
    diverging ``RdBu_r`` centred on 0; camera-space normals as RGB = (n + 1) / 2. Each colour-mapped
    column has its colour bar with units under it.

    Parameters
    ----------
    output
        The dataset folder (reads manifest.jsonl, the items and classes.json).
    path
        The PNG (default ``<output>/label_preview.png``).
    items
        Rows: the first finished items.

    Returns
    -------
    pathlib.Path or None
        The PNG, or None when no finished item holds an image or a label to show.

    References
    ----------
    .. [1] Matplotlib, "Choosing colormaps" (sequential perceptually uniform maps; diverging maps).
    """
    import matplotlib
    import matplotlib.patches

    output = Path(output)
    path = Path(path) if path else output / "label_preview.png"
    found = _preview_items(output, items)
    columns = [name for name in PREVIEW_LABELS if any(name in item for _, item in found)]
    if not found or not columns:
        return None
    frame = next(np.shape(item[name])[:2] for _, item in found for name in columns if name in item)
    aspect = frame[0] / frame[1]
    classes = _class_table(output)
    fig = figure(2.3 * len(columns), 2.3 * aspect * len(found) + 1.5)
    # a last, thin row for the colour bars: every column's panels keep one size and line up
    grid = fig.add_gridspec(len(found) + 1, len(columns), height_ratios=[2.3 * aspect] * len(found) + [0.12])
    axes = np.array([[fig.add_subplot(grid[r, c]) for c in range(len(columns))] for r in range(len(found))])
    norms = {"depth": _depth_norm([item["depth"] for _, item in found if "depth" in item]),
             "defocus": _defocus_norm([item["defocus"] for _, item in found if "defocus" in item])}
    maps = {"depth": matplotlib.colormaps["viridis"].with_extremes(bad="0.75"),
            "defocus": matplotlib.colormaps["RdBu_r"]}
    shown_classes: set[int] = set()
    mappables = {}
    for r, (row, item) in enumerate(found):
        for c, name in enumerate(columns):
            ax = axes[r, c]
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(_PREVIEW_TITLES[name], fontsize=8)
            if c == 0:
                ax.set_ylabel(f"#{row['id']}" + (f"\n{row['split']}" if row.get("split") else ""), fontsize=7)
            if name not in item:
                ax.text(0.5, 0.5, "not written", ha="center", va="center", fontsize=7, color="0.4",
                        transform=ax.transAxes)
                continue
            value = np.asarray(item[name])
            if name in norms:
                shown = np.where(np.isfinite(value), value, np.nan)
                mappables[name] = ax.imshow(shown, cmap=maps[name], norm=norms[name], interpolation="nearest")
            elif name in ("segmentation", "semantic"):
                table = {k: v["colour"] for k, v in classes.items()} if name == "semantic" else None
                ax.imshow(id_colours(value, table), interpolation="nearest")
                if name == "semantic":
                    shown_classes |= {int(v) for v in np.unique(value) if v}
            elif name == "normals":
                ax.imshow(np.clip((np.nan_to_num(value[..., :3]) + 1.0) / 2.0, 0, 1), interpolation="nearest")
            else:
                ax.imshow(value if value.dtype == np.uint8 else (value / 257).astype(np.uint8), interpolation="nearest")
    units = {"depth": "depth z (m); grey: no surface", "defocus": "signed CoC diameter (px), + behind focus"}
    for name, mappable in mappables.items():
        bar = fig.colorbar(mappable, cax=fig.add_subplot(grid[len(found), columns.index(name)]),
                           orientation="horizontal")
        bar.set_label(units[name], fontsize=7)
        bar.ax.tick_params(labelsize=6.5)
    if "normals" in columns:
        axes[-1, columns.index("normals")].set_xlabel("RGB = (n + 1) / 2, n in camera axes", fontsize=6.5)
    if shown_classes:
        handles = [matplotlib.patches.Patch(color=id_colours(np.array([k]), {k: classes[k]["colour"]})[0],
                                            label=classes[k]["name"]) for k in sorted(shown_classes) if k in classes]
        fig.legend(handles=handles[:16], loc="lower center", ncol=min(len(handles), 6), fontsize=6.5, frameon=False,
                   title="classes (semantic)", title_fontsize=7)
    fig.suptitle(f"Labels of the first {len(found)} items", fontsize=9)
    return save_png(fig, path, dpi=110)


_LINES = ("-", "--", ":", "-.")
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")


def _series_styles(params: Sequence[Mapping[str, Any]], keys: Sequence[str]) -> tuple[list, list]:
    """A colour per value of the first sweep key and a line style and marker per value of the
    second (per series without keys), so that series stay apart in grey print and where
    their curves overlap."""
    import matplotlib

    def ranks(key):
        values = [_format(p.get(key)) for p in params]
        order = list(dict.fromkeys(values))
        return [order.index(v) for v in values]

    by_colour = ranks(keys[0]) if keys else list(range(len(params)))
    by_style = ranks(keys[1]) if len(keys) > 1 else (list(range(len(params))) if not keys else by_colour)
    count = max(by_colour) + 1
    palette = matplotlib.colormaps["tab10"] if count <= 10 else matplotlib.colormaps["viridis"]
    colours = [palette(i) if count <= 10 else palette(0.9 * i / max(count - 1, 1)) for i in by_colour]
    return colours, [(_LINES[i % len(_LINES)], _MARKERS[i % len(_MARKERS)]) for i in by_style]


def _diffraction_in_both(meta: Mapping[str, Any]) -> bool:
    """Whether the item and its all-in-focus twin were both rendered with the Airy PSF."""
    def applied(decisions):
        return ((decisions or {}).get("diffraction") or {}).get("choice") not in (None, "skipped")

    return applied(meta.get("model_decisions")) and applied((meta.get("all_in_focus") or {}).get("model_decisions"))


def write_blur_chart(output: str | Path, *, png: str | Path | None = None,
                     csv_path: str | Path | None = None) -> Path | None:
    """Measured blur against depth beside the thin-lens prediction, one series per item.

    Reads each finished item's ``meta.json`` ``blur`` rows (from
    :func:`spectral_cam.apps.dataset.labels.measure_scene_blur`) and draws the predicted
    |CoC|(z) curve of its lens with the measured diameters as markers, and a cross at the
    prediction where no measurement was possible; writes the numbers as CSV too (every digit
    kept), with the reason for each missing measurement in its ``note`` column.

    Parameters
    ----------
    output
        The dataset folder.
    png, csv_path
        Outputs (default ``<output>/blur_vs_depth.png`` and ``.csv``).

    Returns
    -------
    pathlib.Path or None
        The PNG, or None when no item measured its blur.

    References
    ----------
    .. [1] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10.
    """
    import matplotlib
    import matplotlib.ticker

    from ...optics import ThinLens
    from ...scene import scene_from_dict

    output = Path(output)
    png = Path(png) if png else output / "blur_vs_depth.png"
    csv_path = Path(csv_path) if csv_path else output / "blur_vs_depth.csv"
    info = read_json(output / "dataset.json") or {}
    keys = [s["key"] for s in info.get("spec", {}).get("sweeps", [])]
    series = []
    for row in _manifest_rows(output):
        if row.get("status") != "done":
            continue
        meta = read_json(output / row["path"] / "meta.json")
        if not isinstance(meta, dict) or not meta.get("blur"):
            continue
        series.append((row, meta))
    if not series:
        return None
    table = []
    unmeasured, airy_px = 0, []
    fig = figure(8.0, 6.4)
    ax = fig.subplots()
    colours, styles = _series_styles([row.get("params") or {} for row, _ in series], keys)
    for (row, meta), colour, (line, marker) in zip(series, colours, styles):
        config = scene_from_dict(meta["config"])
        lens = ThinLens.from_config(config.lens, config.sensor)
        if _diffraction_in_both(meta):
            airy_px.append(float(lens.airy_diameter_m(550.0)) / lens.pixel_pitch_m)
        depths = [b["depth_m"] for b in meta["blur"]]
        z = np.geomspace(min(depths) * 0.8, max(depths) * 1.25, 200)
        label = _label(row.get("params") or {}, keys).replace("\n", ", ") or f"#{row['id']}"
        ax.plot(z, lens.coc_diameter_px(z), color=colour, ls=line, lw=1.2)
        ax.plot([], [], color=colour, ls=line, marker=marker, mfc="none", label=label)
        measured = [(b["depth_m"], b["measured_coc_px"]) for b in meta["blur"] if b["measured_coc_px"] is not None]
        if measured:
            ax.plot(*zip(*measured), marker, color=colour, ms=5.5, mfc="none", mew=1.2)
        missing = [(b["depth_m"], b["predicted_coc_px"]) for b in meta["blur"] if b["measured_coc_px"] is None]
        if missing:  # shown where the prediction is, with the reason in the CSV
            ax.plot(*zip(*missing), "x", color=colour, ms=6)
            unmeasured += len(missing)
        for b in meta["blur"]:
            table.append({"id": row["id"], **{k: (row.get("params") or {}).get(k) for k in keys},
                          "depth_m": b["depth_m"], "predicted_coc_px": b["predicted_coc_px"],
                          "measured_coc_px": b["measured_coc_px"], "pixels": b["pixels"],
                          "note": b.get("note") or ""})
    ax.plot([], [], "-", color="grey", label="line: thin-lens |CoC|(z)")
    ax.plot([], [], "o", color="grey", mfc="none", label="hollow marker: measured (image vs. all-in-focus)")
    if airy_px:
        # the pinhole twin is rendered with the same Airy PSF, so the fit sees defocus alone; say so
        # where diffraction is large, or a reader takes a small-blur excess for it (issue 39 #20)
        ax.plot([], [], " ", label=f"diffraction (Airy ≤ {max(airy_px):.1f} px at 550 nm) is in both images: "
                                   "not in the measured blur")
    if any(b["measured_coc_px"] is not None and b["predicted_coc_px"] < 3.0 for _, meta in series for b in meta["blur"]):
        ax.plot([], [], " ", label="blurs of a few px read high alike at every f-number (a disc fitted on the "
                                   "pixel grid: metrics.blur)")
    if unmeasured:
        ax.plot([], [], "x", color="grey", label=f"not measured ({unmeasured}: the reason is in the CSV's note)")
    ax.set_xscale("log")
    ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax.xaxis.set_minor_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax.tick_params(axis="x", which="minor", labelsize=7)
    ax.set_xlabel("depth z (m)")
    # log: a 0.5 px blur at f/16 and a 50 px one at f/1.4 on one chart (the prediction's zero at the
    # focus distance drops below the axis)
    ax.set_yscale("log")
    shown = [b[k] for _, meta in series for b in meta["blur"] for k in ("measured_coc_px", "predicted_coc_px")
             if b[k] is not None and b[k] > 0]
    ax.set_ylim(bottom=0.5 * min(shown, default=1.0))
    ax.yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax.set_ylabel("blur diameter |CoC| (pixels)")
    ax.set_title("Measured defocus blur vs. thin-lens prediction")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6.5, ncol=2 if len(series) > 4 else 1, loc="upper center", bbox_to_anchor=(0.5, -0.12))
    save_png(fig, png, dpi=120)
    write_csv(table, csv_path, list(table[0]), number=exact_number)
    return png
