"""Fixtures shared by the validation tests: the example plan's run, CSV reading, the headless
Chromium probe, and the configuration of the ISP's own ColorChecker test."""

from __future__ import annotations

import csv
import time
from pathlib import Path

import pytest

from spectral_cam.apps.validate import plan_from_dict, run_plan
from spectral_cam.scene import read_toml, scene_from_dict
from tests.support.chromium import load_in_chromium
from tests.support.colorchecker import (
    NOISE_OFF,
    colorchecker_tables,
    delta_e_white_matched,
)

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="session")
def example_plan_path() -> Path:
    """plans/validate_example.toml."""
    return ROOT / "plans" / "validate_example.toml"


#: What the example fixture keeps of the example plan: both illuminants (the metamerism index
#: for a change of light), its base exposure, one camera, the ColorChecker, two seeds (an interval),
#: every pipeline type (dcraw through a shell, RawTherapee through argv with registration and
#: input padding; darktable, 1.6 s a cell, is left to test_recipes.py): 8 cells × 2 seeds where
#: the whole plan has 80 × 3.
EXAMPLE_CUT = {"cameras": ["nikon_d850"], "reflectance_sets": ["colorchecker"], "seeds": 2}
EXAMPLE_EXPOSURES = 1
EXAMPLE_PIPELINES = ("ours", "libraw-ahd", "dcraw", "rawtherapee")
#: The fixture's CPU seconds (this process and the tools it ran) may not exceed this, load or not
#: (CPU time, unlike wall time, barely moves with load): measured 6.9 s (28 s wall) at a load of 13
#: on 2 cores, up to ~12 s at 18 (OpenBLAS's threads spinning in the hue/sat map's fit; 4 s with one
#: BLAS thread). The whole plan, 80 cells × 2 seeds, took ~45 s of CPU and 75 s wall quiet, past the
#: 120 s timeout under load.
EXAMPLE_CPU_BUDGET_S = 30.0
#: The timeout of a test using the fixture (the first pays for it): ≥ 6× its 50 s wall at a load of
#: 18 on 2 cores.
EXAMPLE_TIMEOUT_S = 300


@pytest.fixture(scope="session")
def example(tmp_path_factory, example_plan_path):
    """The example plan, cut to :data:`EXAMPLE_CUT` and :data:`EXAMPLE_PIPELINES`, read from the
    file as a user would and run into a report folder: ``(result, folder, timing)``, ``timing``
    the run's ``wall_s`` and ``cpu_s`` (this process's and its children's user + system time)."""
    data = read_toml(example_plan_path, "validation plan")
    data["validate"].update(EXAMPLE_CUT)
    data["exposure"] = data["exposure"][:EXAMPLE_EXPOSURES]
    data["pipeline"] = [p for p in data["pipeline"] if p["name"] in EXAMPLE_PIPELINES]
    plan = plan_from_dict(data, base_dir=example_plan_path.parent, source=str(example_plan_path))
    out = tmp_path_factory.mktemp("validate") / "report"
    started, cpu = time.perf_counter(), _cpu_seconds()
    result = run_plan(plan, out)
    return result, out, {"wall_s": time.perf_counter() - started, "cpu_s": _cpu_seconds() - cpu}


def _cpu_seconds() -> float:
    """User + system CPU seconds of this process and its waited-for children (the tools)."""
    import resource

    return sum(u.ru_utime + u.ru_stime for u in (resource.getrusage(resource.RUSAGE_SELF),
                                                 resource.getrusage(resource.RUSAGE_CHILDREN)))


@pytest.fixture(scope="session")
def read_csv():
    """``read_csv(path)`` → list of dicts (one per row)."""

    def read(path):
        with open(path, newline="", encoding="utf-8") as handle:
            return list(csv.DictReader(handle))

    return read


@pytest.fixture(scope="session")
def chromium():
    """:func:`tests.support.chromium.load_in_chromium`: ``chromium(url) -> (page, errors)``."""
    return load_in_chromium


@pytest.fixture(scope="session")
def noise_off() -> dict:
    """[sensor] keys that switch every noise term off."""
    return dict(NOISE_OFF)


@pytest.fixture(scope="session")
def isp_colour_setup() -> dict:
    """The configuration of the ISP's own ColorChecker test (tests/isp/test_colour.py, its
    noise-free ``chart``): the scene tables, the SceneConfig, and that test's ΔE2000 —
    colour-science directly, white-matched — as ``delta_e(test_rgb, reference_rgb, white)``."""
    tables = colorchecker_tables(**NOISE_OFF)
    return {"tables": tables, "config": scene_from_dict(tables), "delta_e": delta_e_white_matched}
