"""Issue 40 #1: examples/dataset_pytorch.py, from a spec to a few training steps. Its data half
(render, resize and crop keeping K, default-collated batches) is checked everywhere with
PyTorch's collate rules ported to NumPy; the training half runs where torch is installed."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from .collate_reference import default_collate

EXAMPLE = Path(__file__).resolve().parents[3] / "examples" / "dataset_pytorch.py"


def _example():
    spec = importlib.util.spec_from_file_location("dataset_pytorch", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.timeout(300)
def test_the_examples_items_batch_with_consistent_intrinsics(tmp_path):
    example = _example()
    folder = example.make_dataset(tmp_path / "dfd", 3)
    items = example.training_items(folder)
    batch = default_collate([items[i] for i in range(3)])
    assert batch["image"].shape == (3, 24, 24, 3) and batch["defocus"].shape == (3, 24, 24)
    for k, row in enumerate(items.rows):  # camera.json as written, at 48 × 64: f halves, c follows the window
        written = np.array(json.loads((folder / row["path"] / "camera.json").read_text())["K"])
        K = batch["camera"]["K"][k]
        assert K[0, 0] == pytest.approx(written[0, 0] / 2) and K[1, 1] == pytest.approx(written[1, 1] / 2)
        corner = (written[:2, 2] + 0.5) / 2 - 0.5 - K[:2, 2]  # the crop's (left, top) in the halved frame
        assert np.allclose(corner, np.round(corner)) and 0 <= corner[0] <= 8 and corner[1] == 0
    # torch is an optional extra: the package never imports it (where it is installed, too)
    probe = "import sys, spectral_cam.apps.dataset as d; d.SyntheticDataset; print('torch' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True).stdout.strip() == "False"


@pytest.mark.timeout(600)
def test_the_example_trains_where_torch_is_installed(tmp_path):
    pytest.importorskip("torch")
    done = subprocess.run([sys.executable, str(EXAMPLE), "-o", str(tmp_path / "dfd"), "--items", "8",
                           "--steps", "12"], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "CoC L1 loss" in done.stdout
