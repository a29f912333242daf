"""Render jobs shared by tests of different files: the bundled tabletop at its defaults (480 ×
320 px, 64 spp) costs ~45 s on 2 cores, so it is run once, as a CLI job in its own process,
for ``--dry-run``'s memory estimate against its peak (test_plan.py) and for its fireflies
(test_fireflies.py)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: Runs a command and prints its peak resident set (KiB): ``ru_maxrss`` of the waited-for
#: process (Linux wait4(2)), so the job's peak is its own, not the test process's.
LAUNCHER = r"""
import json, os, subprocess, sys
proc = subprocess.Popen(json.loads(sys.argv[1]), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
_, status, usage = os.wait4(proc.pid, 0)
print(usage.ru_maxrss)
sys.exit(os.waitstatus_to_exitcode(status))
"""


def planned_and_run(scene: str, width: int, folder: Path) -> tuple[dict, float, Path]:
    """``spectral-cam render --dry-run --json`` of the bundled ``scene`` at ``width`` × ⅔ of it,
    then the job itself into ``folder``/out, each in its own process: (the plan, the job's peak
    resident bytes, its result folder)."""
    cli = [sys.executable, "-m", "spectral_cam.cli", "render", str(ROOT / "scenes" / scene),
           f"--set=sensor.width_px={width}", f"--set=sensor.height_px={width * 2 // 3}"]
    plan = json.loads(subprocess.run(cli + ["--dry-run", "--json"], capture_output=True, text=True,
                                     check=True).stdout)
    out = folder / "out"
    done = subprocess.run([sys.executable, "-c", LAUNCHER, json.dumps(cli + ["-o", str(out), "-q"])],
                          capture_output=True, text=True, check=True)
    return plan, float(done.stdout) * 1024.0, out


@pytest.fixture(scope="session")
def tabletop_job(tmp_path_factory):
    """The bundled tabletop at its defaults (scenes/tabletop.toml: 480 × 320 px, 64 spp): its plan,
    its job's peak resident bytes and its result folder (radiance.exr, meta.json, ...)."""
    return planned_and_run("tabletop.toml", 480, tmp_path_factory.mktemp("tabletop_defaults"))
