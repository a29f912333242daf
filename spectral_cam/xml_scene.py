"""What a user's Mitsuba XML scene says about its camera, read without Mitsuba.

A scene file brings its own camera: a pose (kept by the render, ``render/scene_dict.py``) and a
field of view. :func:`xml_field_of_view` reads the horizontal field of view of the file's first
``perspective``/``thinlens`` sensor (``fov`` on any ``fov_axis``, or a 35 mm-equivalent
``focal_length``, with ``<default>`` parameters and ``$name`` references substituted), so the
scene file can derive ``lens.focal_length_mm`` from it (:func:`focal_length_for_fov`).

References
----------
.. [1] Mitsuba 3 documentation, "Perspective pinhole camera (perspective)" and "Perspective
   camera with a thin lens (thinlens)": ``fov``, ``fov_axis`` (x, y, diagonal, smaller, larger;
   default x), ``focal_length`` (35 mm film equivalent, default 50mm), and the film's
   ``width``/``height`` (default 768 × 576); "Scene file format" (``<default>``, ``$name``).
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

__all__ = ["XmlFieldOfView", "xml_field_of_view", "focal_length_for_fov"]

_FILM_DEFAULT = (768, 576)  # Mitsuba's film size when the XML gives none
_FILM_35MM_MM = (36.0, 24.0)  # the frame Mitsuba's focal_length refers to
_FOCAL_DEFAULT = "50mm"


@dataclass(frozen=True)
class XmlFieldOfView:
    """The XML camera's horizontal field of view (degrees) and how it was read."""

    fov_x_deg: float
    source: str


def _defaults(root: ET.Element) -> dict[str, str]:
    return {node.get("name", ""): node.get("value", "") for node in root.iter("default")}


def _value(node: ET.Element | None, defaults: dict[str, str]) -> str | None:
    if node is None:
        return None
    value = node.get("value")
    return None if value is None else _substitute(value, defaults)


def _child(sensor: ET.Element, tag: str, name: str) -> ET.Element | None:
    return next((n for n in sensor if n.tag == tag and n.get("name") == name), None)


def _film_size(sensor: ET.Element, defaults: dict[str, str]) -> tuple[float, float]:
    film = next((n for n in sensor if n.tag == "film"), None)
    if film is None:
        return _FILM_DEFAULT
    sizes = []
    for key, default in zip(("width", "height"), _FILM_DEFAULT):
        text = _value(_child(film, "integer", key), defaults)
        sizes.append(float(text) if text else default)
    return sizes[0], sizes[1]


def _half_tan_x(half_tan: float, axis: str, width: float, height: float) -> float:
    """tan(fov_x/2) from tan(fov/2) on ``axis`` of a ``width`` × ``height`` film."""
    if axis == "smaller":
        axis = "y" if width > height else "x"
    elif axis == "larger":
        axis = "x" if width > height else "y"
    if axis == "x":
        return half_tan
    if axis == "y":
        return half_tan * width / height
    if axis == "diagonal":
        return half_tan * width / math.hypot(width, height)
    raise ValueError(f"fov_axis {axis!r}")


def xml_field_of_view(path: str | Path) -> XmlFieldOfView | None:
    """The horizontal field of view of the first perspective or thin-lens sensor in a Mitsuba
    XML scene, or None when the file has none (or one whose field of view cannot be read
    without Mitsuba, e.g. from an ``<include>``).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "scene.xml"
    >>> _ = path.write_text('<scene version="3.0.0"><default name="fov" value="45"/>'
    ...                     '<sensor type="perspective"><float name="fov" value="$fov"/></sensor></scene>')
    >>> xml_field_of_view(path).fov_x_deg
    45.0
    """
    found = _first_camera(Path(path), {}, 0)
    if found is None:
        return None
    sensor, defaults, where = found
    if sensor.get("type") not in ("perspective", "thinlens"):  # issue 25 #4: it fell back silently
        import warnings

        from .errors import SceneWarning

        warnings.warn(f"{where}: the camera is {sensor.get('type')!r}, which has no field of view; spectral_cam "
                      "renders through its own perspective lens from the camera's pose (lens.focal_length_mm, "
                      "default 8 mm): set lens.focal_length_mm for the view you want", SceneWarning, stacklevel=3)
        return None
    width, height = _film_size(sensor, defaults)
    axis = (_value(_child(sensor, "string", "fov_axis"), defaults) or "x").lower()
    fov = _value(_child(sensor, "float", "fov"), defaults)
    try:
        if fov is not None:
            half_tan, source = math.tan(math.radians(float(fov)) / 2), f"fov = {float(fov):g}° on axis {axis}"
        else:
            focal = _value(_child(sensor, "string", "focal_length"), defaults) or _FOCAL_DEFAULT
            millimetres = float(focal.lower().removesuffix("mm"))
            # Mitsuba: a 35 mm-equivalent focal length sets the diagonal field of view
            half_tan = math.hypot(*_FILM_35MM_MM) / (2 * millimetres)
            axis, source = "diagonal", f"focal_length = {focal} (35 mm equivalent, diagonal)"
        fov_x = 2 * math.degrees(math.atan(_half_tan_x(half_tan, axis, width, height)))
    except ValueError:
        fov_x = math.nan
    if not 0 < fov_x < 180:  # NaN included (issue 25 #4: it rendered through the default 8 mm lens)
        from .errors import ConfigError

        raise ConfigError(f"{where}: the camera's field of view ({source}) is not one: give fov in (0, 180) degrees "
                          "or a positive focal_length")
    return XmlFieldOfView(fov_x, source + f", film {width:g} × {height:g}" + (
        f", in {Path(where).name}" if Path(where) != Path(path) else ""))


def _first_camera(path: Path, inherited: dict[str, str], depth: int):
    """(sensor element, defaults, file) of the first ``<sensor>`` in ``path``, following
    ``<include filename=…>`` (relative to the including file, 8 levels at most) in document
    order; None when there is none or the file cannot be read."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError):
        return None
    defaults = {**inherited, **_defaults(root)}
    for node in root.iter():
        if node.tag == "sensor":
            return node, defaults, str(path)
        if node.tag == "include" and node.get("filename") and depth < 8:
            found = _first_camera(path.parent / _substitute(node.get("filename"), defaults), defaults, depth + 1)
            if found is not None:
                return found
    return None


def _substitute(text: str, defaults: dict[str, str]) -> str:
    """``$name`` parameters of an XML attribute replaced by their defaults (unknown ones kept)."""
    return re.sub(r"\$(\w+)", lambda m: defaults.get(m.group(1), m.group(0)), text)


def focal_length_for_fov(fov_x_deg: float, sensor_width_m: float, focus_distance_m: float) -> float:
    """The focal length (mm) whose thin lens, focused at ``focus_distance_m``, gives a sensor
    ``sensor_width_m`` wide the field of view ``fov_x_deg``: the image distance
    v = (w/2)/tan(fov/2) sets it, f = v·z_f/(z_f + v) (the Gaussian lens equation, as
    :attr:`~spectral_cam.optics.ThinLens.fov_x_deg` uses).

    Examples
    --------
    >>> round(focal_length_for_fov(60.0, 0.036, 1e9), 3)  # a 36-mm-wide sensor focused far away
    31.177
    """
    image_distance = sensor_width_m / 2 / math.tan(math.radians(fov_x_deg) / 2)
    return 1e3 * image_distance * focus_distance_m / (focus_distance_m + image_distance)
