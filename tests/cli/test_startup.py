"""Start-up (issue 13 #6): the commands that need no rendering — ``develop``, ``cameras``,
``--help`` — must not import the renderer (Mitsuba, drjit), Dask, or colour-science
(whose import loads matplotlib and scipy, ~1 s): a develop should start like rawpy."""

from __future__ import annotations

import json
import subprocess
import sys

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


@pytest.mark.parametrize("argv", [("--help",), ("cameras",)])
def test_listing_commands_import_nothing_heavy(argv):
    assert _modules_imported_by(*argv) == []


@pytest.mark.parametrize("demosaic", ["menon2007", "malvar2004"])
def test_develop_imports_nothing_heavy(small_dng, tmp_path, demosaic):
    out = tmp_path / f"{demosaic}.png"
    assert _modules_imported_by("develop", str(small_dng), "-o", str(out), "--set", f"isp.demosaic={demosaic}") == []
    assert out.exists()
