"""The lens models (``lens.model``): one :class:`LensModel` entry per model in :data:`LENS_MODELS`.

An entry says everything the pipeline asks of a model, so adding one is a single
``LENS_MODELS.add(...)`` (issue 41 #2):

- ``camera(mi, config, lens, film, spp)``: the Mitsuba sensor dict a render traces;
- ``render(config, plan, progress)``: a render of its own (the layered model's pinhole render
  defocused per depth), or None for a path trace through ``camera``;
- ``post_render(image, plan)``: metadata the render records (a prescription's traced focal length);
- ``memory_bytes_per_pixel(channels)``: what the model holds beyond the radiance cube
  (:func:`spectral_cam.render.memory.estimate_render_bytes` asks it);
- ``margin(lens, depth)`` and ``needs_depth``: pixels rendered around the frame, and whether the
  plan renders the depth probe for it;
- ``intrinsics(config, frame)``: camera.json's focal scale and distortion
  (:func:`spectral_cam.camera_record.capture_camera_record` asks it);
- ``shading(config)``: how the sensor shades the render: ``traced_vignetting`` (the render already
  holds the cos⁴ falloff and the stop's vignetting) and ``chief_ray_prescription`` (the lens whose
  real chief rays set the pixels' angular response; None: the thin lens's). The render records it
  in ``meta["lens_shading"]``, so the sensor reads it without importing render/;
- ``blades`` and ``distortion``: whether the model renders ``lens.blades`` and ``lens.distortion``
  (the scene's validation asks);
- ``keys``: the ``lens.*`` keys the model brings (:class:`~spectral_cam.keys.Key`; ``[lens]`` is
  assembled from them, :mod:`spectral_cam.scene`), and ``checks`` of their combinations.

``lens.model = "auto"`` is not an entry: :func:`spectral_cam.render.decisions.decide_lens_model`
picks among the entries. The ``"layered"`` entry is registered by :mod:`.layered`, beside its
render (it plans through :mod:`.plan`, which reads this registry).

References
----------
.. [1] Mitsuba 3, ``perspective`` and ``thinlens`` sensors (``fov``, ``aperture_radius``,
   ``focus_distance``, ``near_clip``, ``far_clip``).
.. [2] OpenCV, "Camera calibration and 3D reconstruction" (K, distortion k1, k2, p1, p2, k3).
.. [3] colour-science, method mappings (a named mapping per extension point).
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any, Callable

from ..keys import Key, fraction_in
from ..registry import Registry

if TYPE_CHECKING:
    from ..optics import ThinLens

__all__ = ["LensModel", "LensModelRegistry", "LENS_MODELS", "FAR_CLIP_M", "camera_options", "configured_intrinsics"]

#: How far our Mitsuba cameras see (m). Mitsuba's default, 10 km, clipped the far ground (to 20 km)
#: and the clouds near the horizon, which then showed the sky instead.
FAR_CLIP_M = 1e5

#: A model's camera.json optics where it says nothing of its own: the focal scale is the image
#: distance (None), the distortion the configured ``lens.distortion``.
_CONFIGURED = "the configured lens.distortion (exact: the renderer applies this model)"


def configured_intrinsics(config, frame: "ThinLens") -> dict:
    """camera.json's optics of a model whose rays follow the configured lens: K from the image
    distance, the distortion ``lens.distortion`` (exact: the renderer applies it)."""
    return {"focal_length_m": None, "coefficients": tuple(config.lens.distortion), "source": _CONFIGURED,
            "residual_m": None}


def _no_metadata(image, plan) -> None:
    return None


def _no_extra_memory(channels: int) -> float:
    return 0.0


def _no_margin(lens, depth) -> int:
    return 0


def _thin_shading(config) -> dict:
    return {"traced_vignetting": False, "chief_ray_prescription": None}


@dataclass(frozen=True)
class LensModel:
    """One lens model: what each stage of the pipeline asks of it (module docstring).

    Attributes
    ----------
    name, description : str
        The ``lens.model`` value and one line for messages.
    camera : callable
        ``camera(mi, config, lens, film, spp) -> dict``, the Mitsuba sensor dict; ``config``
        needs only ``render.sampler`` and the ``[lens]`` keys (:func:`camera_options`).
    render : callable or None
        ``render(config, plan, progress) -> SpectralImage`` in place of the path trace.
    post_render : callable
        ``post_render(image, plan)``: adds to ``image.meta``.
    memory_bytes_per_pixel : callable
        ``(channels) -> bytes`` held per pixel beyond the radiance cube.
    margin : callable
        ``(lens, depth_m) -> px`` rendered around the frame.
    needs_depth : bool
        The plan renders the depth probe before choosing ``margin``.
    intrinsics : callable
        ``(config, frame) -> {"focal_length_m", "coefficients", "source", "residual_m"}``.
    shading : callable
        ``(config) -> {"traced_vignetting", "chief_ray_prescription"}``.
    blades, distortion : bool
        The model renders ``lens.blades`` / ``lens.distortion``.
    keys : tuple of Key
        The ``lens.*`` keys it declares (another model may read them: list the same Key).
    checks : tuple of callable
        ``check(lens_section) -> (key, value, rule) | None``.
    """

    name: str
    camera: Callable
    description: str = ""
    render: Callable | None = None
    post_render: Callable = _no_metadata
    memory_bytes_per_pixel: Callable = _no_extra_memory
    margin: Callable = _no_margin
    needs_depth: bool = False
    intrinsics: Callable = configured_intrinsics
    shading: Callable = _thin_shading
    blades: bool = False
    distortion: bool = False
    keys: tuple = ()
    checks: tuple = ()

    @property
    def function(self) -> Callable:  # the Registry's Entry shape: the entry's main function
        return self.camera

    @property
    def options(self) -> tuple[str, ...]:
        return ()

    def __call__(self, *args, **kwargs):
        return self.camera(*args, **kwargs)


class LensModelRegistry(Registry):
    """A :class:`~spectral_cam.registry.Registry` of :class:`LensModel` entries."""

    def add(self, name: str, camera: Callable, *, description: str = "", **fields: Any) -> LensModel:
        """Register the model ``name`` whose Mitsuba camera ``camera`` builds, with the
        :class:`LensModel` ``fields`` it changes from the thin lens's defaults."""
        if name in self._entries:
            raise ValueError(f"{self.kind} {name!r} is registered twice")
        if name == "auto":
            raise ValueError("lens.model = \"auto\" is the decision among the models, not a model")
        entry = LensModel(name, camera, description, **fields)
        self._entries[name] = entry
        return entry

    def declared_keys(self) -> list[tuple[str, Key]]:
        """``(owner, Key)`` of every model's declared keys, in registration order."""
        return [(f"lens model {entry.name}", key) for entry in self._entries.values() for key in entry.keys]

    def register(self, name: str, *, description: str = "", **fields: Any):
        """Decorator: register the decorated camera builder under ``name``."""

        def decorate(camera: Callable) -> Callable:
            self.add(name, camera, description=description, **fields)
            return camera

        return decorate


