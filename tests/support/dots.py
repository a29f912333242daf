"""A user's XML scene of small emitting spheres seen from an oblique pose, and their image
centroids (radiance-weighted, found with ``scipy.ndimage.label``): the independent reference that
camera.json's K, distortion and pose are checked against with ``cv2.projectPoints``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import ndimage

#: World positions (m) of the sphere centres.
POINTS = np.array([[0.0, 0.0, 0.0], [0.35, 0.2, 0.3], [-0.4, -0.25, 0.1], [0.3, -0.3, -0.4], [-0.3, 0.3, -0.2]])
RADIUS = 0.008


def dots_xml(path: Path, *, fov_deg: float | None = 40.0) -> Path:
    """Write the scene to ``path``; ``fov_deg`` None leaves Mitsuba's field of view to the lens."""
    spheres = "".join(f'''
    <shape type="sphere" id="dot{i}">
        <point name="center" x="{x}" y="{y}" z="{z}"/><float name="radius" value="{RADIUS}"/>
        <emitter type="area"><rgb name="radiance" value="20"/></emitter>
    </shape>''' for i, (x, y, z) in enumerate(POINTS))
    fov = "" if fov_deg is None else f'''
        <float name="fov" value="{fov_deg:g}"/>'''
    path.write_text(f'''<scene version="3.0.0">
    <sensor type="perspective">{fov}
        <transform name="to_world"><lookat origin="1.2, 0.7, -2.6" target="0, 0, 0" up="0, 1, 0"/></transform>
    </sensor>{spheres}
</scene>''')
    return path


def centroids(radiance: np.ndarray) -> np.ndarray:
    """(column, row) of each bright blob, pixel centres at integers as OpenCV counts them."""
    light = radiance.sum(axis=-1)
    labels, count = ndimage.label(light > 0.05 * light.max())
    return np.array([c[::-1] for c in ndimage.center_of_mass(light, labels, range(1, count + 1))])
