"""The variant probe cache (issue 14 #3): a cached answer spares the child process, and only
an answer stored for exactly this environment is trusted. No GPU needed: the probes' child
processes are counted (and answered) by a stand-in for ``subprocess.run``."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import pytest

from spectral_cam.render import variants

pytestmark = pytest.mark.timeout(120)


class FakeProbe:
    """Stands in for ``subprocess.run``: counts the probes and answers with ``returncode``
    (or raises ``raises``)."""

    def __init__(self, returncode: int = 0, raises: BaseException | None = None):
        self.returncode, self.raises, self.calls, self.envs = returncode, raises, [], []

    def __call__(self, args, **kwargs):
        self.calls.append(args)
        self.envs.append(kwargs.get("env"))
        if self.raises is not None:
            raise self.raises
        return subprocess.CompletedProcess(args, self.returncode, b"", b"")


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    """An empty cache folder for this test; the in-process memo cleared before and after
    (so no stand-in answer outlives the test)."""
    folder = tmp_path / "cache"
    monkeypatch.setenv(variants.CACHE_DIR_ENV, str(folder))
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    variants._probe.cache_clear()
    yield folder
    variants._probe.cache_clear()


def _fresh_probe(backend: str = "llvm") -> variants.Probe:
    """As a new process would see it: the in-process memo cleared."""
    variants._probe.cache_clear()
    return variants._probe(backend)


def test_a_cache_hit_runs_no_child_process(cache_dir, monkeypatch):
    fake = FakeProbe(returncode=0)
    monkeypatch.setattr(subprocess, "run", fake)
    first = _fresh_probe("llvm")
    assert (first.usable, first.source, len(fake.calls)) == (True, "probe", 1)
    assert variants.probe_cache_path() == cache_dir / "variant_probe.json"
    for _ in range(3):
        again = _fresh_probe("llvm")
        assert (again.usable, again.source) == (True, "cache")
    assert len(fake.calls) == 1
    # the CUDA probe has its own entry: its first call probes, its second does not
    fake.returncode = 3
    assert _fresh_probe("cuda") == variants.Probe(False, "probe", "exit 3 (no usable backend)")
    assert _fresh_probe("cuda").source == "cache" and len(fake.calls) == 2
    assert _fresh_probe("llvm").usable is True and len(fake.calls) == 2
    # written atomically: no temporary file is left beside it
    assert sorted(p.name for p in cache_dir.iterdir()) == ["variant_probe.json"]


def test_a_changed_key_probes_again_and_never_trusts_the_old_yes(cache_dir, monkeypatch, tmp_path):
    fake = FakeProbe(returncode=0)
    monkeypatch.setattr(subprocess, "run", fake)
    assert _fresh_probe().usable is True
    # another libLLVM (drjit's DRJIT_LIBLLVM_PATH): the stored "yes" is not for it
    library = tmp_path / "libLLVM-15.so.1"
    library.write_bytes(b"old")
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", str(library))
    fake.returncode = -int(signal.SIGABRT)  # drjit aborts with libLLVM < 16
    probe = _fresh_probe()
    assert (probe.usable, probe.source, len(fake.calls)) == (False, "probe", 2)
    assert _fresh_probe().source == "cache" and len(fake.calls) == 2  # the crash is a definite "no"
    # the same path with other contents (an upgrade in place) is another key too
    library.write_bytes(b"newer, longer")
    fake.returncode = 0
    assert _fresh_probe().usable is True and len(fake.calls) == 3
    # and back to the first environment: its own entry is still there
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH")
    assert _fresh_probe() == variants.Probe(True, "cache", "exit 0") and len(fake.calls) == 3


def test_the_key_holds_what_the_answer_depends_on(cache_dir, monkeypatch):
    key = variants.probe_key("llvm")
    assert key["python"][:2] == [sys.prefix, os.path.realpath(sys.executable)]
    assert key["mitsuba"] and key["drjit"]  # from package metadata
    monkeypatch.setattr(variants, "_version", lambda name: "0.0.0" if name == "drjit" else "9.9.9")
    assert variants.probe_key("llvm") != key  # another drjit or Mitsuba
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "")
    assert "cuda_visible_devices" in variants.probe_key("cuda")
    with pytest.raises(ValueError, match="valid: llvm, cuda"):
        variants.probe_key("metal")


def test_a_library_path_set_after_start_up_is_not_the_loaders(cache_dir, monkeypatch):
    """OpenCV's cv2 adds its folder to os.environ["LD_LIBRARY_PATH"] when imported; this
    process's loader still searches the path it started with, so neither the key nor the
    probe's child may follow the change (a render that imported cv2 first probed again)."""
    initial = variants._loader_library_path()
    key = variants.probe_key("llvm")
    monkeypatch.setenv("LD_LIBRARY_PATH", "/opt/cv2/lib64:")
    assert variants._loader_library_path() == initial and variants.probe_key("llvm") == key
    fake = FakeProbe(returncode=0)
    monkeypatch.setattr(subprocess, "run", fake)
    _fresh_probe()
    assert fake.envs[0].get("LD_LIBRARY_PATH") == initial