#: Every lens model, by ``lens.model`` name.
LENS_MODELS = LensModelRegistry("lens model")


def camera_options(sampler: str = "independent", **lens_keys: Any):
    """The parts of a SceneConfig a model's ``camera`` reads (``render.sampler`` and ``[lens]``
    keys), for a camera built without a scene (probes, tests)."""
    lens = dict(glass="N-BK7", prescription="dgauss_50mm", blades=0, blade_rotation_deg=0.0, blade_rounding=0.0,
                distortion=(0.0, 0.0, 0.0, 0.0, 0.0))
    lens.update(lens_keys)
    return SimpleNamespace(render=SimpleNamespace(sampler=sampler), lens=SimpleNamespace(**lens))


def _pose(mi):
    return mi.ScalarTransform4f().look_at(origin=[0, 0, 0], target=[0, 0, 1], up=[0, 1, 0])


def _perspective(mi, config, lens: "ThinLens", film: dict, spp: int, kind: str = "perspective") -> dict:
    return {
        "type": kind,
        "fov": lens.fov_x_deg,
        "fov_axis": "x",
        "to_world": _pose(mi),
        "film": film,
        "sampler": {"type": config.render.sampler, "sample_count": spp},
        "near_clip": min(1e-3, lens.focus_distance_m / 10),
        "far_clip": FAR_CLIP_M,
    }


