"""Fixtures of the dataset tests: one LocalCluster (2 spawned workers × 1 thread) and one
six-item dataset rendered on it, shared by the package's tests."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from spectral_cam.apps.dataset import generate_dataset, load_spec, local_cluster

SPEC = """
[dataset]
seed = 7
outputs = ["raw", "image", "radiance", "depth", "defocus", "all_in_focus", "clean_rgb"]

[scene]
preset = "dof_targets"
depths_m = [1.0, 2.0, 4.0]

[sensor]
width_px = 24
height_px = 16
model = { choice = ["nikon_d850", "sony_ilce_7m3"] }

[render]
spp = 4

[lens]
focal_length_mm = 25.0
f_number = { log_uniform = [1.4, 8.0] }
focus_distance_m = { uniform = [0.8, 4.0] }

[exposure]
iso = { choice = [100, 400], weights = [3, 1] }
"""

POINTS_SPEC = """
[scene]
preset = "point_sources"
depths_m = [0.5, 2.0]
source_radius_m = 0.0005
[sensor]
width_px = 48
height_px = 16
[render]
spp = 4
[lens]
focal_length_mm = 25.0
f_number = 8.0
"""


@pytest.fixture(scope="package")
def cluster(tmp_path_factory):
    """One LocalCluster for the package's tests."""
    base = tmp_path_factory.mktemp("dataset")
    with local_cluster(2) as client:
        yield SimpleNamespace(client=client, executor=client.get_executor(pure=False), base=base)


@pytest.fixture(scope="package")
def spec_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("spec") / "spec.toml"
    path.write_text(SPEC)
    return path


@pytest.fixture(scope="package")
def points_spec_file(tmp_path_factory):
    """Two point sources at 0.5 and 2 m (f/8, 25 mm): a spec whose sweeps measure blur."""
    path = tmp_path_factory.mktemp("points") / "points.toml"
    path.write_text(POINTS_SPEC)
    return path


@pytest.fixture(scope="package")
def first_run(cluster, spec_file):
    """Six items of :data:`SPEC` rendered on the cluster."""
    out = cluster.base / "six"
    summary = generate_dataset(load_spec(spec_file), out, n=6, executor=cluster.executor, progress=False)
    return SimpleNamespace(out=out, summary=summary, spec=load_spec(spec_file))
