"""Same seed, same bits (issue 12 #4): two renders of one scene and seed in one process are
bit-identical, with and without diffraction, and so are two CLI runs' radiance.exr."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam import render, scene_from_dict
from spectral_cam.cli import main
from spectral_cam.render.scene_dict import power_of_two_at_most

pytestmark = pytest.mark.timeout(180)


def _scene(**render_keys):
    # 27 spp per pixel in one pass was where the LLVM film's thread-ordered sums showed
    return scene_from_dict({"sensor": {"width_px": 240, "height_px": 160},
                            "render": {"spp": 27, "seed": 5, **render_keys}})


@pytest.mark.parametrize("diffraction", ["off", "on"])
def test_two_renders_of_one_seed_are_bit_identical(diffraction):
    config = _scene(diffraction=diffraction)
    first, second = render(config), render(config)
    np.testing.assert_array_equal(first.data, second.data)
    np.testing.assert_array_equal(first.depth_m, second.depth_m)
    assert all(power_of_two_at_most(n) == n for n in (first.meta["spp_per_pass"],))


def test_two_cli_runs_write_the_same_radiance(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text("[sensor]\nwidth_px = 240\nheight_px = 160\n[render]\nspp = 27\nseed = 5\n")
    for name in ("a", "b"):
        assert main(["render", str(scene), "-o", str(tmp_path / name), "-q"]) == 0
    for file in ("radiance.exr", "depth.exr", "raw.dng", "image.png"):
        assert (tmp_path / "a" / file).read_bytes() == (tmp_path / "b" / file).read_bytes(), file



HOG = "import time\nend = time.time() + 600\nwhile time.time() < end:\n    pass\n"


@pytest.fixture
def contention():
    """Two busy processes on the machine's cores and the renderer on 8 threads: the load under
    which a multi-threaded render's pixel sums come out in another order (issue 39 #17)."""
    import subprocess
    import sys

    import drjit

    hogs = [subprocess.Popen([sys.executable, "-c", HOG]) for _ in range(2)]
    threads = drjit.thread_count()
    drjit.set_thread_count(8)
    yield
    drjit.set_thread_count(threads)
    for hog in hogs:
        hog.kill()
        hog.wait()


def _tabletop(**render_keys):
    return scene_from_dict({"scene": {"preset": "tabletop"}, "sensor": {"width_px": 96, "height_px": 64},
                            "render": {"spp": 16, "diffraction": "off", **render_keys}})


@pytest.mark.timeout(600)
def test_render_deterministic_gives_the_same_bits_under_contention(contention):
    """``render.deterministic = true`` renders on one thread, so three renders of one scene under
    contention are bit-identical; the renderer's own thread count is restored afterwards."""
    import drjit

    config = _tabletop(deterministic=True)
    first = render(config)
    assert drjit.thread_count() == 8
    for _ in range(2):
        again = render(config)
        np.testing.assert_array_equal(again.data, first.data)
        np.testing.assert_array_equal(again.depth_m, first.depth_m)

