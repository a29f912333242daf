"""The sensor-kind registry (issue 41 #1): a kind registered from outside the package runs end to end
through the render job, and every bundled kind's entry declares its capture, files, size estimate and
reader.

The toy kind is a CMOS that also writes its mosaic as mosaic.npy; the check against it is LibRaw's own
reading of raw.dng (rawpy), not our writer."""

from __future__ import annotations

import json

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.errors import ConfigError
from spectral_cam.sensor.events import EventStream
from spectral_cam.sensor.kinds import SENSOR_KINDS, SensorCapture, SensorFile, SensorKind, capture


def _capture_mosaic(radiance, config, *, frame_seed=None, render_pose=None):
    from spectral_cam.sensor import expose

    # expose() is the integrating (CMOS) model: this kind is one, with one more file
    raw = expose(radiance, config.replace(**{"sensor.kind": "cmos"}), frame_seed=frame_seed)
    return SensorCapture(raw, {"mosaic": raw.mosaic})


def _write_mosaic(mosaic, folder):
    np.save(folder / "mosaic.npy", mosaic)
    return [folder / "mosaic.npy"]


def _mosaic_bytes(config):
    margin = 2 * config.sensor.crop_margin_px
    return 128.0 + (config.sensor.width_px + margin) * (config.sensor.height_px + margin) * 2.0


@pytest.fixture
def toy_kind():
    """'mosaic_npy', registered for the test and removed after it."""
    entry = SensorKind("mosaic_npy", _capture_mosaic, description="a CMOS that writes its mosaic as .npy too",
                       files=(SensorFile("mosaic", ("mosaic.npy",), _write_mosaic,
                                         lambda folder: np.load(folder / "mosaic.npy"), _mosaic_bytes),),
                       sequences=False, sequence_refusal="mosaic_npy takes no sequence (a test's toy)")
    SENSOR_KINDS.add_kind(entry)
    yield entry
    SENSOR_KINDS.remove("mosaic_npy")


@pytest.mark.timeout(300)
def test_a_sensor_kind_registered_from_a_test_module_runs_through_the_render_job(toy_kind, tmp_path):
    """The job writes the toy kind's file beside raw.dng; its mosaic is the DNG's as LibRaw reads it, the
    entry's reader reads it back, and the disk budget sized it from the entry."""
    rawpy = pytest.importorskip("rawpy")
    from spectral_cam.budget import estimate_result_bytes
    from spectral_cam.job import render_job_files, run_render_job

    config = sc.scene_from_dict({"sensor": {"kind": "mosaic_npy", "width_px": 32, "height_px": 24},
                                 "scene": {"preset": "colorchecker"}, "exposure": {"time_s": 0.01},
                                 "render": {"spp": 4, "bands": "camera", "spectral_output": False,
                                            "diffraction": "off"}})
    assert "mosaic" in render_job_files(config)
    meta = run_render_job(config, tmp_path / "out")
    folder = tmp_path / "out"
    assert "mosaic.npy" in meta["files"]
    mosaic = toy_kind.files[0].read(folder)
    with rawpy.imread(str(folder / "raw.dng")) as raw:
        np.testing.assert_array_equal(mosaic, raw.raw_image)
    assert mosaic.shape == (24 + 16, 32 + 16)
    assert estimate_result_bytes(config, ["mosaic"])["mosaic"] >= (folder / "mosaic.npy").stat().st_size


def test_a_kind_without_sequences_is_refused_with_its_message(toy_kind):
    config = sc.scene_from_dict({"sensor": {"kind": "mosaic_npy", "width_px": 8, "height_px": 8}})
    with pytest.raises(ConfigError, match="takes no sequence"):
        capture(None, config, frame_seed=0, sequence=True)


def test_an_unknown_kind_lists_the_registered_ones_with_their_descriptions(toy_kind):
    with pytest.raises(ConfigError, match=r"'mosaic_npy' \(a CMOS that writes its mosaic as .npy too\)"):
        sc.scene_from_dict({"sensor": {"kind": "nope"}})


@pytest.mark.parametrize("kind", ["cmos", "qis", "spad", "event"])
def test_every_bundled_kind_declares_capture_files_size_and_reader(kind):
    entry = SENSOR_KINDS[kind]
    config = sc.scene_from_dict({"sensor": {"kind": kind, "width_px": 64, "height_px": 48},
                                 "exposure": {"time_s": 0.01}})
    assert callable(entry.function) and entry.description
    assert entry.memory_bytes_per_pixel(config) >= 0.0
    for file in entry.files:
        assert callable(file.write) and callable(file.read) and file.files
        assert file.size_bytes(config) > 64 * 48 / 8  # at least a bit a pixel of one frame
    assert (kind == "cmos") == (not entry.files)
    assert entry.sequences == (kind != "event")
    for check in entry.keys:  # every key it owns is a SensorSection key whose default passes its check
        assert check.problem("sensor", config.sensor) is None


def test_the_event_entry_writes_and_reads_back_a_stream_in_dsec_layout(tmp_path):
    """x, y and polarity as written; t in whole microseconds (DSEC), from seconds; events.png the event
    frame as Pillow reads it."""
    stream = EventStream(np.array([1, 5], np.uint16), np.array([2, 3], np.uint16), np.array([1e-6, 2.5e-3]),
                         np.array([1, -1], np.int8), (4, 6), {"threshold": 0.2})
    entry = SENSOR_KINDS["event"].files[0]
    assert {p.name for p in entry.write(stream, tmp_path)} == {"events.npz", "events.png"}
    back = entry.read(tmp_path)
    np.testing.assert_array_equal(back["x"], [1, 5])
    np.testing.assert_array_equal(back["t"], [1, 2500])
    np.testing.assert_array_equal(back["p"], [1, 0])
    assert back["meta"]["shape"] == [4, 6]
    from PIL import Image

    np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "events.png").convert("RGB")), stream.frame_rgb())


def test_the_photon_counts_reader_unpacks_what_numpy_packed(tmp_path):
    counts = (np.random.default_rng(1).random((3, 4, 13)) < 0.3).astype(np.uint8)
    np.savez_compressed(tmp_path / "photon_counts.npz", bits=np.packbits(counts, axis=-1),
                        meta=np.array(json.dumps({"shape": [4, 13], "bits": 1})))
    back = SENSOR_KINDS["qis"].files[0].read(tmp_path)
    np.testing.assert_array_equal(back["counts"], counts)
