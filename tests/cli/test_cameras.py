"""Issue 39 #9: each bundled camera's published sensor figures (full well, read noise, bit depth,
pitch, resolution, sensor size, base ISO) with a source per value, set by ``sensor.model`` for the
keys a scene leaves unset, listed by ``spectral-cam cameras``; a render through a named camera has
its bit depth (the DNG's WhiteLevel as LibRaw reads it) and its gain K = (2^bits − 1 − black) /
full well · ISO / base ISO (EMVA 1288 §2.2, docs/design.md) from the table."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from spectral_cam import spectra
from spectral_cam.errors import ConfigError
from spectral_cam.scene import scene_from_dict

FIGURES = ("full_well_e", "read_noise_e", "bit_depth", "pixel_pitch_um", "width_px", "height_px",
           "sensor_width_mm", "sensor_height_mm", "base_iso")
TABLE = Path(spectra.__file__).parent / "data" / "cameras" / "sensor_figures.csv"


def test_every_camera_has_every_figure_with_a_value_and_a_source():
    """Every camera ``sensor.model`` may name (17 bundled + 2 colour-science) has all nine figures,
    each a positive finite number with a source; the table names no other camera; an assumed value
    says why ("assumed: … no … found" or its reasoning), and the bit depths are 12 or 14."""
    with TABLE.open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert {row["camera"] for row in rows} == set(spectra.camera_names())
    assert len(spectra.camera_names()) == 19
    for name in spectra.camera_names():
        figures = spectra.camera_figures(name)
        assert set(figures) == set(FIGURES), name
        for key, figure in figures.items():
            assert math.isfinite(figure.value) and figure.value > 0, (name, key)
            assert len(figure.source) > 20, (name, key)
            if figure.source.startswith("assumed"):
                assert len(figure.source) > 60, (name, key, "an assumption says why")
        assert figures["bit_depth"].value in (12, 14)
    assert sum(f.source.startswith("assumed") for n in spectra.camera_names()
               for f in spectra.camera_figures(n).values()) < 3 * 19  # not every figure assumed


@pytest.mark.parametrize("name", spectra.camera_names())
def test_pitch_times_resolution_is_the_published_sensor_size(name):
    """Pixel pitch × effective columns and rows is the maker's sensor width and height within 1 %."""
    figures = spectra.camera_figures(name)
    pitch_mm = figures["pixel_pitch_um"].value * 1e-3
    assert pitch_mm * figures["width_px"].value == pytest.approx(figures["sensor_width_mm"].value, rel=0.01)
    assert pitch_mm * figures["height_px"].value == pytest.approx(figures["sensor_height_mm"].value, rel=0.01)


def test_a_named_camera_sets_the_keys_left_unset_and_explicit_keys_win():
    """A D850 and an α7 III no longer share full well, bit depth, pitch and base ISO; a key the
    scene sets wins, and the record says where each came from; a scene naming no camera keeps
    the generic figures."""
    d850 = scene_from_dict({"sensor": {"model": "nikon_d850"}}).sensor
    a7 = scene_from_dict({"sensor": {"model": "sony_ilce_7m3"}}).sensor
    for sensor, name in ((d850, "nikon_d850"), (a7, "sony_ilce_7m3")):
        table = spectra.camera_figures(name)
        assert (sensor.full_well_e, sensor.read_noise_e, sensor.bit_depth, sensor.pixel_pitch_um, sensor.base_iso) == (
            table["full_well_e"].value, table["read_noise_e"].value, table["bit_depth"].value,
            table["pixel_pitch_um"].value, table["base_iso"].value)
    assert (d850.full_well_e, d850.pixel_pitch_um, d850.base_iso) != (a7.full_well_e, a7.pixel_pitch_um, a7.base_iso)
    mine = scene_from_dict({"sensor": {"model": "nikon_d850", "full_well_e": 30000, "bit_depth": 12}}).sensor
    assert mine.full_well_e == 30000 and mine.bit_depth == 12 and mine.base_iso == 64
    record = spectra.figure_record(mine)
    assert record["full_well_e"]["from"] == "scene" and record["bit_depth"]["from"] == "scene"
    assert record["base_iso"]["from"].startswith("camera table (nikon_d850): Nikon D850 specifications")
    generic = scene_from_dict({}).sensor
    assert generic.full_well_e == 20000 and spectra.figure_record(generic)["full_well_e"]["from"].startswith("default")
    # a copy with another camera takes that camera's figures, keeping what the scene set
    other = scene_from_dict({"sensor": {"model": "nikon_d850", "full_well_e": 30000}}).replace(
        **{"sensor.model": "canon_eos_5d"})
    assert other.sensor.bit_depth == 12 and other.sensor.full_well_e == 30000
    assert other.sensor.pixel_pitch_um == spectra.camera_figures("canon_eos_5d")["pixel_pitch_um"].value


