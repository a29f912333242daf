"""From a dataset spec to a few PyTorch training steps, on the CPU.

Renders a small depth-from-defocus dataset (the depth targets at random f-numbers and focus
distances), serves it through :class:`~spectral_cam.apps.dataset.SyntheticDataset` with a
resize and a random crop that keep the intrinsics consistent, batches it with PyTorch's
default collate (no ``collate_fn``), and trains a three-layer convolutional network to predict
the signed circle of confusion (px) from the developed image for a few steps. The loss printed
first and last is the mean absolute CoC error in pixels; a few steps on 12 tiny items only show
that the loop runs and the loss moves, not a useful model.

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


def train(folder: Path, steps: int) -> tuple[float, float]:
    """A few Adam steps of a small CNN from image to CoC; returns the first and last batch loss (px)."""
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
            losses.append(float(loss))
            if len(losses) == 1:
                print(f"batch: image {tuple(batch['image'].shape)}, defocus {tuple(batch['defocus'].shape)}, "
                      f"K {tuple(batch['camera']['K'].shape)}")
            if len(losses) == steps:
                break
    print(f"CoC L1 loss: first step {losses[0]:.3f} px, last step {losses[-1]:.3f} px over {steps} steps")
    return losses[0], losses[-1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", help="dataset folder (default: a temporary one)")
    parser.add_argument("--items", type=int, default=12)
    parser.add_argument("--steps", type=int, default=20)
    args = parser.parse_args(argv)
    try:
        import torch  # noqa: F401
    except ImportError:
        print("this example needs PyTorch: pip install torch --index-url https://download.pytorch.org/whl/cpu",
              file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as scratch:
        folder = make_dataset(Path(args.output or Path(scratch) / "dfd"), args.items)
        first, last = train(folder, args.steps)
    return 0 if last < first else 1


if __name__ == "__main__":
    sys.exit(main())
