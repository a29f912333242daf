"""Render twelve items of the world's dataset plan (tabletop and vegetation, with the preset,
sun time, cloud cover, layout, materials, focal length and aperture drawn per item) through the
whole chain on the local Dask cluster and draw their contact sheet as docs/natural_presets.png.

    .venv/bin/python docs/make_natural_figure.py
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from spectral_cam.apps.dataset import generate_dataset, load_spec, write_contact_sheet

HERE = Path(__file__).parent


def main() -> None:
    spec = load_spec(HERE.parent / "plans" / "natural_presets.toml")
    with tempfile.TemporaryDirectory() as folder:
        summary = generate_dataset(spec, Path(folder) / "natural", n=12, progress=False)
        if summary.failed:
            raise SystemExit(f"{summary.failed} items failed")
        path = write_contact_sheet(Path(folder) / "natural", HERE / "natural_presets.png", columns=4,
                                   keys=["scene.preset", "sky.hour", "sky.cloud_cover", "lens.f_number"])
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
