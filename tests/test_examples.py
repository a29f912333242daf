"""Issue 17 #5: the worked examples under examples/ run (small sizes) and hold the physics each
one prints: √n shot noise, exposure against ISO, demosaicing against square size, what an ISP
change leaves undoable. Each script exits non-zero when its own check fails."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.timeout(240)
@pytest.mark.parametrize("script, args, expect", [
    ("shot_noise_table.py", ["--pixels", "96"], "shot noise is Poisson"),
    ("exposure_vs_iso.py", ["--pixels", "96"], "brightness restored by the gain: True"),
    ("demosaic_checkerboard.py", ["-o", "{tmp}"], "wrote"),
    ("isp_forensics.py", ["-o", "{tmp}"], "clipping and quantisation lost: True"),
])
def test_a_worked_example_runs_and_holds(script, args, expect, tmp_path):
    done = subprocess.run([sys.executable, str(EXAMPLES / script), *(a.format(tmp=tmp_path) for a in args)],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert expect in done.stdout