def test_reading_the_key_imports_neither_drjit_nor_mitsuba():
    code = ("import sys; from spectral_cam.render.variants import probe_key, probe_cache_path; "
            "probe_key('llvm'); probe_key('cuda'); probe_cache_path(); "
            "print([m for m in ('drjit', 'mitsuba') if m in sys.modules])")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False)
    assert done.stdout.strip() == "[]", done.stderr


@pytest.mark.parametrize("content", [
    b"{ not json", b"\xff\xfe\x00", b"[]", b'{"schema": 1, "entries": []}', b'{"schema": 99, "entries": {}}', b"",
])
def test_a_corrupt_cache_file_probes_again_and_is_replaced(cache_dir, monkeypatch, content):
    cache_dir.mkdir()
    (cache_dir / "variant_probe.json").write_bytes(content)
    fake = FakeProbe(returncode=0)
    monkeypatch.setattr(subprocess, "run", fake)
    assert _fresh_probe() == variants.Probe(True, "probe", "exit 0")
    assert json.loads((cache_dir / "variant_probe.json").read_text())["schema"] == 1
    assert _fresh_probe().source == "cache" and len(fake.calls) == 1


def test_an_entry_that_does_not_match_its_key_is_not_trusted(cache_dir, monkeypatch):
    fake = FakeProbe(returncode=3)
    monkeypatch.setattr(subprocess, "run", fake)
    assert _fresh_probe().usable is False
    path = cache_dir / "variant_probe.json"
    data = json.loads(path.read_text())
    (entry,) = data["entries"].values()
    entry["usable"], entry["key"]["drjit"] = True, "0.0.1"  # edited by hand: the digest no longer fits
    path.write_text(json.dumps(data))
    assert _fresh_probe().usable is False and len(fake.calls) == 2
    entry = next(iter(json.loads(path.read_text())["entries"].values()))
    entry["usable"] = "yes"  # not a bool
    path.write_text(json.dumps({"schema": 1, "entries": {variants._digest(entry["key"]): entry}}))
    assert _fresh_probe().usable is False and len(fake.calls) == 3


@pytest.mark.parametrize("failure", [
    subprocess.TimeoutExpired("python", 120), OSError("no such interpreter"), 1, -int(signal.SIGKILL),
    -int(signal.SIGINT),
])
def test_a_failed_probe_is_not_cached(cache_dir, monkeypatch, failure):
    fake = FakeProbe(returncode=failure) if isinstance(failure, int) else FakeProbe(raises=failure)
    monkeypatch.setattr(subprocess, "run", fake)
    probe = _fresh_probe()
    assert (probe.usable, probe.source) == (False, "probe (not cached)")
    assert not (cache_dir / "variant_probe.json").exists()
    fake.returncode, fake.raises = 0, None  # it works the next time: probed again, not a stored "no"
    assert _fresh_probe() == variants.Probe(True, "probe", "exit 0") and len(fake.calls) == 2


def _file_in_the_way(cache_dir, monkeypatch):
    cache_dir.parent.mkdir(exist_ok=True)
    blocker = cache_dir.parent / "a file"
    blocker.write_text("")
    monkeypatch.setenv(variants.CACHE_DIR_ENV, str(blocker / "cache"))


