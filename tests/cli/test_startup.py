"""Start-up (issue 13 #6): the commands that need no rendering — ``develop``, ``cameras``,
``--help`` — must not import the renderer (Mitsuba, drjit), Dask, or colour-science
(whose import loads matplotlib and scipy, ~1 s): a develop should start like rawpy.
Loading and validating a scene (issue 14 #3) must not either: names are checked against
written-out lists, spectra load when the render needs them."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from spectral_cam.raw import RawImage, write_dng

pytestmark = pytest.mark.timeout(120)

HEAVY = ("mitsuba", "drjit", "dask", "distributed", "matplotlib", "colour", "colour_demosaicing", "scipy")

_PROBE = """
import json, runpy, sys
sys.argv = ["spectral-cam"] + sys.argv[1:]
try:
    runpy.run_module("spectral_cam.cli", run_name="__main__")
except SystemExit as stop:
    code = stop.code
heavy = {heavy!r}
print(json.dumps([name for name in heavy if name in sys.modules]), file=sys.stderr)
"""


def _modules_imported_by(*argv: str) -> list[str]:
    done = subprocess.run([sys.executable, "-c", _PROBE.format(heavy=HEAVY), *argv],
                          capture_output=True, text=True, timeout=100)
    return json.loads(done.stderr.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def small_dng(tmp_path_factory):
    mosaic = np.random.default_rng(0).integers(600, 3000, (48, 64)).astype(np.uint16)
    raw = RawImage(mosaic, "RGGB", 512.0, 4095, color_matrix=np.eye(3), as_shot_neutral=np.ones(3))
    return write_dng(raw, tmp_path_factory.mktemp("startup") / "small.dng")


@pytest.mark.parametrize("argv", [("--help",), ("cameras",), ("render", "--help")])
def test_listing_commands_import_nothing_heavy(argv):
    assert _modules_imported_by(*argv) == []


@pytest.mark.parametrize("demosaic", ["menon2007", "malvar2004"])
def test_develop_imports_nothing_heavy(small_dng, tmp_path, demosaic):
    out = tmp_path / f"{demosaic}.png"
    assert _modules_imported_by("develop", str(small_dng), "-o", str(out), "--set", f"isp.demosaic={demosaic}") == []
    assert out.exists()


SCENES = Path(__file__).resolve().parents[2] / "scenes"

_LOAD_PROBE = """
import json, sys
import spectral_cam
for path, overrides in json.loads(sys.argv[1]):
    spectral_cam.load_scene(path, overrides=overrides)
print(json.dumps([name for name in {heavy!r} if name in sys.modules]))
"""


def _modules_imported_loading(*jobs) -> list[str]:
    """Heavy modules imported by ``load_scene(path, overrides)`` for each (path, overrides)."""
    jobs = [[str(path), list(overrides)] for path, overrides in jobs]
    done = subprocess.run([sys.executable, "-c", _LOAD_PROBE.format(heavy=HEAVY), json.dumps(jobs)],
                          capture_output=True, text=True, timeout=100, check=False)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_loading_the_bundled_scenes_imports_nothing_heavy():
    assert _modules_imported_loading((SCENES / "colorchecker.toml", [])) == []
    assert _modules_imported_loading(*[(path, []) for path in sorted(SCENES.glob("*.toml"))]) == []


def test_validating_every_kind_of_spectrum_imports_nothing_heavy(tmp_path):
    """Names, numbers, CSVs and filters are all checked without colour-science."""
    spd = tmp_path / "led.csv"
    spd.write_text("wavelength_nm,value\n400,0\n450,1\n500,0.5\n")
    scene = SCENES / "colorchecker.toml"
    assert _modules_imported_loading(
        (scene, ["illuminant.spd=F40/DX (Broadband FL)", "scene.preset=flat_field", "scene.reflectance=dark skin",
                 "sensor.model=sigma_sdmerill_npl", "sensor.ir_cut=ir_cut:650", "lens.transmission=0.9"]),
        (scene, [f"illuminant.spd={spd}", "scene.preset=flat_field", f"scene.reflectance={spd}",
                 f"lens.transmission={spd}", f"sensor.ir_cut={spd}"]),
        (scene, ["illuminant.spd=blackbody:3200", "scene.preset=flat_field", "scene.reflectance=0.5",
                 "sensor.model=ideal", "sensor.cfa=none"]),
    ) == []


def test_colour_science_loads_its_plotting_only_when_a_user_plots():
    """spectral_cam defers colour.plotting (matplotlib, ~0.6 s of ``import colour``): colour's own
    code runs without it, and a user's ``from colour.plotting import …`` still gets the real thing."""
    code = (
        "import sys, spectral_cam, colour\n"
        "assert 'matplotlib' not in sys.modules\n"
        "assert colour.sd_to_XYZ(colour.SDS_ILLUMINANTS['D65']).shape == (3,)\n"
        "assert 'matplotlib' not in sys.modules\n"
        "from colour.plotting import plot_single_colour_swatch, ColourSwatch\n"
        "import colour.plotting.diagrams\n"
        "figure, _ = plot_single_colour_swatch(ColourSwatch((0.45, 0.31, 0.04)), show=False)\n"
        "assert 'matplotlib' in sys.modules and type(figure).__name__ == 'Figure'\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=100,
                          env={**__import__("os").environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 0, done.stderr[-2000:]
