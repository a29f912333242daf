"""Issue 40 #5: train/val/test splits by fraction and seed, assigned per item index (binomial
shares, stable when the dataset grows), in metadata.jsonl and as Hugging Face splits; WebDataset
tar shards holding each item's files byte for byte, read back by Python's tarfile and by the
``webdataset`` package."""

from __future__ import annotations

import json
import tarfile

import numpy as np
import pytest

from spectral_cam.apps.dataset import generate_dataset, spec_from_dict
from spectral_cam.errors import ConfigError

from .reading import read_manifest

pytestmark = pytest.mark.timeout(300)

BASE = {"scene": {"preset": "dof_targets", "depths_m": [1.0, 2.0, 4.0]}, "sensor": {"width_px": 24, "height_px": 16},
        "render": {"spp": 2}, "lens": {"focal_length_mm": 25.0, "f_number": {"log_uniform": [2.0, 8.0]}}}
FRACTIONS = {"train": 0.8, "val": 0.1, "test": 0.1}


def _spec(**dataset):
    return spec_from_dict({"dataset": {"seed": 5, "outputs": ["image", "depth", "camera"], **dataset}, **BASE})


def test_split_shares_of_1000_indices_are_binomial_about_the_fractions():
    from scipy.stats import binomtest

    spec = _spec(splits=FRACTIONS, split_seed=11)
    drawn = [spec.split_of(index) for index in range(1000)]
    for name, fraction in FRACTIONS.items():
        count = drawn.count(name)
        assert binomtest(count, 1000, fraction).pvalue > 1e-3, (name, count)
    other = _spec(splits=FRACTIONS, split_seed=12)
    assert drawn != [other.split_of(index) for index in range(1000)]  # the seed decides the draw
    assert _spec().split_of(3) == "train"  # no splits: every item in train, Hugging Face's default


def test_splits_do_not_change_the_items_and_are_checked():
    assert _spec(splits=FRACTIONS, split_seed=3, webdataset=True, shard_items=2).hash == _spec().hash
    for bad, match in (({"train": 0.8, "val": 0.1}, "sum to 0.9"), ({"train": 1.2, "val": -0.2}, r"in \[0, 1\]"),
                       ({"train/a": 1.0}, "split name"), ([0.8, 0.2], "table of split name")):
        with pytest.raises(ConfigError, match=match):
            _spec(splits=bad)
    with pytest.raises(ConfigError, match="split_seed"):
        _spec(split_seed=-1)
    with pytest.raises(ConfigError, match="shard_items"):
        _spec(shard_items=0)
    with pytest.raises(ConfigError, match="webdataset"):
        _spec(webdataset="yes")


def _fake_item(task):
    """A stand-in for render_item: the splits need no pixels."""
    return {"index": task["index"], "id": task["id"], "seed": task["seed"], "params": task["params"],
            "status": "failed", "files": [], "error": "not rendered (test)"}


def test_an_item_keeps_its_split_when_the_dataset_grows(tmp_path):
    spec = _spec(splits=FRACTIONS)
    generate_dataset(spec, tmp_path / "a", n=20, scheduler="inline", progress=False, item_function=_fake_item)
    generate_dataset(spec, tmp_path / "a", n=60, scheduler="inline", progress=False, item_function=_fake_item)
    generate_dataset(spec, tmp_path / "b", n=60, scheduler="inline", progress=False, item_function=_fake_item)
    grown, fresh = read_manifest(tmp_path / "a"), read_manifest(tmp_path / "b")
    assert [r["split"] for r in grown] == [r["split"] for r in fresh]
    assert {r["split"] for r in grown} == set(FRACTIONS)


def _two_split_seed(spec_args, count):
    """A split seed putting the first ``count`` items in both splits (so each split has items)."""
    for seed in range(100):
        spec = _spec(**spec_args, split_seed=seed)
        drawn = {spec.split_of(index) for index in range(count)}
        if len(drawn) == 2:
            return seed
    raise AssertionError("no seed splits the items")


@pytest.fixture(scope="module")
def sharded(tmp_path_factory):
    args = {"splits": {"train": 0.5, "test": 0.5}, "webdataset": True, "shard_items": 1}
    spec = _spec(**args, split_seed=_two_split_seed(args, 3))
    out = tmp_path_factory.mktemp("splits") / "data"
    generate_dataset(spec, out, n=3, scheduler="inline", progress=False)
    return out, spec


def test_metadata_and_the_hugging_face_splits_follow_the_spec(sharded, tmp_path):
    import datasets

    out, spec = sharded
    rows = [json.loads(line) for line in (out / "metadata.jsonl").read_text().splitlines()]
    assert [r["split"] for r in rows] == [spec.split_of(r["index"]) for r in rows]
    loaded = datasets.load_dataset(str(out), cache_dir=str(tmp_path / "cache"))
    assert set(loaded) == {r["split"] for r in rows}
    for name, split in loaded.items():
        assert sorted(split["id"]) == sorted(r["id"] for r in rows if r["split"] == name)
    card = (out / "README.md").read_text()
    assert "## Splits" in card and "| `train` | 0.5 |" in card


def test_webdataset_tars_hold_every_item_file_byte_for_byte(sharded):
    out, spec = sharded
    manifest = [r for r in read_manifest(out) if r["status"] == "done"]
    tars = sorted((out / "webdataset").glob("split=*/*.tar"))
    assert len(tars) == len(manifest)  # shard_items = 1
    seen = {}
    for path in tars:
        with tarfile.open(path) as tar:  # Python's own reader
            for member in tar.getmembers():
                assert member.isfile()
                key, _, name = member.name.partition(".")
                seen[(key, name)] = tar.extractfile(member).read()
                assert path.parent.name == f"split={spec.split_of(int(key))}"
    expected = {(r["id"], f.split("/")[-1]): (out / f).read_bytes() for r in manifest for f in r["files"]}
    assert set(seen) == set(expected) and all(seen[k] == expected[k] for k in expected)


def test_the_webdataset_package_streams_the_samples(sharded):
    import webdataset as wds  # in the test extras
    out, _ = sharded
    samples = []
    for path in sorted((out / "webdataset").glob("split=*/*.tar")):
        samples += list(wds.WebDataset(str(path), shardshuffle=False))
    manifest = {r["id"]: r for r in read_manifest(out) if r["status"] == "done"}
    assert sorted(s["__key__"] for s in samples) == sorted(manifest)
    for sample in samples:
        folder = out / "items" / sample["__key__"]
        assert sample["image.png"] == (folder / "image.png").read_bytes()
        assert json.loads(sample["camera.json"]) == json.loads((folder / "camera.json").read_text())
        assert np.frombuffer(sample["depth.exr"], np.uint8).size == (folder / "depth.exr").stat().st_size