def test_the_cli_lists_every_camera_with_its_figures_and_sources():
    result = subprocess.run([sys.executable, "-m", "spectral_cam.cli", "cameras"], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    for name in spectra.camera_names():
        assert f"\n{name}\n" in f"\n{result.stdout}"
    assert "Nikon D850 specifications" in result.stdout and "assumed:" in result.stdout
    assert "full well" in result.stdout and "read noise" in result.stdout


@pytest.mark.timeout(300)
def test_a_render_through_a_named_camera_has_its_bit_depth_and_gain(tmp_path):
    """sensor.model = nikon_d850 at ISO 100: the DNG's WhiteLevel read by LibRaw (rawpy) is
    2^14 − 1, and meta.json's gain is (2^14 − 1 − black)/full well · 100/64 with the table's full
    well and base ISO (it was 12 bits and 20 000 e⁻ at base ISO 100 for every camera)."""
    rawpy = pytest.importorskip("rawpy")
    scene = tmp_path / "d850.toml"
    scene.write_text('[scene]\npreset = "colorchecker"\n[sensor]\nmodel = "nikon_d850"\nwidth_px = 36\n'
                     'height_px = 24\n[exposure]\niso = 100\n[render]\nspp = 4\n')
    out = tmp_path / "out"
    result = subprocess.run([sys.executable, "-m", "spectral_cam.cli", "render", str(scene), "-o", str(out)],
                            capture_output=True, text=True, timeout=280)
    assert result.returncode == 0, result.stderr
    table = spectra.camera_figures("nikon_d850")
    with rawpy.imread(str(out / "raw.dng")) as raw:
        assert raw.white_level == 2 ** 14 - 1
        black = float(raw.black_level_per_channel[0])
    meta = json.loads((out / "meta.json").read_text())
    sensor = _find(meta, "K_dn_per_e")
    expected = (2 ** 14 - 1 - black) / table["full_well_e"].value * 100 / table["base_iso"].value
    assert sensor["K_dn_per_e"] == pytest.approx(expected, rel=1e-9)
    assert sensor["sensor_figures"]["full_well_e"]["from"].startswith("camera table (nikon_d850)")
    assert sensor["sensor_figures"]["full_well_e"]["value"] == table["full_well_e"].value


def _find(tree, key):
    """The first dict in a JSON tree that holds ``key``."""
    if isinstance(tree, dict):
        if key in tree:
            return tree
        tree = list(tree.values())
    for item in tree if isinstance(tree, list) else ():
        found = _find(item, key)
        if found is not None:
            return found
    return None


def test_keep_field_of_view_needs_a_camera_and_agrees_with_a_given_pitch():
    with pytest.raises(ConfigError, match="keep_field_of_view = true needs a camera's published sensor size"):
        scene_from_dict({"sensor": {"keep_field_of_view": True}})
    with pytest.raises(ConfigError, match=r"pixel_pitch_um = 5 with sensor.keep_field_of_view = true"):
        scene_from_dict({"sensor": {"model": "nikon_d850", "keep_field_of_view": True, "pixel_pitch_um": 5}})
