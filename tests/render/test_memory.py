"""Frames too large for memory are refused with an estimate before Mitsuba starts."""

from __future__ import annotations

import pytest

from spectral_cam import render, scene_from_dict


@pytest.mark.timeout(60)
def test_a_frame_too_large_for_memory_is_refused_before_mitsuba_starts():
    """Issue 12 #12: 20000 × 20000 px passed validation and segfaulted in Mitsuba."""
    from spectral_cam.errors import ConfigError
    from spectral_cam.render.memory import available_bytes, estimate_render_bytes

    from spectral_cam.errors import SceneWarning

    config = scene_from_dict({"sensor": {"width_px": 20000, "height_px": 20000}})
    assert estimate_render_bytes(20000, 20000) > available_bytes()  # 600 GB on any machine here
    with pytest.raises(ConfigError, match=r"needs about \d+\.\d GB of memory .* lower sensor.width_px"), \
            pytest.warns(SceneWarning, match="165° across"):  # 120 mm of sensor behind 8 mm, said first
        render(config)


def test_the_estimate_lets_a_45_mp_frame_in_24_gb_and_says_what_else_fits():
    """Issue 14 #2: frames render in tiles, so Mitsuba's share stops growing at one tile and a
    45 MP (8256 × 5504) 31-band job fits a 24 GB machine; the refusal offers the size that
    fits and the 6-channel camera film."""
    from spectral_cam.render import memory
    from spectral_cam.render.scene_dict import TILE_PIXELS

    assert memory.estimate_render_bytes(8256, 5504) < 20e9
    tile = memory.estimate_render_bytes(1024, TILE_PIXELS // 1024)
    assert memory.estimate_render_bytes(1024, 2 * TILE_PIXELS // 1024) - tile == pytest.approx(
        TILE_PIXELS * (4 * 31 + memory.PIPELINE_BYTES_PER_PIXEL))  # past one tile: the cube and pipeline only
    assert memory.estimate_render_bytes(8256, 5504, channels=6) < memory.estimate_render_bytes(8256, 5504)


@pytest.mark.timeout(120)
def test_the_estimate_is_not_below_what_a_tiled_job_uses(tmp_path):
    """The peak resident memory of a whole render job on a 1.2 MP frame (two tiles with its
    margin), measured by the kernel for the child process, stays under the estimate."""
    import subprocess
    import sys

    from spectral_cam.render.memory import estimate_render_bytes

    scene = tmp_path / "scene.toml"
    scene.write_text("[sensor]\nwidth_px = 1200\nheight_px = 1000\ncrop_margin_px = 8\n[render]\nspp = 1\n")
    # VmHWM, the high-water mark of this process image: ru_maxrss would also count the forked copy
    # of the test process before exec (Linux keeps the larger across execve), ~1.9 GB late in the suite
    code = ("import sys; from spectral_cam.cli import main; code = main(sys.argv[1:]); "
            "print(next(l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM:'))); "
            "sys.exit(code)")
    done = subprocess.run([sys.executable, "-c", code, "render", str(scene), "-o", str(tmp_path / "out"), "-q"],
                          check=True, capture_output=True, text=True)
    peak = float(done.stdout.split()[-1]) * 1024.0  # VmHWM is in kB
    assert peak < estimate_render_bytes(1216, 1016), peak


def test_a_layered_45_mp_frame_is_refused_on_24_gb_with_the_thin_lens_as_the_remedy(monkeypatch):
    """The layered model holds several cubes at once (measured 1.83 GB at 1.2 MP): on a 24 GB
    machine a 45 MP layered frame is refused, naming the remedies and what they would need."""
    from spectral_cam.errors import ConfigError
    from spectral_cam.render import memory

    monkeypatch.setattr(memory, "available_bytes", lambda: 24e9)
    memory.check_render_memory(8256, 5504)  # the thin lens fits
    with pytest.raises(ConfigError) as refused:
        memory.check_render_memory(8256, 5504, layered=True)
    message = str(refused.value)
    assert 'lens.model = "thin"' in message and 'render.bands = "camera"' in message and "px fits" in message
