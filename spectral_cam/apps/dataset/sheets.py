"""Dataset summaries drawn from a finished folder: the contact sheet and the blur chart.

Both read only what a run wrote (``manifest.jsonl``, ``dataset.json``, the items' images and
meta.json), so they can be redrawn at any time. Figures are matplotlib ``Figure`` objects
(:mod:`spectral_cam.viz`): drawing one never changes a user's matplotlib backend.

References
----------
.. [1] docs/design.md, "Result folder (job.py)" and "Optics (optics/)" (the thin-lens CoC).
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

__all__ = ["CONTACT_SHEET_MAX", "write_contact_sheet", "write_blur_chart", "caption_keys"]

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