def _read_only_folder(cache_dir, monkeypatch):
    """A folder the user may not write (0o555); for root, which writes anyway, the same refusal
    as the kernel would give anyone else, raised where the cache file is created."""
    cache_dir.mkdir()
    cache_dir.chmod(0o555)
    if os.access(cache_dir, os.W_OK):
        import tempfile

        real_mkstemp = tempfile.mkstemp

        def refuse_in_cache(*args, **kwargs):
            if str(kwargs.get("dir", "")).startswith(str(cache_dir)):
                raise PermissionError(13, "Permission denied", str(cache_dir))
            return real_mkstemp(*args, **kwargs)

        monkeypatch.setattr(tempfile, "mkstemp", refuse_in_cache)


def _read_only_file_system(cache_dir, monkeypatch):
    def refuse(*args, **kwargs):
        raise OSError(30, "Read-only file system")

    monkeypatch.setattr(os, "replace", refuse)


@pytest.mark.parametrize("make_unwritable", [_file_in_the_way, _read_only_folder, _read_only_file_system])
def test_an_unwritable_cache_only_costs_the_probe(cache_dir, monkeypatch, make_unwritable):
    make_unwritable(cache_dir, monkeypatch)
    fake = FakeProbe(returncode=0)
    monkeypatch.setattr(subprocess, "run", fake)
    try:
        assert _fresh_probe() == variants.Probe(True, "probe", "exit 0")
        assert _fresh_probe() == variants.Probe(True, "probe", "exit 0") and len(fake.calls) == 2
        assert not cache_dir.exists() or not any(cache_dir.iterdir())  # no temporary file left either
    finally:
        if cache_dir.exists():
            cache_dir.chmod(0o755)


def test_the_cache_folder_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.delenv(variants.CACHE_DIR_ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert variants.probe_cache_path() == tmp_path / "xdg" / "spectral_cam" / "variant_probe.json"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/ignored")  # the XDG specification: absolute only
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert variants.probe_cache_path() == tmp_path / "home" / ".cache" / "spectral_cam" / "variant_probe.json"
    monkeypatch.setenv(variants.CACHE_DIR_ENV, str(tmp_path / "mine"))
    assert variants.probe_cache_path() == tmp_path / "mine" / "variant_probe.json"


def test_the_record_says_whether_the_variant_came_from_the_cache(cache_dir, monkeypatch):
    pytest.importorskip("mitsuba")
    monkeypatch.delenv("SPECTRAL_CAM_VARIANT", raising=False)
    fake = FakeProbe(returncode=3)  # neither CUDA nor LLVM here
    monkeypatch.setattr(subprocess, "run", fake)
    variants._probe.cache_clear()
    variant, record = variants.choose_variant_record("auto")
    assert variant == "scalar_spectral" == record["choice"] and record["from_cache"] is False
    assert all(p["source"] == "probe" for p in record["probes"].values())
    variants._probe.cache_clear()
    variant, record = variants.choose_variant_record("auto")
    assert variant == "scalar_spectral" and record["from_cache"] is True
    assert variants.choose_variant("auto") == "scalar_spectral"  # the public function: a name
    calls = len(fake.calls)
    variant, record = variants.choose_variant_record("scalar_spectral")  # no probe needed
    assert (variant, record["probes"], record["from_cache"], len(fake.calls)) == ("scalar_spectral", {}, True, calls)
    with pytest.raises(variants.RenderError, match="libLLVM >= 16"):
        variants.choose_variant_record("llvm_ad_spectral")


def test_real_probe_then_cache_in_fresh_processes(tmp_path):
    """End to end, no stand-in: the second process reads the first one's answer."""
    pytest.importorskip("mitsuba")
    code = ("import json; from spectral_cam.render.variants import choose_variant_record; "
            "print(json.dumps(choose_variant_record('auto')))")
    env = {**os.environ, variants.CACHE_DIR_ENV: str(tmp_path)}
    env.pop("SPECTRAL_CAM_VARIANT", None)
    runs = [json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                                      timeout=100, check=True).stdout) for _ in range(2)]
    (first_variant, first), (second_variant, second) = runs
    assert first_variant == second_variant
    assert not first["from_cache"] and second["from_cache"]
    assert {k: v["usable"] for k, v in first["probes"].items()} == {k: v["usable"] for k, v in second["probes"].items()}