@LENS_MODELS.register("thin", description="an ideal thin lens (Mitsuba's thinlens): path-traced defocus")
def thin_camera(mi, config, lens: "ThinLens", film: dict, spp: int) -> dict:
    """Mitsuba's ``thinlens``: the lens's field of view, aperture radius and focus distance."""
    camera = _perspective(mi, config, lens, film, spp, "thinlens")
    camera["aperture_radius"] = lens.aperture_radius_m
    camera["focus_distance"] = lens.focus_distance_m
    return camera


@LENS_MODELS.register("pinhole", description="a pinhole (Mitsuba's perspective) with the lens's field of view")
def pinhole_camera(mi, config, lens: "ThinLens", film: dict, spp: int) -> dict:
    """A pinhole (Mitsuba's ``perspective``) with the lens's horizontal field of view."""
    return _perspective(mi, config, lens, film, spp)


def _glass(value, lens):
    from ..optics.glass import GLASS_NAMES

    glasses = [part.strip() for part in str(value).split("+")]
    if value != "ideal" and (len(glasses) > 2 or any(g not in GLASS_NAMES for g in glasses)):
        return (f"give \"ideal\" (no dispersion), a glass (a singlet) or crown+flint (an achromat) from: "
                f"{', '.join(GLASS_NAMES)}")
    return None


def _blade_count(value, lens):
    if isinstance(value, int) and not isinstance(value, bool) and (value == 0 or 3 <= value <= 32):
        return None
    return "give 0 (a circular opening) or 3..32 straight blades"


def _rendered_by_model(capability: str, rule: str):
    """Refuse a non-zero key on an explicit model that does not render it (``"auto"`` picks one that does)."""
    def check(value, lens):
        if any(value) if isinstance(value, tuple) else value:
            if lens.model != "auto" and lens.model in LENS_MODELS and not getattr(LENS_MODELS[lens.model], capability):
                return "lens.model", lens.model, rule
        return None
    return check


def _distortion(value, lens):
    import math

    if len(value) != 5 or not all(math.isfinite(v) and abs(v) <= 1.0 for v in value):
        return "give Brown–Conrady [k1, k2, p1, p2, k3] (OpenCV's order), each within ±1"
    return None


GLASS_KEY = Key("glass", "ideal", "str", "ideal (no dispersion), a SCHOTT glass such as N-BK7 (a singlet), or "
                "crown+flint (a cemented achromat); the focal length at the d line", (_glass,))
BLADE_KEYS = (
    Key("blades", 0, "int", "straight aperture blades (0: round, 3-32)",
        (_blade_count, _rendered_by_model("blades", "aperture blades are rendered by the \"spectral_thin\" lens "
                                          "(lens.model = \"auto\" picks it) or a \"prescription\"'s stop; set "
                                          "lens.model accordingly"))),
    Key("blade_rotation_deg", 0.0, "float", "a blade vertex's angle from up towards image-left",
        (lambda v, s: None if isinstance(v, float) and v == v and abs(v) != float("inf")
         else "must be an angle in degrees",)),
    Key("blade_rounding", 0.0, "float", "0 straight blades - 1 a circle",
        (fraction_in(0.0, 1.0, "must lie in [0, 1]: 0 straight blades, 1 a circle"),)),
)
DISTORTION_KEY = Key("distortion", (0.0, 0.0, 0.0, 0.0, 0.0), "tuple[float, ...]",
                     "Brown–Conrady [k1, k2, p1, p2, k3] (OpenCV's order)",
                     (_distortion, _rendered_by_model("distortion", "Brown–Conrady distortion is rendered by the "
                                                      "\"spectral_thin\" lens (lens.model = \"auto\" picks it; a "
                                                      "prescription has its own); set lens.model = \"spectral_thin\"")))
