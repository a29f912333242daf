"""Fixtures shared by the validation tests: the example plan's run, CSV reading, the headless
Chromium probe, and the configuration of the ISP's own ColorChecker test."""

from __future__ import annotations

import csv
import time
from pathlib import Path

import pytest

from spectral_cam.apps.validate import load_plan, run_plan
from spectral_cam.scene import scene_from_dict
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


@pytest.fixture(scope="session")
def example(tmp_path_factory, example_plan_path):
    """The example plan run into a report folder: ``(result, folder, seconds)``, with two noise
    seeds per cell instead of its three (an interval needs two; the suite's time budget)."""
    out = tmp_path_factory.mktemp("validate") / "report"
    started = time.perf_counter()
    result = run_plan(load_plan(example_plan_path, {"validate.seeds": 2}), out)
    return result, out, time.perf_counter() - started


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
