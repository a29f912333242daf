"""The blur-vs-depth chart a DOF researcher reads (issue 39 #20): nine series of a 3 × 3 sweep are
told apart by more than colour, and the chart says where the lens's diffraction went."""

from __future__ import annotations

import json

import pytest
from matplotlib.colors import to_hex

from spectral_cam.apps.dataset import sheets
from spectral_cam.records import write_json
from spectral_cam.scene import scene_from_dict

F_NUMBERS, FOCUS_M = (1.4, 4.0, 16.0), (1.5, 2.25, 3.0)
AIRY = {"diffraction": {"choice": "airy_psf_per_band"}}


@pytest.fixture
def sweep(tmp_path):
    """A 3 × 3 sweep folder of dof_targets items, each with blur rows and diffraction in both renders."""
    rows = []
    for index, (n, focus) in enumerate((n, focus) for n in F_NUMBERS for focus in FOCUS_M):
        config = scene_from_dict({"scene": {"preset": "dof_targets"}, "lens": {"f_number": n, "focus_distance_m": focus}})
        blur = [{"depth_m": z, "predicted_coc_px": 2.0, "measured_coc_px": 2.3, "pixels": 99, "note": None}
                for z in (1.0, 2.0, 4.0)]
        folder = tmp_path / "items" / f"{index:06d}"
        folder.mkdir(parents=True)
        write_json({"config": config.to_dict(), "blur": blur, "model_decisions": AIRY,
                    "all_in_focus": {"model_decisions": AIRY}}, folder / "meta.json")
        rows.append({"id": f"{index:06d}", "status": "done", "path": f"items/{index:06d}",
                     "params": {"lens.f_number": n, "lens.focus_distance_m": focus}})
    (tmp_path / "manifest.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    write_json({"spec": {"sweeps": [{"key": "lens.f_number", "values": list(F_NUMBERS)},
                                    {"key": "lens.focus_distance_m", "values": list(FOCUS_M)}]}},
               tmp_path / "dataset.json")
    return tmp_path


def _drawn(monkeypatch, folder):
    figures = []
    monkeypatch.setattr(sheets, "save_png", lambda fig, path, **_: figures.append(fig) or path)
    sheets.write_blur_chart(folder)
    (fig,) = figures
    (ax,) = fig.axes
    return ax


def test_nine_series_differ_in_colour_line_style_and_marker(monkeypatch, sweep):
    ax = _drawn(monkeypatch, sweep)
    legend = ax.get_legend()
    series = {text.get_text(): handle for text, handle in zip(legend.get_texts(), legend.legend_handles)
              if text.get_text().startswith("f_number=")}
    assert len(series) == 9
    looks = {(to_hex(h.get_color()), h.get_linestyle(), h.get_marker()) for h in series.values()}
    assert len(looks) == 9
    # one colour per f-number, one line style and marker per focus distance: f/1.4 curves apart by shape
    f14 = [h for label, h in series.items() if label.startswith("f_number=1.4,")]
    assert len({(h.get_linestyle(), h.get_marker()) for h in f14}) == 3
    assert len({to_hex(h.get_color()) for h in f14}) == 1
    assert ax.get_yscale() == "log"  # 0.5 px at f/16 and 50 px at f/1.4 both readable


def test_the_chart_says_diffraction_is_in_both_images(monkeypatch, sweep):
    ax = _drawn(monkeypatch, sweep)
    notes = [t.get_text() for t in ax.get_legend().get_texts()]
    # Airy first dark ring 2.44·λ·N_w at 550 nm, f/16 focused at 1.5 m with a 25 mm lens, 6 µm pixels
    n_w = 16.0 * (1 + 0.025 / (1.5 - 0.025))
    airy_px = 2.44 * 550e-9 * n_w / 6e-6
    assert any(f"Airy ≤ {airy_px:.1f} px at 550 nm) is in both images" in note for note in notes), notes
