"""From a dataset spec to a few PyTorch training steps, on the CPU.

Renders a small depth-from-defocus dataset (the depth targets at random f-numbers and focus
distances), serves it through :class:`~spectral_cam.apps.dataset.SyntheticDataset` with a
resize and a random crop that keep the intrinsics consistent, batches it with PyTorch's
default collate (no ``collate_fn``), and trains a three-layer convolutional network to predict
the signed circle of confusion (px) from the developed image for a few steps. The loss printed
first and last is the mean absolute CoC error in pixels; a few steps on 12 tiny items only show
that the loop runs and the loss moves, not a useful model.

Without PyTorch the data half still runs and says so: the dataset is rendered, served with the
same transforms and stacked into batches as the default collate would (NumPy), the batch shapes
and a constant predictor's CoC error (what training has to beat) are printed, and no step is
trained.

    pip install torch --index-url https://download.pytorch.org/whl/cpu
    python examples/dataset_pytorch.py [-o DIR] [--items 12] [--steps 20]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

SPEC = {
    "dataset": {"seed": 1, "outputs": ["image", "depth", "defocus", "camera"]},
    "scene": {"preset": "dof_targets", "depths_m": [0.8, 1.6, 3.2]},
    "sensor": {"width_px": 64, "height_px": 48},
    "render": {"spp": 4},
    "lens": {"focal_length_mm": 25.0, "f_number": {"log_uniform": [1.4, 5.6]},
             "focus_distance_m": {"uniform": [0.8, 3.2]}},
}


def make_dataset(folder: Path, items: int) -> Path:
    """Render (or resume) the dataset in one process."""
    from spectral_cam.apps.dataset import generate_dataset, spec_from_dict

    summary = generate_dataset(spec_from_dict(SPEC), folder, n=items, scheduler="inline", progress=False)
    print(f"dataset {folder}: {summary.rendered} rendered, {summary.resumed} resumed, {summary.failed} failed")
    return folder


def training_items(folder: Path):
    """The items as the model sees them: halved to 24 × 32 px (K and the CoC in pixels follow),
    then a random 24 × 24 window (K's principal point follows)."""
    from spectral_cam.apps.dataset import Crop, Resize, SyntheticDataset

    return SyntheticDataset(folder, labels=("image", "defocus", "camera"),
                            transform=[Resize(24, 32), Crop(24, 24, position="random", seed=0)])


def stacked_batches(items, batch_size: int = 4):
    """Batches as PyTorch's default collate makes them, in NumPy: each array key stacked along a
    new first axis, dicts (the camera) batched key by key, strings gathered into lists."""
    import numpy as np

    def collate(values):
        first = values[0]
        if isinstance(first, dict):
            return {key: collate([v[key] for v in values]) for key in first}
        if isinstance(first, str):
            return list(values)
        return np.stack([np.asarray(v) for v in values])

    for start in range(0, len(items) - batch_size + 1, batch_size):
        yield collate([items[i] for i in range(start, start + batch_size)])


def data_only(folder: Path) -> float:
    """The data half without PyTorch: batch shapes and the L1 error (px) of predicting every
    pixel's CoC as the training set's median, the loss a model has to beat."""
    import numpy as np

    items = training_items(folder)
    batch = next(stacked_batches(items, min(4, len(items))))
    print(f"batch: image {batch['image'].shape}, defocus {batch['defocus'].shape}, K {batch['camera']['K'].shape}")
    coc = np.concatenate([items[i]["defocus"].ravel() for i in range(len(items))])
    baseline = float(np.mean(np.abs(coc - np.median(coc))))
    print(f"constant-CoC baseline: L1 {baseline:.3f} px (a model has to beat this)")
    return baseline


def train(folder: Path, steps: int) -> tuple[float, float]:
    """A few Adam steps of a small CNN from image to CoC; returns the mean loss (px) of the first
    and of the last epoch (every item once: one batch's loss depends on which items it drew)."""
    import torch
    from torch.utils.data import DataLoader

    torch.manual_seed(0)
    loader = DataLoader(training_items(folder), batch_size=4, shuffle=True)  # the default collate
    model = torch.nn.Sequential(torch.nn.Conv2d(3, 16, 3, padding=1), torch.nn.ReLU(),
                                torch.nn.Conv2d(16, 16, 3, padding=1), torch.nn.ReLU(),
                                torch.nn.Conv2d(16, 1, 3, padding=1))
    optimiser = torch.optim.Adam(model.parameters(), lr=3e-3)
    losses = []
    while len(losses) < steps:
        for batch in loader:
            image = batch["image"].permute(0, 3, 1, 2).float() / 255.0  # (B, 3, 24, 24)
            target = batch["defocus"].unsqueeze(1)                        # (B, 1, 24, 24) px
            loss = torch.nn.functional.l1_loss(model(image), target)
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            losses.append(loss.item())
            if len(losses) == 1:
                print(f"batch: image {tuple(batch['image'].shape)}, defocus {tuple(batch['defocus'].shape)}, "
                      f"K {tuple(batch['camera']['K'].shape)}")
            if len(losses) == steps:
                break
    epoch = len(loader)
    first, last = sum(losses[:epoch]) / epoch, sum(losses[-epoch:]) / epoch
    print(f"CoC L1 loss: first epoch {first:.3f} px, last epoch {last:.3f} px over {steps} steps")
    return first, last


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", help="dataset folder (default: a temporary one)")
    parser.add_argument("--items", type=int, default=12)
    parser.add_argument("--steps", type=int, default=20)
    args = parser.parse_args(argv)
    try:
        import torch  # noqa: F401
    except ImportError:
        torch = None
    with tempfile.TemporaryDirectory() as scratch:
        folder = make_dataset(Path(args.output or Path(scratch) / "dfd"), args.items)
        data_only(folder)
        if torch is None:
            print("PyTorch is not installed: the data half ran, no step was trained "
                  "(pip install torch --index-url https://download.pytorch.org/whl/cpu)")
            return 0
        first, last = train(folder, args.steps)
    return 0 if last < first else 1


if __name__ == "__main__":
    sys.exit(main())
