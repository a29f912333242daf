"""Atomic output (issue 12 #14): replacing a result is one exchange rename where the platform
has one, and a kill between the two renames of the fallback loses nothing — the next run
puts the old result back. Reference: POSIX rename(2), Linux renameat2(RENAME_EXCHANGE)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from spectral_cam.errors import ConfigError
from spectral_cam.io import exchange_paths, staged_directory

pytestmark = pytest.mark.timeout(60)


def _result(folder, text):
    folder.mkdir()
    (folder / "meta.json").write_text(text)


def test_exchange_swaps_two_folders(tmp_path):
    _result(tmp_path / "a", "a")
    _result(tmp_path / "b", "b")
    assert exchange_paths(tmp_path / "a", tmp_path / "b")  # Linux ≥ 3.15 on a local file system
    assert (tmp_path / "a" / "meta.json").read_text() == "b"
    assert (tmp_path / "b" / "meta.json").read_text() == "a"


def test_force_replaces_a_result_and_leaves_nothing_behind(tmp_path):
    _result(tmp_path / "out", "old")
    with staged_directory(tmp_path / "out", force=True) as stage:
        (stage / "meta.json").write_text("new")
    assert (tmp_path / "out" / "meta.json").read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


KILL_BETWEEN_RENAMES = textwrap.dedent("""
    import os, sys
    from pathlib import Path
    import spectral_cam.io as io
    io.exchange_paths = lambda a, b: False          # a platform without an atomic exchange
    calls = []
    real = os.replace
    def replace(a, b):
        calls.append(a)
        real(a, b)
        if len(calls) == 1:
            os._exit(9)                              # killed between the two renames
    os.replace = replace
    with io.staged_directory(Path(sys.argv[1]), force=True) as stage:
        (stage / "meta.json").write_text("new")
""")


def test_a_kill_between_the_fallback_renames_loses_nothing(tmp_path):
    target = tmp_path / "out"
    _result(target, "old")
    done = subprocess.run([sys.executable, "-c", KILL_BETWEEN_RENAMES, str(target)])
    assert done.returncode == 9
    assert not target.exists()  # the window: the old result sits in a hidden .old folder
    with pytest.raises(ConfigError, match="exists"):
        with staged_directory(target) as stage:  # the next run restores it before anything else
            (stage / "meta.json").write_text("newer")
    assert (target / "meta.json").read_text() == "old"
    assert not list(tmp_path.glob(".out.old-*"))


def test_a_failed_exr_write_is_an_os_error_the_cli_reports(tmp_path, monkeypatch, capsys):
    """Issue 12 #11: a full disk during an EXR write escaped as a traceback. The disk fills
    after the first megabyte the EXR writer writes (/dev/full's error, ENOSPC)."""
    import builtins
    import errno

    from spectral_cam import exr
    from spectral_cam.cli import main

    class FillingDisk:
        def __init__(self, file):
            self.file, self.written = file, 0

        def write(self, data):
            self.written += len(data)
            if self.written > 1 << 20:
                raise OSError(errno.ENOSPC, "No space left on device")
            return self.file.write(data)

        def __getattr__(self, name):
            return getattr(self.file, name)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.file.close()

    monkeypatch.setattr(exr, "open", lambda *a, **k: FillingDisk(builtins.open(*a, **k)), raising=False)
    scene = tmp_path / "scene.toml"
    scene.write_text("[sensor]\nwidth_px = 240\nheight_px = 160\n[render]\nspp = 1\n")
    assert main(["render", str(scene), "-o", str(tmp_path / "out"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "could not write the OpenEXR file" in err and "No space left" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml"]


@pytest.mark.timeout(60)
def test_exr_compression_auto_zips_what_compresses_and_keeps_every_bit(tmp_path):
    """OpenEXR reads back both kinds bit for bit; the header says which codec auto chose:
    ZIP for a smooth field, none for float noise (which ZIP cannot shrink, but spends seconds on)."""
    import numpy as np
    import OpenEXR

    from spectral_cam.exr import write_exr_channels

    y, x = np.mgrid[0:64, 0:96].astype(np.float32)
    smooth = {"Z": (2.0 + 0.001 * x + 0.0 * y).astype(np.float32)}
    noise = {f"S0.{500 + 10 * i},000000nm": np.random.default_rng(i).uniform(0, 1, (64, 96)).astype(np.float32)
             for i in range(4)}
    for channels, codec in ((smooth, OpenEXR.ZIP_COMPRESSION), (noise, OpenEXR.NO_COMPRESSION)):
        path = write_exr_channels(channels, tmp_path / f"{len(channels)}.exr")
        with OpenEXR.File(str(path), separate_channels=True) as exr:
            assert exr.header()["compression"] == codec
            back = {name: channel.pixels for name, channel in exr.channels().items()}
        for name, values in channels.items():
            np.testing.assert_array_equal(back[name], values)


# Issue 39 #32 and #31: --force onto a file or a symbolic link leaves nothing hidden behind; a
# killed run's staging folder is removed by the next run; a dangling -o is named, not the stage.

@pytest.mark.parametrize("kind", ["file", "symlink", "dangling symlink"])
def test_force_onto_a_file_or_a_link_leaves_nothing_behind(tmp_path, kind):
    (tmp_path / "elsewhere").mkdir()
    target = tmp_path / "out"
    if kind == "file":
        target.write_text("a user's file")
    else:
        target.symlink_to(tmp_path / ("elsewhere" if kind == "symlink" else "missing"))
    with staged_directory(target, force=True) as stage:
        (stage / "meta.json").write_text("new")
    assert not target.is_symlink() and (target / "meta.json").read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["elsewhere", "out"]
    assert list((tmp_path / "elsewhere").iterdir()) == []  # a link is replaced, not followed


def test_a_dangling_link_is_named_as_what_is_in_the_way(tmp_path):
    (tmp_path / "out").symlink_to(tmp_path / "missing")
    with pytest.raises(ConfigError, match=r"out exists \(a symbolic link to .*missing, which does not exist\); "
                                          r"pass --force"):
        with staged_directory(tmp_path / "out"):
            pass
    with pytest.raises(ConfigError, match=r"cannot write .*out/sub: .*out \(a symbolic link .*\) is in the way"):
        with staged_directory(tmp_path / "out" / "sub"):
            pass
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


KILLED_MID_RUN = textwrap.dedent("""
    import os, sys
    from pathlib import Path
    import spectral_cam.io as io
    with io.staged_directory(Path(sys.argv[1])) as stage:
        (stage / "half.dng").write_bytes(b"II*")
        with io.atomic_path(Path(sys.argv[1]).parent / "file.json") as tmp:
            os._exit(9)                                  # kill -9 runs no cleanup
""")


def test_what_a_killed_run_left_is_removed_by_the_next(tmp_path):
    target = tmp_path / "out"
    subprocess.run([sys.executable, "-c", KILLED_MID_RUN, str(target)], check=False, timeout=50)
    left = sorted(p.name for p in tmp_path.iterdir())
    assert len(left) == 2 and all(".partial-" in name for name in left)
    with staged_directory(target) as stage:
        (stage / "meta.json").write_text("new")
    from spectral_cam.io import atomic_path

    with atomic_path(tmp_path / "file.json") as tmp:
        tmp.write_text("{}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.json", "out"]


def test_a_running_writers_stage_is_left_alone(tmp_path):
    from spectral_cam.io import _partial_prefix, remove_abandoned_partials

    alive = tmp_path / (_partial_prefix("out") + "x")  # this process: still running
    alive.mkdir()
    assert remove_abandoned_partials(tmp_path / "out") == [] and alive.exists()
