"""Shared fixtures: tiny scenes that exercise the real code paths in seconds."""

from __future__ import annotations

import os

import pytest

from spectral_cam.scene import scene_from_dict


def tiny_scene(**sections):
    """A scene dict with a small sensor; sections override the defaults."""
    base = {
        "sensor": {"width_px": 24, "height_px": 16, "pixel_pitch_um": 6.0},
        "render": {"spp": 16},
    }
    for name, table in sections.items():
        base.setdefault(name, {}).update(table)
    return scene_from_dict(base)


@pytest.fixture(scope="session")
def make_scene():
    """Factory: ``make_scene(scene={...}, lens={...})`` -> a validated tiny SceneConfig."""
    return tiny_scene


@pytest.fixture(scope="session")
def variant():
    """The variant 'auto' resolves to on this machine (llvm with libLLVM >= 16, else scalar)."""
    from spectral_cam.render import choose_variant

    return choose_variant("auto")


@pytest.fixture
def cli_env():
    """Environment for CLI subprocesses: this interpreter's venv first on PATH."""
    env = dict(os.environ)
    return env