PRESCRIPTION_KEY = Key("prescription", "dgauss_50mm", "str", "a bundled lens (dgauss_50mm, telephoto_250mm, "
                       "wide_56deg_100mm, dgauss_f2_100mm_glass) or a CSV of surfaces")


@LENS_MODELS.register("spectral_thin", blades=True, distortion=True, keys=(GLASS_KEY, *BLADE_KEYS, DISTORTION_KEY),
                      description="a dispersive thin lens of lens.glass, with aperture blades and Brown–Conrady "
                                  "distortion")
def spectral_thin_camera(mi, config, lens: "ThinLens", film: dict, spp: int) -> dict:
    """A thin lens of ``lens.glass`` (:mod:`spectral_cam.render.spectral_lens`)."""
    from .spectral_lens import plugin_dict, register

    section = config.lens
    register(mi)
    return dict(plugin_dict(lens, section.glass, blades=section.blades, blade_rotation_deg=section.blade_rotation_deg,
                            blade_rounding=section.blade_rounding, distortion=section.distortion),
                to_world=_pose(mi), film=film, sampler={"type": config.render.sampler, "sample_count": spp})


def prescription_camera(mi, config, lens: "ThinLens", film: dict, spp: int) -> dict:
    """Real surfaces of ``lens.prescription`` (:mod:`spectral_cam.render.prescription_lens`)."""
    from ..optics.prescription import load_prescription
    from .prescription_lens import plugin_dict, register

    section = config.lens
    register(mi)
    return dict(plugin_dict(load_prescription(section.prescription), lens, lens.focus_distance_m,
                            blades=section.blades, blade_rotation_deg=section.blade_rotation_deg,
                            blade_rounding=section.blade_rounding),
                to_world=_pose(mi), film=film, sampler={"type": config.render.sampler, "sample_count": spp})


def _prescription_metadata(image, plan) -> None:
    """What the trace says the lens is (focal length, f-number, field), its stop closed to N."""
    from ..optics.prescription import load_prescription

    config = plan.config
    design = load_prescription(config.lens.prescription, f_number=config.lens.f_number)
    image.meta["prescription"] = design.describe(plan.lens.focus_distance_m, plan.lens.sensor_width_m)


def _prescription_intrinsics(config, frame: "ThinLens") -> dict:
    """The prescription's traced focal scale and its distortion fitted to its chief rays."""
    import numpy as np

    from ..optics.prescription import load_prescription

    fitted = load_prescription(config.lens.prescription).opencv_distortion(
        frame.focus_distance_m, 0.5 * float(np.hypot(frame.sensor_width_m, frame.sensor_height_m)))
    return {"focal_length_m": fitted["focal_length_m"], "coefficients": tuple(fitted["coefficients"]),
            "source": "fitted to the prescription's chief rays (least squares over the field to the sensor's corner)",
            "residual_m": fitted["residual_m"]}


def _prescription_shading(config) -> dict:
    # the trace holds its vignetting (natural and mechanical); its real chief rays set the CRA
    return {"traced_vignetting": True, "chief_ray_prescription": config.lens.prescription}


LENS_MODELS.add("prescription", prescription_camera, blades=True, post_render=_prescription_metadata,
                keys=(PRESCRIPTION_KEY, *BLADE_KEYS),
                intrinsics=_prescription_intrinsics, shading=_prescription_shading,
                description="real surfaces of lens.prescription traced (its stop's blades; its own distortion)")
