"""Colour-pipeline validation against spectral ground truth: ``spectral-cam validate``.

A *plan* (TOML) names a matrix of illuminants × cameras × exposures × reflectance sets and
the pipelines to evaluate on it. For every cell the simulator builds a chart of the
reflectances under the illuminant, exposes it on the camera's measured curves, writes the
RAW as a DNG and hands it to each pipeline; each pipeline's linear output is compared,
patch by patch, with the colorimetric ground truth computed from the spectra.

    spectral-cam validate PLAN.toml -o REPORT_DIR [--set section.key=value]... [--force]
    spectral-cam validate --self [--csv PATH]

Ground truth (one definition everywhere, :mod:`spectral_cam.colorimetry`): CIE 1931 2° XYZ
of each reflectance under the scene illuminant (colour-science integration on the CMFs'
1-nm grid, the perfect diffuser at Y = 1) → Bradford chromatic adaptation (von Kries) from
the illuminant's white to D65 → linear sRGB, unclipped. A pipeline's patch means are first
scaled so the white reference has the ground truth's luminance (exposure matching); then

- ΔE2000 per patch (CIELAB under D65; mean, 95th percentile — NumPy's linear
  interpolation — and maximum over the set's patches);
- white-balance error: the angle (degrees) between the pipeline's and the ground truth's
  linear sRGB of the white reference (the recovery angular error);
- noise: SNR = mean / standard deviation of the luminance Y over each patch's interior.

The chart
---------
``chart = "synthetic"`` (the default) builds the radiance directly: each reflectance a
square block of ``patch_px`` pixels on a dark frame (reflectance 0.03, as the ColorChecker
preset's), with band radiance ``L_b = ∫_b ρ(λ)·E(λ)/π dλ`` (Lambert's law; E the
illuminant's absolute spectral irradiance at ``illuminance_lux``) on the ``bands`` grid.
That is exactly what a render of flat Lambertian patches facing the camera converges to,
without Monte-Carlo noise, so no Mitsuba run is needed. ``chart = "render"`` renders the
``colorchecker`` scene preset with Mitsuba instead (the plan's ``[scene]``, ``[lens]``,
``[render]`` tables apply), e.g. to reproduce a render-based test exactly.

Sets other than the ColorChecker get the ColorChecker's ``white 9.5 (.05 D)`` patch appended
as the white reference (excluded from their statistics). Auto exposure
(``time_s = "auto"``) puts the brightest patch — for every camera the white reference on a
ColorChecker; on sets with fluorescent samples above white, that sample — at
``auto_fraction`` of saturation. On a synthetic chart natural vignetting is off unless the
plan's ``[sensor]`` sets ``vignetting``: the chart is a flat target, and lens fall-off
would count as colour error. Temporal noise is seeded by ``[render] seed`` and the fixed
patterns by ``[sensor] seed``, as in a render, so every cell of a plan sees the same noise
realisation (common random numbers make pipelines directly comparable).

Pipelines
---------
- ``type = "ours"``: :func:`spectral_cam.isp.develop` with any ISP settings (``isp = {...}``);
  its linear sRGB before the tone curve is measured. It develops the exposed RAW in memory,
  which carries the fitted colour corrections the ``"fitted"``/``"root_polynomial"``
  colour matrices need (a DNG read back does not).
- ``type = "rawpy"``: LibRaw through rawpy (``demosaic``, ``white_balance``,
  ``output_color``, ``highlight_mode``, ``fbdd_noise_reduction``,
  ``median_filter_passes``), always linear (gamma 1), 16-bit, without auto brightening or
  LibRaw's maximum adjustment.
- ``type = "callable"``: ``function = "module:function"``, called as ``function(raw_path)``
  and returning an (H, W, 3) array in the space ``output`` names (``"linear_srgb"``,
  ``"xyz"`` — CIE XYZ relative to D65 — or ``"srgb"``, sRGB-encoded); ``python_path`` lists
  folders (relative to the plan) to import it from.
- ``type = "command"``: ``command`` with ``{input}`` (the DNG) and ``{output}`` (a file
  with suffix ``output_suffix``: ``.npy``, ``.tif``/``.tiff``, ``.png`` or ``.exr``)
  placeholders, run without a shell; ``output`` as for callables.

A plan::

    [validate]
    illuminants = ["D65", "A"]            # colour-science names, "blackbody:<K>", CSV paths
    cameras = ["nikon_d850", "sony_ilce_7m3"]
    reflectance_sets = ["colorchecker", "cie2017"]   # or CSV files (wavelength_nm, one column per patch)
    [validate.thresholds]                 # a cell passes when all of these hold
    mean_delta_e = 3.0
    [[exposure]]                          # one table per exposure (default: auto, ISO of [sensor])
    iso = 100
    [[pipeline]]
    name = "ours"
    type = "ours"
    isp = { demosaic = "menon2007" }
    [sensor]                              # any scene-file [sensor]/[lens]/[scene]/[render] key
    read_noise_e = 2.5

References
----------
.. [1] CIE 15:2004, Colorimetry, 3rd ed., §7 (tristimulus values), §8.2.1 (CIELAB).
.. [2] Lam, K. M. (1985). Metamerism and colour constancy. PhD thesis, University of
   Bradford; CIE 160:2004 (the Bradford chromatic adaptation transform).
.. [3] Sharma, G., Wu, W., & Dalal, E. N. (2005). The CIEDE2000 color-difference formula.
   Color Research & Application 30(1), 21–30.
.. [4] Hordley, S. D., & Finlayson, G. D. (2006). Reevaluation of color constancy algorithm
   performance. JOSA A 23(5), 1008–1020 (angular error).
.. [5] ISO 15739:2017, Photography — Electronic still-picture imaging — Noise measurements
   (SNR of uniform patches).
.. [6] CIE 224:2017, CIE 2017 Colour Fidelity Index for accurate scientific use (99 samples);
   CIE 13.3-1995 (test colour samples); Davis, W., & Ohno, Y. (2010). Color quality scale.
   Optical Engineering 49(3) (CQS samples); Academy of Motion Picture Arts and Sciences,
   rawtoaces (190 training reflectances); Pascale, D. (2006), BabelColor ColorChecker data.
.. [7] EMVA Standard 1288, Release 4.0 (2021) (photon transfer, for ``--self``).
"""

from __future__ import annotations

import abc
import argparse
import copy
import csv
import dataclasses
import importlib
import json
import math
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from .charts import (
    REFLECTANCE_SETS,
    Chart,
    ReflectanceSet,
    reflectance_set,
    synthetic_chart,
)
from .colorimetry import white_patch_index
from .errors import ConfigError, SpectralCamError

__all__ = [
    "REFLECTANCE_SETS",
    "PIPELINE_TYPES",
    "OUTPUT_SPACES",
    "CHART_SOURCES",
    "RAWPY_WHITE_BALANCE",
    "RAWPY_OUTPUT_COLOURS",
    "Thresholds",
    "ExposureSpec",
    "Plan",
    "ReflectanceSet",
    "Chart",
    "CellResult",
    "ValidationResult",
    "CheckResult",
    "OursPipeline",
    "RawpyPipeline",
    "CallablePipeline",
    "CommandPipeline",
    "load_plan",
    "plan_from_dict",
    "reflectance_set",
    "synthetic_chart",
    "rendered_chart",
    "evaluate_patches",
    "angular_error_deg",
    "run_plan",
    "self_checks",
    "format_checks",
    "configure_parser",
    "run",
]

#: Chart sources: analytic radiance blocks, or a Mitsuba render of the ColorChecker preset.
CHART_SOURCES = ("synthetic", "render")
#: Pipeline kinds a plan's ``[[pipeline]]`` ``type`` may name.
PIPELINE_TYPES = ("ours", "rawpy", "callable", "command")
#: What a user pipeline returns: linear sRGB, CIE XYZ (D65-relative) or sRGB-encoded values.
OUTPUT_SPACES = ("linear_srgb", "xyz", "srgb")
#: Files a command pipeline may write.
OUTPUT_SUFFIXES = (".npy", ".tif", ".tiff", ".png", ".exr")
#: LibRaw white balance: AsShotNeutral, LibRaw's automatic estimate, its daylight
#: multipliers (from the D65 matrix), or ``wb_gains``.
RAWPY_WHITE_BALANCE = ("camera", "auto", "daylight", "manual")
#: LibRaw output spaces measured (both relative to D65 in LibRaw).
RAWPY_OUTPUT_COLOURS = ("XYZ", "sRGB")
RAWPY_HIGHLIGHT_MODES = ("clip", "ignore", "blend", "reconstruct")
RAWPY_FBDD = ("off", "light", "full")
#: Report swatch selection.
SWATCH_MODES = ("all", "failing", "none")
#: Fraction of each patch's size left out on every side when averaging (edges, demosaicing).
PATCH_MARGIN = 0.2
#: The ColorChecker patch used as white reference (exposure matching, WB error).
#: Reflectance of the synthetic chart's frame (the ColorChecker preset's black frame).
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]*$")
_SCENE_SECTIONS = ("scene", "lens", "sensor", "render", "illuminant")


def rendered_chart(config) -> Chart:
    """The ``colorchecker`` scene preset rendered with Mitsuba under ``config``.

    Parameters
    ----------
    config : SceneConfig
        A scene with ``scene.preset = "colorchecker"`` (its illuminant, lens, sensor size
        and render settings are used as they are).

    Returns
    -------
    Chart
        The render (tiny negative round-off set to 0) with the preset's patches.

    References
    ----------
    .. [1] Jakob, W., et al. (2022). Mitsuba 3 renderer (spectral variants, ``specfilm``).
    """
    from . import spectra
    from .presets import colorchecker_patches
    from .render import render

    if config.scene.preset != "colorchecker" or config.scene.mitsuba_xml:
        raise ConfigError("validate.chart = 'render' renders the 'colorchecker' scene preset; "
                          "set [scene] preset = 'colorchecker' (and no mitsuba_xml)")
    image = render(config, with_depth=False)
    image.data = np.maximum(image.data, 0.0)
    patches = colorchecker_patches(config)
    names = [p.name for p in patches]
    sds = list(spectra.colorchecker_reflectances().values())
    return Chart(image, patches, len(patches), white_patch_index(names), sds, "render")


# ============================================================================ plan
@dataclass(frozen=True)
class Thresholds:
    """Pass criteria of a cell (all must hold).

    Attributes
    ----------
    mean_delta_e, p95_delta_e, max_delta_e : float
        Largest allowed mean, 95th-percentile and maximum ΔE2000 over the set's patches.
    wb_angular_error_deg : float
        Largest allowed angle (degrees) between the pipeline's and the ground truth's white
        reference in linear sRGB.
    """

    mean_delta_e: float = 3.0
    p95_delta_e: float = 6.0
    max_delta_e: float = 10.0
    wb_angular_error_deg: float = 3.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
                raise ConfigError(f"validate.thresholds.{f.name} = {value!r}: must be a number > 0 (inf disables it)")
            object.__setattr__(self, f.name, float(value))

    def failures(self, stats: Mapping[str, float]) -> list[str]:
        """Names of the criteria a cell's statistics break."""
        checks = (("mean_delta_e", "delta_e_mean"), ("p95_delta_e", "delta_e_p95"),
                  ("max_delta_e", "delta_e_max"), ("wb_angular_error_deg", "wb_angular_error_deg"))
        return [f"{stat} {stats[stat]:.3g} > {getattr(self, limit):g}" for limit, stat in checks
                if not stats[stat] <= getattr(self, limit)]


@dataclass(frozen=True)
class ExposureSpec:
    """One exposure setting of the plan.

    Attributes
    ----------
    name : str
        Label in the report (default from the settings, e.g. ``"auto0.8_iso100"``).
    time_s : float or "auto"
        Exposure time, s; ``"auto"`` puts the brightest patch at ``auto_fraction`` of
        saturation.
    iso : float
        ISO speed (gain K = K_base·iso/base_iso).
    auto_fraction : float
        Fraction of saturation for auto exposure.
    """

    name: str
    time_s: float | str = "auto"
    iso: float = 100.0
    auto_fraction: float = 0.8


class _Pipeline(abc.ABC):
    """A pipeline under test: turns one RAW into a linear sRGB image of the whole frame."""

    kind = ""

    def __init__(self, name: str):
        self.name = name

    @abc.abstractmethod
    def develop(self, raw, dng_path: Path, workdir: Path) -> np.ndarray:
        """Develop a RAW.

        Parameters
        ----------
        raw : RawImage
            The exposed RAW in memory (with the simulator's metadata).
        dng_path : pathlib.Path
            The same RAW written as a DNG.
        workdir : pathlib.Path
            A scratch folder.

        Returns
        -------
        numpy.ndarray
            (H, W, 3) linear sRGB (D65), unclipped; any exposure scale.
        """

    @abc.abstractmethod
    def describe(self) -> str:
        """One line for the report."""

    @abc.abstractmethod
    def to_dict(self) -> dict:
        """JSON-friendly settings (for plan.json)."""


class OursPipeline(_Pipeline):
    """spectral_cam's own ISP with the given :class:`~spectral_cam.isp.ISPConfig`.

    The measured image is :attr:`DevelopedImage.linear` (linear sRGB before tone curve and
    sharpening), so ΔE is measured with the tone curve off, as the design prescribes.
    """

    kind = "ours"

    def __init__(self, name: str, *, isp):
        super().__init__(name)
        self.isp = isp

    def develop(self, raw, dng_path: Path, workdir: Path) -> np.ndarray:
        from .isp import develop

        return np.asarray(develop(raw, self.isp).linear, dtype=np.float64)

    def describe(self) -> str:
        from .isp import ISPConfig

        default = ISPConfig().to_dict()
        changed = {k: v for k, v in self.isp.to_dict().items() if default.get(k) != v}
        return "spectral_cam ISP" + (f" ({', '.join(f'{k}={v}' for k, v in changed.items())})" if changed else "")

    def to_dict(self) -> dict:
        return {"name": self.name, "type": self.kind, "isp": self.isp.to_dict()}


class RawpyPipeline(_Pipeline):
    """LibRaw (rawpy) development of the DNG, linear 16-bit output, measured as is.

    References
    ----------
    .. [1] rawpy API, ``RawPy.postprocess`` (LibRaw output parameters).
    """

    kind = "rawpy"

    def __init__(self, name: str, *, demosaic: str = "AHD", white_balance: str = "camera",
                 wb_gains: Sequence[float] = (), output_color: str = "XYZ", highlight_mode: str = "clip",
                 fbdd_noise_reduction: str = "off", median_filter_passes: int = 0):
        import rawpy

        super().__init__(name)
        supported = [a.name for a in rawpy.DemosaicAlgorithm if a.isSupported]
        by_fold = {n.casefold(): n for n in supported}
        if str(demosaic).casefold() not in by_fold:
            raise ConfigError(f"pipeline {name!r}: demosaic = {demosaic!r}; valid (this LibRaw): {', '.join(supported)}")
        self.demosaic = by_fold[str(demosaic).casefold()]
        if white_balance not in RAWPY_WHITE_BALANCE:
            raise ConfigError(f"pipeline {name!r}: white_balance = {white_balance!r}; valid: "
                              f"{', '.join(RAWPY_WHITE_BALANCE)}")
        gains = tuple(float(g) for g in wb_gains)
        if white_balance == "manual" and (len(gains) != 3 or not all(g > 0 for g in gains)):
            raise ConfigError(f"pipeline {name!r}: white_balance = 'manual' needs wb_gains = [r, g, b] (all > 0)")
        self.white_balance, self.wb_gains = white_balance, gains
        colours = {c.casefold(): c for c in RAWPY_OUTPUT_COLOURS}
        if str(output_color).casefold() not in colours:
            raise ConfigError(f"pipeline {name!r}: output_color = {output_color!r}; valid: "
                              f"{', '.join(RAWPY_OUTPUT_COLOURS)} (LibRaw's D65-relative spaces)")
        self.output_color = colours[str(output_color).casefold()]
        if highlight_mode not in RAWPY_HIGHLIGHT_MODES:
            raise ConfigError(f"pipeline {name!r}: highlight_mode = {highlight_mode!r}; valid: "
                              f"{', '.join(RAWPY_HIGHLIGHT_MODES)}")
        self.highlight_mode = highlight_mode
        if fbdd_noise_reduction not in RAWPY_FBDD:
            raise ConfigError(f"pipeline {name!r}: fbdd_noise_reduction = {fbdd_noise_reduction!r}; valid: "
                              f"{', '.join(RAWPY_FBDD)}")
        self.fbdd_noise_reduction = fbdd_noise_reduction
        if isinstance(median_filter_passes, bool) or not isinstance(median_filter_passes, int) \
                or not 0 <= median_filter_passes <= 10:
            raise ConfigError(f"pipeline {name!r}: median_filter_passes = {median_filter_passes!r}; "
                              "must be a whole number in 0..10")
        self.median_filter_passes = median_filter_passes

    def _options(self) -> dict:
        import rawpy

        highlight = {"clip": rawpy.HighlightMode.Clip, "ignore": rawpy.HighlightMode.Ignore,
                     "blend": rawpy.HighlightMode.Blend, "reconstruct": rawpy.HighlightMode.ReconstructDefault}
        fbdd = {"off": rawpy.FBDDNoiseReductionMode.Off, "light": rawpy.FBDDNoiseReductionMode.Light,
                "full": rawpy.FBDDNoiseReductionMode.Full}
        options = dict(
            demosaic_algorithm=rawpy.DemosaicAlgorithm[self.demosaic],
            output_color=rawpy.ColorSpace[self.output_color],
            gamma=(1, 1), no_auto_bright=True, adjust_maximum_thr=0.0, output_bps=16, user_flip=0,
            highlight_mode=highlight[self.highlight_mode], fbdd_noise_reduction=fbdd[self.fbdd_noise_reduction],
            median_filter_passes=self.median_filter_passes,
            use_camera_wb=self.white_balance == "camera", use_auto_wb=self.white_balance == "auto",
        )
        if self.white_balance == "manual":
            r, g, b = self.wb_gains
            options["user_wb"] = [r, g, b, g]
        return options

    def develop(self, raw, dng_path: Path, workdir: Path) -> np.ndarray:
        import rawpy

        from .colorimetry import xyz_to_linear_srgb

        with rawpy.imread(str(dng_path)) as handle:
            image = handle.postprocess(**self._options()).astype(np.float64) / 65535.0
        return xyz_to_linear_srgb(image) if self.output_color == "XYZ" else image

    def describe(self) -> str:
        import rawpy

        return (f"LibRaw {'.'.join(map(str, rawpy.libraw_version))} via rawpy "
                f"({self.demosaic}, wb {self.white_balance}, {self.output_color} output)")

    def to_dict(self) -> dict:
        return {"name": self.name, "type": self.kind, "demosaic": self.demosaic, "white_balance": self.white_balance,
                "wb_gains": list(self.wb_gains), "output_color": self.output_color,
                "highlight_mode": self.highlight_mode, "fbdd_noise_reduction": self.fbdd_noise_reduction,
                "median_filter_passes": self.median_filter_passes}


def _to_linear_srgb(image, space: str) -> np.ndarray:
    """(H, W, 3) values in ``space`` → linear sRGB (unclipped)."""
    import colour

    from .colorimetry import xyz_to_linear_srgb

    if space == "xyz":
        return xyz_to_linear_srgb(image)
    if space == "srgb":
        return np.asarray(colour.cctf_decoding(image, function="sRGB"), dtype=np.float64)
    return image


def _check_output(image, name: str) -> np.ndarray:
    try:
        array = np.asarray(image, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"pipeline {name!r} returned something that is not a numeric array ({exc})") from None
    if array.ndim == 3 and array.shape[-1] == 4:
        array = array[..., :3]  # drop alpha
    if array.ndim != 3 or array.shape[-1] != 3:
        raise ConfigError(f"pipeline {name!r} returned shape {array.shape}; expected (H, W, 3)")
    if not np.all(np.isfinite(array)):
        raise ConfigError(f"pipeline {name!r} returned NaN or infinite values")
    return array


class CallablePipeline(_Pipeline):
    """A user's Python function ``function(raw_path) -> (H, W, 3) array``."""

    kind = "callable"

    def __init__(self, name: str, *, function: str, output: str = "linear_srgb",
                 python_path: Sequence[str] = (), base_dir: Path = Path(".")):
        super().__init__(name)
        if not isinstance(function, str) or function.count(":") != 1 or not all(function.split(":")):
            raise ConfigError(f"pipeline {name!r}: function = {function!r}; use 'module:function' "
                              "(e.g. 'my_isp:develop')")
        if output not in OUTPUT_SPACES:
            raise ConfigError(f"pipeline {name!r}: output = {output!r}; valid: {', '.join(OUTPUT_SPACES)}")
        self.function, self.output = function, output
        paths = [python_path] if isinstance(python_path, str) else list(python_path)
        self.python_path = [str((base_dir / Path(p).expanduser()).resolve()) for p in paths]
        self._callable = self._resolve()

    def _resolve(self) -> Callable:
        module_name, attribute = self.function.split(":")
        for entry in reversed(self.python_path):
            if entry not in sys.path:
                sys.path.insert(0, entry)
        try:
            module = importlib.import_module(module_name)
        except Exception as exc:
            raise ConfigError(f"pipeline {self.name!r}: cannot import module {module_name!r} "
                              f"({type(exc).__name__}: {exc}); add its folder to python_path") from None
        target = module
        for part in attribute.split("."):
            target = getattr(target, part, None)
        if not callable(target):
            raise ConfigError(f"pipeline {self.name!r}: {self.function!r} is not a callable in {module_name!r}")
        return target

    def develop(self, raw, dng_path: Path, workdir: Path) -> np.ndarray:
        image = _check_output(self._callable(str(dng_path)), self.name)
        return _to_linear_srgb(image, self.output)

    def describe(self) -> str:
        return f"Python callable {self.function} → {self.output}"

    def to_dict(self) -> dict:
        return {"name": self.name, "type": self.kind, "function": self.function, "output": self.output,
                "python_path": self.python_path}


def _read_image_file(path: Path) -> np.ndarray:
    """Read a command's output: .npy (as is), TIFF/PNG (integers scaled to [0, 1]), EXR."""
    suffix = path.suffix.lower()
    if suffix == ".npy":
        return np.load(path, allow_pickle=False)
    if suffix in (".tif", ".tiff"):
        import tifffile

        data = tifffile.imread(path)
    elif suffix == ".png":
        import cv2

        data = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if data is None:
            raise ConfigError(f"{path} is not a readable PNG")
        if data.ndim == 3:
            data = data[..., 2::-1] if data.shape[-1] in (3, 4) else data
    elif suffix == ".exr":
        import OpenEXR

        with OpenEXR.File(str(path)) as exr:
            channels = exr.channels()
            if "RGB" in channels or "RGBA" in channels:
                data = np.asarray(channels.get("RGB", channels.get("RGBA")).pixels)
            else:
                missing = [c for c in "RGB" if c not in channels]
                if missing:
                    raise ConfigError(f"{path}: EXR without channels {', '.join(missing)}")
                data = np.stack([np.asarray(channels[c].pixels) for c in "RGB"], axis=-1)
    else:
        raise ConfigError(f"cannot read {path.name}; valid output suffixes: {', '.join(OUTPUT_SUFFIXES)}")
    data = np.asarray(data)
    if np.issubdtype(data.dtype, np.integer):
        return data.astype(np.float64) / float(np.iinfo(data.dtype).max)
    return data.astype(np.float64)


class CommandPipeline(_Pipeline):
    """An external program run as ``command`` with ``{input}``/``{output}`` placeholders.

    The command line is split like a POSIX shell would (``shlex``) and run without a
    shell; ``{input}`` becomes the DNG path, ``{output}`` a fresh file path with
    ``output_suffix``, which the program must write.
    """

    kind = "command"

    def __init__(self, name: str, *, command: str, output: str = "linear_srgb", output_suffix: str = ".tiff",
                 timeout_s: float = 300.0):
        super().__init__(name)
        if not isinstance(command, str) or "{input}" not in command or "{output}" not in command:
            raise ConfigError(f"pipeline {name!r}: command = {command!r}; it must contain the {{input}} and "
                              "{output} placeholders")
        try:
            self.argv = shlex.split(command)
        except ValueError as exc:
            raise ConfigError(f"pipeline {name!r}: cannot split command ({exc})") from None
        if output not in OUTPUT_SPACES:
            raise ConfigError(f"pipeline {name!r}: output = {output!r}; valid: {', '.join(OUTPUT_SPACES)}")
        suffix = str(output_suffix).lower()
        if not suffix.startswith("."):
            suffix = "." + suffix
        if suffix not in OUTPUT_SUFFIXES:
            raise ConfigError(f"pipeline {name!r}: output_suffix = {output_suffix!r}; valid: {', '.join(OUTPUT_SUFFIXES)}")
        if isinstance(timeout_s, bool) or not isinstance(timeout_s, (int, float)) or not timeout_s > 0:
            raise ConfigError(f"pipeline {name!r}: timeout_s = {timeout_s!r}; must be a number of seconds > 0")
        self.command, self.output, self.output_suffix, self.timeout_s = command, output, suffix, float(timeout_s)

    def develop(self, raw, dng_path: Path, workdir: Path) -> np.ndarray:
        with tempfile.TemporaryDirectory(prefix=f"{self.name}-", dir=workdir) as folder:
            out = Path(folder) / f"output{self.output_suffix}"
            argv = [arg.replace("{input}", str(dng_path)).replace("{output}", str(out)) for arg in self.argv]
            try:
                done = subprocess.run(argv, capture_output=True, text=True, timeout=self.timeout_s)
            except FileNotFoundError:
                raise ConfigError(f"pipeline {self.name!r}: program {argv[0]!r} not found") from None
            except subprocess.TimeoutExpired:
                raise ConfigError(f"pipeline {self.name!r}: no result within {self.timeout_s:g} s") from None
            if done.returncode != 0:
                tail = (done.stderr or done.stdout or "").strip()[-500:]
                raise ConfigError(f"pipeline {self.name!r}: exit status {done.returncode}: {tail}")
            if not out.is_file():
                raise ConfigError(f"pipeline {self.name!r}: the command wrote no {{output}} file ({out.name})")
            image = _check_output(_read_image_file(out), self.name)
        return _to_linear_srgb(image, self.output)

    def describe(self) -> str:
        return f"command `{self.command}` → {self.output}"

    def to_dict(self) -> dict:
        return {"name": self.name, "type": self.kind, "command": self.command, "output": self.output,
                "output_suffix": self.output_suffix, "timeout_s": self.timeout_s}


@dataclass(frozen=True)
class Plan:
    """A validated validation plan (see the module docstring for the TOML layout).

    Attributes
    ----------
    illuminants, cameras : tuple of str
        The matrix axes.
    reflectance_sets : tuple of ReflectanceSet
    exposures : tuple of ExposureSpec
    pipelines : tuple
        Pipeline objects (:class:`OursPipeline`, :class:`RawpyPipeline`,
        :class:`CallablePipeline`, :class:`CommandPipeline`).
    thresholds : Thresholds
    chart : str
        ``"synthetic"`` or ``"render"``.
    bands : str
        Synthetic chart band centres, nm.
    patch_px, gap_px : int
        Synthetic chart patch size and spacing, pixels.
    swatches : str
        Report swatches for ``"all"`` cells, only ``"failing"`` ones, or ``"none"``.
    sections : dict
        Scene-file tables shared by every cell (``scene``, ``lens``, ``sensor``,
        ``render``, ``illuminant``).
    source : str
        The plan file (or ``"<dict>"``).
    base_dir : str
        Folder relative paths in ``sections`` are resolved against.
    """

    illuminants: tuple[str, ...]
    cameras: tuple[str, ...]
    reflectance_sets: tuple[ReflectanceSet, ...]
    exposures: tuple[ExposureSpec, ...]
    pipelines: tuple
    thresholds: Thresholds = Thresholds()
    chart: str = "synthetic"
    bands: str = "400:700:10"
    patch_px: int = 16
    gap_px: int = 4
    swatches: str = "all"
    sections: dict = field(default_factory=dict)
    source: str = "<dict>"
    base_dir: str = "."

    @property
    def illuminance_lux(self) -> float:
        return float(self.sections.get("illuminant", {}).get("illuminance_lux", 1000.0))

    def scene_config(self, illuminant: str, camera: str, exposure: ExposureSpec, chart: Chart | None = None):
        """The validated SceneConfig of one cell.

        Parameters
        ----------
        illuminant, camera : str
            The cell's illuminant and camera.
        exposure : ExposureSpec
        chart : Chart, optional
            A synthetic chart fixes the sensor size (and vignetting defaults to off).
        """
        from .scene import scene_from_dict

        data = {name: dict(table) for name, table in self.sections.items()}
        overrides: dict[str, Any] = {
            "illuminant.spd": illuminant, "sensor.model": camera,
            "exposure.time_s": exposure.time_s, "exposure.iso": exposure.iso,
            "exposure.auto_fraction": exposure.auto_fraction,
        }
        if chart is not None and chart.source == "synthetic":
            height, width = chart.radiance.data.shape[:2]
            overrides.update({"sensor.width_px": width, "sensor.height_px": height})
            if "vignetting" not in data.get("sensor", {}):
                overrides["sensor.vignetting"] = False
        return scene_from_dict(data, overrides=overrides, base_dir=Path(self.base_dir))

    def to_dict(self) -> dict:
        """JSON-friendly description (written as ``plan.json`` next to the report)."""
        return {
            "source": self.source,
            "illuminants": list(self.illuminants),
            "cameras": list(self.cameras),
            "reflectance_sets": [{"name": s.name, "patches": len(s), "description": s.description}
                                 for s in self.reflectance_sets],
            "exposures": [dataclasses.asdict(e) for e in self.exposures],
            "pipelines": [p.to_dict() for p in self.pipelines],
            "thresholds": {k: v if math.isfinite(v) else "inf" for k, v in dataclasses.asdict(self.thresholds).items()},
            "chart": self.chart, "bands": self.bands, "patch_px": self.patch_px, "gap_px": self.gap_px,
            "swatches": self.swatches,
            "sections": self.sections,
        }


def _string_list(key: str, value: Any) -> tuple[str, ...]:
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, (list, tuple)) or not value or not all(isinstance(v, str) and v.strip() for v in value):
        raise ConfigError(f"{key} = {value!r}: give a non-empty list of names")
    if len(set(value)) != len(value):
        raise ConfigError(f"{key} = {value!r}: names must not repeat")
    return tuple(v.strip() for v in value)


def _check_keys(where: str, table: Mapping, valid: Sequence[str]) -> None:
    unknown = sorted(set(table) - set(valid))
    if unknown:
        raise ConfigError(f"unknown key(s) {', '.join(unknown)} in {where}; valid: {', '.join(valid)}")


_VALIDATE_KEYS = ("illuminants", "cameras", "reflectance_sets", "chart", "bands", "patch_px", "gap_px",
                  "swatches", "thresholds")
_PIPELINE_KEYS = {
    "ours": ("name", "type", "isp"),
    "rawpy": ("name", "type", "demosaic", "white_balance", "wb_gains", "output_color", "highlight_mode",
              "fbdd_noise_reduction", "median_filter_passes"),
    "callable": ("name", "type", "function", "output", "python_path"),
    "command": ("name", "type", "command", "output", "output_suffix", "timeout_s"),
}


def _exposure(table: Mapping, index: int, default_iso: float) -> ExposureSpec:
    from .scene import ExposureSection

    if not isinstance(table, Mapping):
        raise ConfigError(f"[[exposure]] #{index + 1} must be a table of key = value pairs")
    _check_keys(f"[[exposure]] #{index + 1}", table, ("name", "time_s", "iso", "auto_fraction"))
    time_s = table.get("time_s", "auto")
    iso = table.get("iso", default_iso)
    fraction = table.get("auto_fraction", 0.8)
    for key, value in (("iso", iso), ("auto_fraction", fraction)):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"[[exposure]] #{index + 1}: {key} = {value!r} must be a number")
    if time_s != "auto" and (isinstance(time_s, bool) or not isinstance(time_s, (int, float))):
        raise ConfigError(f"[[exposure]] #{index + 1}: time_s = {time_s!r}; give seconds or 'auto'")
    section = ExposureSection(time_s=time_s if time_s == "auto" else float(time_s), iso=float(iso),
                              auto_fraction=float(fraction))
    if "name" in table:
        name = table["name"]
    elif time_s == "auto":
        name = f"auto{section.auto_fraction:g}_iso{section.iso:g}"
    else:
        name = f"{section.time_s:g}s_iso{section.iso:g}"
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise ConfigError(f"[[exposure]] #{index + 1}: name = {name!r}; use letters, digits, '_', '.', '+', '-'")
    return ExposureSpec(name, section.time_s, section.iso, section.auto_fraction)


def _pipeline(table: Mapping, index: int, base_dir: Path):
    from .isp import ISPConfig

    where = f"[[pipeline]] #{index + 1}"
    if not isinstance(table, Mapping):
        raise ConfigError(f"{where} must be a table of key = value pairs")
    kind = table.get("type")
    if kind not in PIPELINE_TYPES:
        raise ConfigError(f"{where}: type = {kind!r}; valid: {', '.join(PIPELINE_TYPES)}")
    name = table.get("name", kind)
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise ConfigError(f"{where}: name = {name!r}; use letters, digits, '_', '.', '+', '-'")
    _check_keys(f"{where} (type = {kind!r})", table, _PIPELINE_KEYS[kind])
    options = {k: v for k, v in table.items() if k not in ("name", "type")}
    if kind == "ours":
        isp = options.get("isp", {})
        if not isinstance(isp, Mapping):
            raise ConfigError(f"{where}: isp must be a table of ISP settings, e.g. isp = {{ demosaic = 'menon2007' }}")
        return OursPipeline(name, isp=ISPConfig.from_dict(dict(isp)))
    if kind == "rawpy":
        return RawpyPipeline(name, **options)
    if kind == "callable":
        if "function" not in options:
            raise ConfigError(f"{where}: a callable pipeline needs function = 'module:function'")
        return CallablePipeline(name, base_dir=base_dir, **options)
    if "command" not in options:
        raise ConfigError(f"{where}: a command pipeline needs command = '... {{input}} ... {{output}} ...'")
    return CommandPipeline(name, **options)


def _set_dotted(data: dict, dotted: str, value: Any) -> None:
    parts = str(dotted).split(".")
    if len(parts) < 2 or not all(parts):
        raise ConfigError(f"override {dotted!r}: use section.key=value, e.g. validate.patch_px=12")
    table = data
    for part in parts[:-1]:
        table = table.setdefault(part, {})
        if not isinstance(table, dict):
            raise ConfigError(f"override {dotted!r}: {part!r} is not a table")
    table[parts[-1]] = value


def plan_from_dict(data: Mapping[str, Any], *, base_dir: str | Path = ".", source: str = "<dict>",
                   overrides: Mapping[str, Any] | None = None) -> Plan:
    """Build and validate a :class:`Plan` from nested dicts (as read from TOML).

    Parameters
    ----------
    data : mapping
        ``{"validate": {...}, "exposure": [...], "pipeline": [...], "sensor": {...}, ...}``.
    base_dir : str or path-like
        Folder relative paths (CSV sets and illuminants, python_path) are resolved against.
    source : str
        Where the plan came from (for the report).
    overrides : mapping, optional
        ``{"section.key": value}`` applied on top (e.g. ``{"validate.patch_px": 12}``).

    Returns
    -------
    Plan

    Raises
    ------
    ConfigError
        For unknown sections, keys or names (listing the valid ones) and invalid values;
        every cell's scene configuration is validated before anything runs.
    """
    from . import spectra
    from .scene import scene_from_dict

    base_dir = Path(base_dir)
    data = copy.deepcopy(dict(data))
    for dotted, value in (overrides or {}).items():
        _set_dotted(data, dotted, value)
    valid_sections = ("validate", "exposure", "pipeline", *_SCENE_SECTIONS)
    _check_keys("the plan (sections)", data, valid_sections)
    if "isp" in data:
        raise ConfigError("[isp] belongs to a pipeline: give [[pipeline]] type = 'ours' with isp = {...}")
    settings = data.get("validate")
    if not isinstance(settings, Mapping):
        raise ConfigError("the plan needs a [validate] table with illuminants, cameras and reflectance_sets")
    _check_keys("[validate]", settings, _VALIDATE_KEYS)
    illuminants = _string_list("validate.illuminants", settings.get("illuminants", ["D65"]))
    resolved = []
    for name in illuminants:
        if name.lower().endswith(".csv") and not Path(name).is_absolute():
            name = str((base_dir / name).resolve())
        spectra.illuminant(name)
        resolved.append(name)
    illuminants = tuple(resolved)
    cameras = _string_list("validate.cameras", settings.get("cameras", ["nikon_d850"]))
    for camera in cameras:
        if camera == "ideal":
            raise ConfigError("validate.cameras: 'ideal' has three identical channels and no colour; valid: "
                              + ", ".join(spectra.camera_names()))
        spectra.camera_sensitivities(camera)
    sets = tuple(reflectance_set(name, base_dir=base_dir)
                 for name in _string_list("validate.reflectance_sets", settings.get("reflectance_sets", ["colorchecker"])))
    chart = settings.get("chart", "synthetic")
    if chart not in CHART_SOURCES:
        raise ConfigError(f"validate.chart = {chart!r}; valid: {', '.join(CHART_SOURCES)}")
    if chart == "render" and any(s.name != "colorchecker" for s in sets):
        raise ConfigError("validate.chart = 'render' renders the ColorChecker preset only; use "
                          "reflectance_sets = ['colorchecker'] or chart = 'synthetic'")
    bands = settings.get("bands", "400:700:10")
    if not isinstance(bands, str):
        raise ConfigError(f"validate.bands = {bands!r}; give band centres 'start:stop:step' in nm")
    spectra.parse_bands(bands)
    swatches = settings.get("swatches", "all")
    if swatches not in SWATCH_MODES:
        raise ConfigError(f"validate.swatches = {swatches!r}; valid: {', '.join(SWATCH_MODES)}")
    thresholds_table = settings.get("thresholds", {})
    if not isinstance(thresholds_table, Mapping):
        raise ConfigError("validate.thresholds must be a table")
    _check_keys("[validate.thresholds]", thresholds_table, [f.name for f in dataclasses.fields(Thresholds)])
    thresholds = Thresholds(**thresholds_table)

    sections = {}
    for name in _SCENE_SECTIONS:
        table = data.get(name, {})
        if not isinstance(table, Mapping):
            raise ConfigError(f"[{name}] must be a table of key = value pairs")
        sections[name] = dict(table)
    if "spd" in sections["illuminant"]:
        raise ConfigError("[illuminant] spd comes from validate.illuminants; [illuminant] takes illuminance_lux only")
    if "model" in sections["sensor"]:
        raise ConfigError("[sensor] model comes from validate.cameras; remove it from [sensor]")
    if chart == "synthetic":
        fixed = [k for k in ("width_px", "height_px") if k in sections["sensor"]]
        if fixed:
            raise ConfigError(f"sensor.{fixed[0]} is set by the chart when validate.chart = 'synthetic'; "
                              "use validate.patch_px and validate.gap_px")
    base = scene_from_dict(sections, overrides={"sensor.model": cameras[0]}, base_dir=base_dir)

    exposures_data = data.get("exposure", [{}])
    if isinstance(exposures_data, Mapping):
        exposures_data = [exposures_data]
    if not isinstance(exposures_data, list) or not exposures_data:
        raise ConfigError("[[exposure]]: give one or more exposure tables")
    exposures = tuple(_exposure(table, i, base.exposure.iso) for i, table in enumerate(exposures_data))
    if len({e.name for e in exposures}) != len(exposures):
        raise ConfigError("[[exposure]] names must be unique: " + ", ".join(e.name for e in exposures))

    pipelines_data = data.get("pipeline")
    if isinstance(pipelines_data, Mapping):
        pipelines_data = [pipelines_data]
    if not isinstance(pipelines_data, list) or not pipelines_data:
        raise ConfigError("the plan needs at least one [[pipeline]] table (type = "
                          + " | ".join(repr(t) for t in PIPELINE_TYPES) + ")")
    pipelines = tuple(_pipeline(table, i, base_dir) for i, table in enumerate(pipelines_data))
    if len({p.name for p in pipelines}) != len(pipelines):
        raise ConfigError("[[pipeline]] names must be unique: " + ", ".join(p.name for p in pipelines))

    plan = Plan(illuminants=illuminants, cameras=cameras, reflectance_sets=sets, exposures=exposures,
                pipelines=pipelines, thresholds=thresholds, chart=chart, bands=bands,
                patch_px=settings.get("patch_px", 16), gap_px=settings.get("gap_px", 4), swatches=swatches,
                sections=sections, source=source, base_dir=str(base_dir))
    if chart == "synthetic":  # patch sizes are checked by building one chart's geometry
        for key in ("patch_px", "gap_px"):
            value = getattr(plan, key)
            if isinstance(value, bool) or not isinstance(value, int) or value < (4 if key == "patch_px" else 0):
                raise ConfigError(f"validate.{key} = {value!r}: must be a whole number of pixels "
                                  f">= {4 if key == 'patch_px' else 0}")
    for exposure in exposures:  # every cell's scene settings are valid
        plan.scene_config(illuminants[0], cameras[0], exposure)
    return plan


def load_plan(path: str | Path, overrides: Mapping[str, Any] | Sequence[str] | None = None) -> Plan:
    """Read a TOML validation plan, apply overrides and validate it.

    Parameters
    ----------
    path : str or path-like
        The plan file.
    overrides : mapping or list of str, optional
        ``{"validate.patch_px": 12}`` or ``["validate.patch_px=12", ...]``.

    Returns
    -------
    Plan

    Raises
    ------
    ConfigError
        If the file is missing, not TOML, or invalid (see :func:`plan_from_dict`).
    """
    from .scene import parse_override, read_toml

    path = Path(path)
    data = read_toml(path, "plan file")
    if isinstance(overrides, (list, tuple)):
        overrides = dict(parse_override(item) for item in overrides)
    return plan_from_dict(data, base_dir=path.resolve().parent, source=str(path), overrides=overrides)


# ============================================================================ metrics
def angular_error_deg(test_rgb, reference_rgb) -> float:
    """Angle between two RGB vectors, degrees (the recovery angular error).

    Parameters
    ----------
    test_rgb, reference_rgb : array_like
        (3,) linear RGB.

    Returns
    -------
    float
        arccos(a·b / (|a||b|)) in degrees (NaN when a vector is zero).

    References
    ----------
    .. [1] Hordley & Finlayson (2006), JOSA A 23(5), 1008–1020.
    """
    a = np.asarray(test_rgb, dtype=float)
    b = np.asarray(reference_rgb, dtype=float)
    norm = np.linalg.norm(a) * np.linalg.norm(b)
    if not norm > 0:
        return float("nan")
    return float(np.degrees(np.arccos(np.clip(a @ b / norm, -1.0, 1.0))))


def evaluate_patches(linear: np.ndarray, chart: Chart, reference: np.ndarray) -> dict:
    """Patch statistics of a pipeline's linear sRGB image against the ground truth.

    Parameters
    ----------
    linear : numpy.ndarray
        (H, W, 3) linear sRGB, unclipped, the chart's size.
    chart : Chart
    reference : numpy.ndarray
        (N, 3) ground-truth linear sRGB of every chart patch (perfect diffuser Y = 1).

    Returns
    -------
    dict
        ``test`` (N, 3) exposure-matched patch means, ``delta_e`` (N,) ΔE2000,
        ``snr`` (N,) mean/σ of Y, ``wb_angular_error_deg``, ``exposure_scale``, and the
        set statistics ``delta_e_mean``, ``delta_e_p95``, ``delta_e_max``, ``snr_median``,
        ``snr_min``.

    Raises
    ------
    ConfigError
        If the image is the wrong size or black at the white reference.

    References
    ----------
    .. [1] Sharma, Wu & Dalal (2005) (CIEDE2000); ISO 15739:2017 (SNR); Hordley & Finlayson
       (2006) (angular error).
    """
    import colour

    from .metrics.image_quality import delta_e2000, patch_means

    height, width = chart.radiance.data.shape[:2]
    if linear.shape != (height, width, 3):
        raise ConfigError(f"the pipeline's image is {linear.shape}; the chart needs ({height}, {width}, 3) — "
                          "a pipeline must return the whole frame, uncropped and unrotated")
    weights = np.asarray(colour.models.RGB_COLOURSPACE_sRGB.matrix_RGB_to_XYZ)[1]
    means = patch_means(linear, chart.patches, margin=PATCH_MARGIN)
    w = chart.white_index
    y_test = float(means[w] @ weights)
    if not y_test > 0:
        raise ConfigError("the pipeline's image is black (or negative) at the white reference")
    scale = float(reference[w] @ weights) / y_test
    test = means * scale
    delta = delta_e2000(test, reference)
    snr = np.empty(len(chart.patches))
    for i, patch in enumerate(chart.patches):
        luminance = linear[patch.interior(PATCH_MARGIN)].reshape(-1, 3) @ weights
        sigma = float(np.std(luminance, ddof=1)) if luminance.size > 1 else 0.0
        snr[i] = float(np.mean(luminance)) / sigma if sigma > 0 else math.inf
    n = chart.n_set
    return {
        "test": test,
        "delta_e": delta,
        "snr": snr,
        "exposure_scale": scale,
        "wb_angular_error_deg": angular_error_deg(test[w], reference[w]),
        "delta_e_mean": float(np.mean(delta[:n])),
        "delta_e_p95": float(np.percentile(delta[:n], 95)),
        "delta_e_max": float(np.max(delta[:n])),
        "snr_median": float(np.median(snr[:n])),
        "snr_min": float(np.min(snr[:n])),
    }


# ============================================================================ running
@dataclass
class CellResult:
    """One pipeline on one illuminant × camera × exposure × reflectance set.

    Attributes
    ----------
    set_name, illuminant, camera, exposure, pipeline : str
        The cell's coordinates.
    status : str
        ``"pass"``, ``"fail"`` (a threshold broken) or ``"error"`` (the pipeline failed).
    failures : list of str
        Broken criteria, or the error message.
    patch_names : list of str
        Every chart patch (the set's first ``n_set``).
    n_set, white_index : int
    reference, test : numpy.ndarray or None
        (N, 3) ground truth and exposure-matched pipeline linear sRGB.
    delta_e, snr : numpy.ndarray or None
        (N,) ΔE2000 and SNR per patch.
    stats : dict
        ``delta_e_mean``, ``delta_e_p95``, ``delta_e_max``, ``wb_angular_error_deg``,
        ``snr_median``, ``snr_min``, ``exposure_scale``.
    exposure_s, iso, gain_dn_per_e : float
        What the sensor did.
    runtime_s : float
        Seconds the pipeline took.
    dng : str
        The RAW the pipeline developed (relative to the report folder).
    """

    set_name: str
    illuminant: str
    camera: str
    exposure: str
    pipeline: str
    status: str
    failures: list
    patch_names: list
    n_set: int
    white_index: int
    reference: np.ndarray | None
    test: np.ndarray | None
    delta_e: np.ndarray | None
    snr: np.ndarray | None
    stats: dict
    exposure_s: float
    iso: float
    gain_dn_per_e: float
    runtime_s: float
    dng: str

    @property
    def key(self) -> tuple[str, str, str, str, str]:
        return (self.set_name, self.illuminant, self.camera, self.exposure, self.pipeline)


@dataclass
class ValidationResult:
    """Everything a plan run measured.

    Attributes
    ----------
    plan : Plan
    cells : list of CellResult
    elapsed_s : float
        Wall-clock seconds of the whole run.
    output_dir : pathlib.Path or None
        Where the report, CSVs and DNGs were written.
    versions : dict
        Python, LibRaw and package versions (:func:`spectral_cam.job.package_versions`).
    """

    plan: Plan
    cells: list
    elapsed_s: float
    output_dir: Path | None
    versions: dict

    @property
    def passed(self) -> bool:
        return all(cell.status == "pass" for cell in self.cells)

    def cell(self, **where: str) -> CellResult:
        """The one cell matching ``set_name=..., illuminant=..., camera=..., exposure=..., pipeline=...``."""
        found = [c for c in self.cells if all(getattr(c, k) == v for k, v in where.items())]
        if len(found) != 1:
            raise KeyError(f"{len(found)} cells match {where}")
        return found[0]


def _slug(text: str) -> str:
    text = Path(text).stem if str(text).lower().endswith(".csv") else str(text)
    return re.sub(r"[^A-Za-z0-9.+-]+", "_", text).strip("_") or "x"


def _exposure_mask(chart: Chart, camera: str, illuminant: str, transmission) -> np.ndarray:
    """Interior of the patch with the largest camera response (normally the white)."""
    from .sensor import calibration

    responses = calibration.camera_responses(camera, illuminant, chart.sds, transmission=transmission)
    brightest = int(np.argmax(responses.max(axis=1)))
    if responses.max(axis=1)[brightest] <= responses.max(axis=1)[chart.white_index] * (1 + 1e-9):
        brightest = chart.white_index
    height, width = chart.radiance.data.shape[:2]
    mask = np.zeros((height, width), dtype=bool)
    mask[chart.patches[brightest].interior(PATCH_MARGIN)] = True
    return mask


def _transmissions(config) -> list:
    from . import spectra

    return [t for t in (spectra.transmission(config.lens.transmission), spectra.transmission(config.sensor.ir_cut))
            if t is not None] or None


def run_plan(plan: Plan, output_dir: str | Path | None = None, *, force: bool = False,
             progress: Callable[[str], None] | None = None) -> ValidationResult:
    """Run every cell of a plan; write the report, CSVs and DNGs into ``output_dir``.

    Parameters
    ----------
    plan : Plan
    output_dir : str or path-like, optional
        Report folder (written atomically: it appears complete or not at all); None runs
        in a temporary folder and writes nothing.
    force : bool
        Replace an existing ``output_dir``.
    progress : callable, optional
        Called with one line of text per finished cell.

    Returns
    -------
    ValidationResult

    Raises
    ------
    ConfigError
        If ``output_dir`` exists without ``force``. A pipeline that fails does not stop
        the run: its cells get status ``"error"`` with the message.

    References
    ----------
    .. [1] See the module docstring (ground truth, ΔE2000, angular error, SNR).
    """
    from . import colorimetry
    from .io import staged_directory
    from .raw import write_dng
    from .sensor import expose

    started = time.perf_counter()
    from .job import package_versions

    versions = package_versions()
    cells: list[CellResult] = []
    if output_dir is None:
        holder = tempfile.TemporaryDirectory(prefix="spectral-cam-validate-")
        context = _NullStage(Path(holder.name))
    else:
        holder = None
        context = staged_directory(output_dir, force=force)
    total = (len(plan.reflectance_sets) * len(plan.illuminants) * len(plan.cameras) * len(plan.exposures)
             * len(plan.pipelines))
    try:
        with context as stage:
            raw_dir = stage / "raw"
            raw_dir.mkdir(parents=True, exist_ok=True)
            work_dir = Path(tempfile.mkdtemp(prefix=".work-", dir=stage))
            render_cache: dict = {}
            for refset in plan.reflectance_sets:
                for illuminant in plan.illuminants:
                    synthetic = None
                    if plan.chart == "synthetic":
                        synthetic = synthetic_chart(refset, illuminant, illuminance_lux=plan.illuminance_lux,
                                                    bands=plan.bands, patch_px=plan.patch_px, gap_px=plan.gap_px)
                        reference = colorimetry.patch_linear_srgb(illuminant, synthetic.sds)
                    for camera in plan.cameras:
                        for exposure in plan.exposures:
                            chart = synthetic
                            if chart is None:
                                config = plan.scene_config(illuminant, camera, exposure)
                                key = _render_key(config, illuminant, camera, exposure)
                                if key not in render_cache:
                                    render_cache[key] = rendered_chart(config)
                                chart = render_cache[key]
                                reference = colorimetry.patch_linear_srgb(illuminant, chart.sds)
                            config = plan.scene_config(illuminant, camera, exposure, chart)
                            mask = _exposure_mask(chart, camera, illuminant, _transmissions(config))
                            raw = expose(chart.radiance, config, white_mask=mask)
                            # positions keep names unique (two CSVs may share a file name)
                            dng_name = (f"{plan.reflectance_sets.index(refset):02d}-{_slug(refset.name)}__"
                                        f"{plan.illuminants.index(illuminant):02d}-{_slug(illuminant)}__"
                                        f"{_slug(camera)}__{plan.exposures.index(exposure):02d}-"
                                        f"{_slug(exposure.name)}.dng")
                            dng_path = write_dng(raw, raw_dir / dng_name)
                            for pipeline in plan.pipelines:
                                cell = _run_cell(pipeline, raw, dng_path, work_dir, chart, reference, plan,
                                                 refset.name, illuminant, camera, exposure, f"raw/{dng_name}")
                                cells.append(cell)
                                if progress is not None:
                                    progress(_progress_line(cell, len(cells), total))
            shutil.rmtree(work_dir, ignore_errors=True)
            result = ValidationResult(plan, cells, time.perf_counter() - started,
                                      Path(output_dir) if output_dir is not None else None, versions)
            if output_dir is not None:
                from .report import write_report

                (stage / "plan.json").write_text(json.dumps({"plan": plan.to_dict(), "versions": versions},
                                                            indent=2, default=str) + "\n", encoding="utf-8")
                write_report(result, stage)
    finally:
        if holder is not None:
            holder.cleanup()
    result.elapsed_s = time.perf_counter() - started
    return result


class _NullStage:
    """A staging context for runs that keep nothing."""

    def __init__(self, path: Path):
        self.path = path

    def __enter__(self) -> Path:
        return self.path

    def __exit__(self, *exc) -> None:
        return None


def _render_key(config, illuminant: str, camera: str, exposure: ExposureSpec) -> tuple:
    """Renders are shared by cameras and exposures unless the film holds the camera's own
    curves, or ``spp = "auto"`` sizes the render by the sensor's noise at the exposure."""
    render = config.render
    bands = getattr(render, "bands", "400:700:10")
    camera_film = bands == "camera" or (bands == "auto" and not getattr(render, "spectral_output", True))
    auto_spp = render.spp == "auto"
    return (illuminant, camera if camera_film or auto_spp else None, exposure.name if auto_spp else None)


def _run_cell(pipeline, raw, dng_path: Path, work_dir: Path, chart: Chart, reference: np.ndarray, plan: Plan,
              set_name: str, illuminant: str, camera: str, exposure: ExposureSpec, dng: str) -> CellResult:
    names = [p.name for p in chart.patches]
    meta = raw.meta or {}
    common = dict(set_name=set_name, illuminant=illuminant, camera=camera, exposure=exposure.name,
                  pipeline=pipeline.name, patch_names=names, n_set=chart.n_set, white_index=chart.white_index,
                  reference=reference, exposure_s=float(meta.get("exposure_s", float("nan"))),
                  iso=float(meta.get("iso", exposure.iso)), gain_dn_per_e=float(meta.get("K_dn_per_e", float("nan"))),
                  dng=dng)
    t0 = time.perf_counter()
    try:
        linear = pipeline.develop(raw, dng_path, work_dir)
        runtime = time.perf_counter() - t0
        measured = evaluate_patches(np.asarray(linear, dtype=np.float64), chart, reference)
    except Exception as exc:  # a user's pipeline may fail in any way; record it, go on
        message = str(exc) if isinstance(exc, SpectralCamError) else f"{type(exc).__name__}: {exc}"
        return CellResult(status="error", failures=[message], test=None, delta_e=None, snr=None, stats={},
                          runtime_s=time.perf_counter() - t0, **common)
    stats = {k: measured[k] for k in ("delta_e_mean", "delta_e_p95", "delta_e_max", "wb_angular_error_deg",
                                      "snr_median", "snr_min", "exposure_scale")}
    failures = plan.thresholds.failures(stats)
    return CellResult(status="fail" if failures else "pass", failures=failures, test=measured["test"],
                      delta_e=measured["delta_e"], snr=measured["snr"], stats=stats, runtime_s=runtime, **common)


def _progress_line(cell: CellResult, done: int, total: int) -> str:
    where = f"[{done}/{total}] {cell.set_name} · {cell.illuminant} · {cell.camera} · {cell.exposure} · {cell.pipeline}"
    if cell.status == "error":
        return f"{where}: ERROR {cell.failures[0]}"
    s = cell.stats
    return (f"{where}: ΔE00 mean {s['delta_e_mean']:.2f}, p95 {s['delta_e_p95']:.2f}, max {s['delta_e_max']:.2f}; "
            f"WB {s['wb_angular_error_deg']:.2f}°  {cell.status.upper()}")


# ============================================================================ --self
@dataclass
class CheckResult:
    """One physics self-check: a measured value against a reference and a tolerance.

    Attributes
    ----------
    check : str
        What is checked.
    quantity : str
        The measured quantity, with its unit.
    measured, reference, tolerance : float
        Pass when ``|measured − reference| ≤ tolerance`` (``tolerance`` relative to the
        reference when ``relative``).
    relative : bool
    seconds : float
        Time the check took (shared checks report their first row's time).
    """

    check: str
    quantity: str
    measured: float
    reference: float
    tolerance: float
    relative: bool = False
    seconds: float = 0.0

    @property
    def passed(self) -> bool:
        limit = self.tolerance * (abs(self.reference) if self.relative else 1.0)
        return bool(np.isfinite(self.measured) and abs(self.measured - self.reference) <= limit)

    @property
    def tolerance_text(self) -> str:
        return f"±{self.tolerance * 100:g} %" if self.relative else f"±{self.tolerance:g}"


def _render_fields() -> set[str]:
    from .scene import RenderSection

    return {f.name for f in dataclasses.fields(RenderSection)}


def _render_table(**values) -> dict:
    """A [render] table with the explicit spectral settings the checks need."""
    table = {"bands": "400:700:10", "diffraction": "off", **values}
    if "spectral_output" in _render_fields():
        table["spectral_output"] = True
    return table


def _check_radiometry() -> list[CheckResult]:
    """Band radiance of a rendered ρ = 0.5 Lambertian plane under D65 at 1000 lx against
    colour-science's illuminant and photometry (L = ρE/π, E scaled by ``luminous_flux``)."""
    import colour

    from .render import render
    from .scene import scene_from_dict

    t0 = time.perf_counter()
    lux, rho = 1000.0, 0.5
    config = scene_from_dict({
        "scene": {"preset": "flat_field", "reflectance": rho, "distance_m": 2.0},
        "illuminant": {"spd": "D65", "illuminance_lux": lux},
        "lens": {"model": "pinhole"},
        "sensor": {"width_px": 8, "height_px": 8, "pixel_pitch_um": 100.0},
        "render": _render_table(spp=1 << 14, max_depth=2, seed=3),
    })
    image = render(config, with_depth=False)
    measured = image.data.reshape(-1, image.data.shape[-1]).astype(np.float64).mean(axis=0)
    shape = colour.SpectralShape(360, 830, 1)
    spd = colour.SDS_ILLUMINANTS["D65"].copy().align(shape, interpolator=colour.LinearInterpolator)
    spd = spd * (lux / colour.luminous_flux(spd))
    radiance = rho * np.asarray(spd.values) / np.pi
    expected = []
    for lo, hi in zip(image.band_edges_nm[:-1], image.band_edges_nm[1:]):
        fine = np.linspace(lo, hi, 101)
        expected.append(np.trapezoid(np.interp(fine, shape.wavelengths, radiance), fine))
    relative = measured / np.asarray(expected) - 1.0
    seconds = time.perf_counter() - t0
    return [
        CheckResult("radiometry vs colour-science", "worst of 31 band radiances, error (%)",
                    float(np.max(np.abs(relative)) * 100), 0.0, 1.5, seconds=seconds),
        CheckResult("radiometry vs colour-science", "mean band radiance error, bias (%)",
                    float(np.mean(relative) * 100), 0.0, 0.3),
    ]


def _check_thin_lens() -> list[CheckResult]:
    """Defocus blur of a point source against the thin-lens circle of confusion
    c = A·f·|z − z_f| / (z·(z_f − f)) (second moment of the blur disc = c²/8)."""
    from .optics import ThinLens
    from .render import render
    from .scene import scene_from_dict

    t0 = time.perf_counter()
    focal_m, f_number, focus_m, pitch_m, size, depth = 0.05, 2.0, 2.0, 10e-6, 48, 3.0
    image_distance = 1.0 / (1.0 / focal_m - 1.0 / focus_m)
    source_px = 3.0
    config = scene_from_dict({
        "scene": {"preset": "point_sources", "depths_m": [depth],
                  "source_radius_m": source_px * pitch_m * depth / image_distance},
        "lens": {"focal_length_mm": focal_m * 1e3, "f_number": f_number, "focus_distance_m": focus_m, "model": "thin"},
        "sensor": {"width_px": size, "height_px": size, "pixel_pitch_um": pitch_m * 1e6},
        "render": _render_table(spp=512, max_depth=2, seed=0),
    })
    image = render(config, with_depth=False)
    weights = image.data.sum(axis=-1).astype(np.float64)
    rows, cols = np.indices(weights.shape)
    total = weights.sum()
    cx = (weights * (cols + 0.5)).sum() / total
    cy = (weights * (rows + 0.5)).sum() / total
    m2 = (weights * ((cols + 0.5 - cx) ** 2 + (rows + 0.5 - cy) ** 2)).sum() / total
    measured = math.sqrt(max(8.0 * (m2 - source_px ** 2 / 2 - 2 / 12), 0.0))
    lens = ThinLens.from_config(config.lens, config.sensor)
    return [CheckResult("thin-lens CoC", f"blur diameter at z = {depth:g} m, focus {focus_m:g} m (px)",
                        measured, float(lens.coc_diameter_px(depth)), 0.02, relative=True,
                        seconds=time.perf_counter() - t0)]


def _narrow_band_image(size: int, radiance: float, wavelength_nm: float):
    from .image import SpectralImage

    centres = np.arange(400.0, 701.0, 10.0)
    edges = np.append(centres - 5.0, centres[-1] + 5.0)
    data = np.zeros((size, size, len(centres)), np.float32)
    data[..., int(np.argmin(abs(centres - wavelength_nm)))] = radiance
    return SpectralImage(data, centres, edges)


def _photons_per_radiance(config, wavelength_nm: float, exposure_s: float) -> float:
    """μ_p per unit band radiance: π/(1 + 4N_w²)·A·t·λ/(h·c) (EMVA 1288 §2.1 with the
    camera equation of the design)."""
    import scipy.constants as const

    from .optics import ThinLens

    n_w = ThinLens.from_config(config.lens, config.sensor).working_f_number
    area = (config.sensor.pixel_pitch_um * 1e-6) ** 2
    return math.pi / (1 + 4 * n_w ** 2) * area * exposure_s * wavelength_nm * 1e-9 / (const.h * const.c)


def _check_shot_noise() -> list[CheckResult]:
    """σ_e = √μ_e: temporal noise of flat-field pairs on a noiseless-electronics sensor."""
    from .scene import scene_from_dict
    from .sensor import expose

    t0 = time.perf_counter()
    t_s, size = 0.01, 128
    config = scene_from_dict({
        "sensor": {"model": "ideal", "cfa": "none", "width_px": size, "height_px": size, "read_noise_e": 0.0,
                   "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0, "bit_depth": 16,
                   "full_well_e": 100000.0, "black_level_dn": 256, "peak_qe": 0.5, "vignetting": False},
        "exposure": {"time_s": t_s, "iso": 100.0},
    })
    per_radiance = _photons_per_radiance(config, 550.0, t_s)
    means, sigmas = [], []
    for index, electrons in enumerate((100.0, 1000.0, 10000.0, 50000.0)):
        flat = _narrow_band_image(size, electrons / 0.5 / per_radiance, 550.0)
        a = expose(flat, config, frame_seed=2 * index + 1)
        b = expose(flat, config, frame_seed=2 * index + 2)
        gain = a.meta["K_dn_per_e"]
        fa, fb = a.mosaic.astype(np.float64), b.mosaic.astype(np.float64)
        means.append(((fa + fb) / 2 - a.black_level).mean() / gain)
        sigmas.append(math.sqrt(max(np.var(fa - fb) / 2 - 1 / 12, 0.0)) / gain)
    slope = float(np.polyfit(np.log(means), np.log(sigmas), 1)[0])
    ratio = sigmas[2] ** 2 / means[2]
    seconds = time.perf_counter() - t0
    return [
        CheckResult("√n law (shot noise)", "slope d ln σ_e / d ln μ_e, 10²–5·10⁴ e⁻", slope, 0.5, 0.01,
                    seconds=seconds),
        CheckResult("√n law (shot noise)", "σ_e² / μ_e at 10⁴ e⁻", float(ratio), 1.0, 0.03),
    ]


def _check_monte_carlo() -> list[CheckResult]:
    """Monte-Carlo noise of the render falls as spp^(-1/2) (independent samples)."""
    from .render import render
    from .scene import scene_from_dict

    t0 = time.perf_counter()
    spread = []
    counts = (16, 256)
    for spp in counts:
        config = scene_from_dict({
            "scene": {"preset": "flat_field", "reflectance": 0.5},
            "lens": {"model": "pinhole"},
            "sensor": {"width_px": 32, "height_px": 32, "pixel_pitch_um": 100.0},
            "render": _render_table(spp=spp, max_depth=2, seed=11),
        })
        data = render(config, with_depth=False).data.astype(np.float64)
        spread.append(float(np.mean(data.std(axis=(0, 1), ddof=1) / data.mean(axis=(0, 1)))))
    slope = math.log(spread[1] / spread[0]) / math.log(counts[1] / counts[0])
    return [CheckResult("√n law (Monte Carlo)", "slope d ln σ / d ln spp, 16–256 spp", slope, -0.5, 0.05,
                        seconds=time.perf_counter() - t0)]


def _check_emva() -> list[CheckResult]:
    """EMVA 1288 photon transfer of simulated flat fields recovers the sensor's settings."""
    from .metrics.emva1288 import photon_transfer
    from .scene import scene_from_dict
    from .sensor import expose

    t0 = time.perf_counter()
    size, t_s, read_e, dark_e_per_s, dsnu_e, prnu, qe = 128, 0.1, 3.0, 50.0, 2.0, 0.005, 0.7
    config = scene_from_dict({
        "sensor": {"model": "ideal", "cfa": "none", "width_px": size, "height_px": size, "pixel_pitch_um": 5.0,
                   "read_noise_e": read_e, "dark_current_e_per_s": dark_e_per_s, "dsnu_e": dsnu_e, "prnu": prnu,
                   "peak_qe": qe, "bit_depth": 14, "full_well_e": 20000.0, "black_level_dn": 256,
                   "vignetting": False, "seed": 7},
        "exposure": {"time_s": t_s, "iso": 100.0},
        "lens": {"f_number": 4.0},
    })
    k_ref = (2 ** 14 - 1 - 256) / 20000.0
    sigma_ref = math.sqrt(read_e ** 2 + dark_e_per_s * t_s)
    saturation_photons = 20000.0 / qe
    # dense 0.5 % steps around saturation, where the variance peak that defines μ_e.sat
    # (EMVA 1288 §6.5; a little below the full well, as PRNU and shot noise make some
    # pixels clip first) must be resolved
    levels = np.concatenate([np.linspace(0.004, 0.05, 4), np.linspace(0.06, 0.88, 12),
                             np.linspace(0.9, 1.2, 61)]) * saturation_photons
    per_radiance = _photons_per_radiance(config, 550.0, t_s)
    pairs = []
    for i, photons in enumerate(levels):
        flat = _narrow_band_image(size, photons / per_radiance, 550.0)
        pairs.append((expose(flat, config, frame_seed=2 * i + 1), expose(flat, config, frame_seed=2 * i + 2)))
    dark = _narrow_band_image(size, 0.0, 550.0)
    dark_pairs = [(expose(dark, config, frame_seed=10_001), expose(dark, config, frame_seed=10_002))]
    dark_stack = [expose(dark, config, frame_seed=20_000 + i) for i in range(16)]
    half = _narrow_band_image(size, 0.5 * saturation_photons / per_radiance, 550.0)
    bright_stack = [expose(half, config, frame_seed=30_000 + i) for i in range(16)]
    result = photon_transfer(pairs, dark_pairs, photons_per_pixel=levels, dark_stack=dark_stack,
                             bright_stack=bright_stack)
    seconds = time.perf_counter() - t0
    name = "EMVA 1288 round trip"
    return [
        CheckResult(name, "system gain K (DN/e⁻)", result.gain, k_ref, 0.03, relative=True, seconds=seconds),
        CheckResult(name, "dark noise σ_d (e⁻)", result.sigma_d_e, sigma_ref, 0.05, relative=True),
        CheckResult(name, "quantum efficiency η at 550 nm", float(result.quantum_efficiency[0]), qe, 0.03,
                    relative=True),
        CheckResult(name, "saturation capacity (e⁻)", result.saturation_e, 20000.0, 0.05, relative=True),
        CheckResult(name, "DSNU (e⁻)", float(result.dsnu_e), dsnu_e, 0.1, relative=True),
        CheckResult(name, "PRNU (fraction)", float(result.prnu), prnu, 0.1, relative=True),
    ]


def _noise_free_chart_raw(camera: str = "nikon_d850", illuminant: str = "D65"):
    from .scene import scene_from_dict
    from .sensor import expose

    refset = reflectance_set("colorchecker")
    chart = synthetic_chart(refset, illuminant, patch_px=16, gap_px=4)
    height, width = chart.radiance.data.shape[:2]
    config = scene_from_dict({
        "illuminant": {"spd": illuminant},
        "sensor": {"model": camera, "width_px": width, "height_px": height, "shot_noise": False,
                   "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0,
                   "vignetting": False},
        "exposure": {"time_s": "auto", "auto_fraction": 0.8},
    })
    mask = np.zeros((height, width), dtype=bool)
    mask[chart.patches[chart.white_index].interior(PATCH_MARGIN)] = True
    return chart, expose(chart.radiance, config, white_mask=mask)


def _check_dng_libraw() -> list[CheckResult]:
    """Our DNG read by LibRaw: the mosaic bit for bit, AsShotNeutral, ColorMatrix1, and
    LibRaw's own development against ours with the DNG matrix."""
    import rawpy

    from . import colorimetry
    from .isp import ISPConfig, develop
    from .metrics.image_quality import delta_e2000, patch_means
    from .raw import read_raw, write_dng

    t0 = time.perf_counter()
    chart, raw = _noise_free_chart_raw()
    with tempfile.TemporaryDirectory(prefix="spectral-cam-self-") as folder:
        path = write_dng(raw, Path(folder) / "chart.dng")
        with rawpy.imread(str(path)) as handle:
            mosaic = np.array(handle.raw_image_visible, copy=True)  # a view dies with the handle
            multipliers = np.asarray(handle.camera_whitebalance[:3], dtype=float)
            xyz = handle.postprocess(use_camera_wb=True, output_color=rawpy.ColorSpace.XYZ, gamma=(1, 1),
                                     no_auto_bright=True, adjust_maximum_thr=0.0, output_bps=16, user_flip=0,
                                     demosaic_algorithm=rawpy.DemosaicAlgorithm.AHD).astype(np.float64) / 65535.0
        back = read_raw(path)
    same_shape = mosaic.shape == raw.mosaic.shape
    max_dn = float(np.max(np.abs(mosaic.astype(np.int64) - raw.mosaic.astype(np.int64)))) if same_shape else math.inf
    neutral = (1.0 / multipliers) / (1.0 / multipliers).max()
    libraw = patch_means(colorimetry.xyz_to_linear_srgb(xyz), chart.patches, margin=PATCH_MARGIN)
    ours = patch_means(develop(raw, ISPConfig(colour_matrix="dng", demosaic="menon2007", tone="linear",
                                              highlights="none")).linear, chart.patches, margin=PATCH_MARGIN)
    ours_scaled = ours * (libraw[chart.white_index] @ _y_weights()) / (ours[chart.white_index] @ _y_weights())
    agreement = delta_e2000(ours_scaled, libraw)
    seconds = time.perf_counter() - t0
    name = "DNG / LibRaw agreement"
    return [
        CheckResult(name, "mosaic read back by LibRaw, max |ΔDN|", max_dn, 0.0, 0.0, seconds=seconds),
        CheckResult(name, "AsShotNeutral via LibRaw, max relative error",
                    float(np.max(np.abs(neutral / raw.as_shot_neutral - 1))), 0.0, 1e-5),
        CheckResult(name, "ColorMatrix1 via LibRaw, max |error|",
                    float(np.max(np.abs(back.color_matrix - raw.color_matrix))), 0.0, 2e-4),
        CheckResult(name, "LibRaw vs our ISP (DNG matrix), mean ΔE2000", float(np.mean(agreement)), 0.0, 1.0),
    ]


def _y_weights() -> np.ndarray:
    import colour

    return np.asarray(colour.models.RGB_COLOURSPACE_sRGB.matrix_RGB_to_XYZ)[1]


def _check_colour_chain() -> list[CheckResult]:
    """Ground truth by two integrations, and the noise-free chain (synthetic chart →
    sensor → our ISP, fitted 3×3) against the same matrix on spectrally integrated
    camera responses."""
    import colour

    from .sensor import calibration
    from . import colorimetry
    from .isp import ISPConfig, develop
    from .metrics.image_quality import delta_e2000, patch_means

    t0 = time.perf_counter()
    reference = colorimetry.patch_linear_srgb("A")
    white = calibration.illuminant_white_xyz("A")
    d65 = colour.xy_to_XYZ(colour.models.RGB_COLOURSPACE_sRGB.whitepoint)
    cat = np.asarray(colour.adaptation.matrix_chromatic_adaptation_VonKries(white, d65, "Bradford"))
    other = colorimetry.xyz_to_linear_srgb(calibration.reflectance_xyz("A") @ cat.T)
    routes = float(np.max(delta_e2000(other, reference)))
    chart, raw = _noise_free_chart_raw()
    reference = colorimetry.patch_linear_srgb("D65")
    matrix = calibration.camera_to_xyz_d65("nikon_d850", "D65")
    linear = develop(raw, ISPConfig(colour_matrix="fitted", demosaic="menon2007", tone="linear",
                                    highlights="none"), camera_to_xyz=matrix).linear
    chain = delta_e2000(patch_means(linear, chart.patches, margin=PATCH_MARGIN), reference,
                        exposure_match_index=chart.white_index)
    balanced = calibration.camera_responses("nikon_d850", "D65") / calibration.camera_responses(
        "nikon_d850", "D65", [1.0])[0]
    analytic = delta_e2000(colorimetry.xyz_to_linear_srgb(balanced @ matrix.T), reference,
                           exposure_match_index=chart.white_index)
    seconds = time.perf_counter() - t0
    return [
        CheckResult("ground truth", "two XYZ integrations + Bradford under A, max ΔE2000", routes, 0.0, 0.05,
                    seconds=seconds),
        CheckResult("colour chain (ColorChecker, D65)", "mean ΔE2000 through sensor + ISP minus analytic",
                    float(np.mean(chain) - np.mean(analytic)), 0.0, 0.1),
    ]


#: The --self checks, in the order they run.
SELF_CHECKS: dict[str, Callable[[], list[CheckResult]]] = {
    "radiometry": _check_radiometry,
    "thin_lens": _check_thin_lens,
    "shot_noise": _check_shot_noise,
    "monte_carlo": _check_monte_carlo,
    "emva1288": _check_emva,
    "dng_libraw": _check_dng_libraw,
    "colour_chain": _check_colour_chain,
}


def self_checks(names: Sequence[str] | None = None) -> list[CheckResult]:
    """Run the simulator's own physics checks (small and fast: seconds each).

    Parameters
    ----------
    names : sequence of str, optional
        Subset of :data:`SELF_CHECKS` (default all): ``radiometry`` (rendered band radiance
        of a Lambertian plane against colour-science), ``thin_lens`` (defocus blur against the
        circle of confusion), ``shot_noise`` and ``monte_carlo`` (the √n laws), ``emva1288``
        (photon-transfer round trip), ``dng_libraw`` (our DNG through LibRaw),
        ``colour_chain`` (ground-truth routes; sensor + ISP against analytic responses).

    Returns
    -------
    list of CheckResult

    Raises
    ------
    ConfigError
        For an unknown check name (listing the valid ones).

    References
    ----------
    .. [1] McCluney (2014) §1.6 (Lambert); Ray, Applied Photographic Optics, 3rd ed., ch. 10
       (CoC); EMVA 1288 Release 4.0; Adobe DNG Specification 1.7.1.0.
    """
    selected = list(SELF_CHECKS) if names is None else list(names)
    unknown = [n for n in selected if n not in SELF_CHECKS]
    if unknown:
        raise ConfigError(f"unknown self-check(s) {', '.join(unknown)}; valid: {', '.join(SELF_CHECKS)}")
    results: list[CheckResult] = []
    for name in selected:
        results.extend(SELF_CHECKS[name]())
    return results


def _number(value: float) -> str:
    if not np.isfinite(value):
        return str(value)
    if value == 0:
        return "0"
    magnitude = abs(value)
    return f"{value:.4g}" if 1e-3 <= magnitude < 1e5 else f"{value:.3e}"


def format_checks(results: Sequence[CheckResult]) -> str:
    """The self-checks as a plain-text table: check, quantity, measured, reference,
    tolerance, result."""
    header = ("check", "quantity", "measured", "reference", "tolerance", "result")
    rows = [(r.check, r.quantity, _number(r.measured), _number(r.reference), r.tolerance_text,
             "pass" if r.passed else "FAIL") for r in results]
    widths = [max(len(row[i]) for row in [header, *rows]) for i in range(len(header))]
    lines = ["  ".join(cell.ljust(widths[i]) if i < 2 else cell.rjust(widths[i]) if i < 5 else cell
                       for i, cell in enumerate(row)) for row in [header, *rows]]
    lines.insert(1, "  ".join("-" * w for w in widths))
    passed = sum(r.passed for r in results)
    lines.append(f"{passed}/{len(results)} checks pass")
    return "\n".join(lines)


def write_checks_csv(results: Sequence[CheckResult], path: str | Path) -> Path:
    """Write the self-checks as CSV (atomically)."""
    from .io import atomic_path

    path = Path(path)
    with atomic_path(path) as tmp:
        with tmp.open("w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle)
            writer.writerow(["check", "quantity", "measured", "reference", "tolerance", "tolerance_relative",
                             "passed", "seconds"])
            for r in results:
                writer.writerow([r.check, r.quantity, repr(float(r.measured)), repr(float(r.reference)),
                                 repr(float(r.tolerance)), r.relative, r.passed, f"{r.seconds:.3f}"])
    return path


# ============================================================================ CLI
def configure_parser(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``spectral-cam validate``."""
    parser.add_argument("plan", nargs="?", help="validation plan (.toml); see plans/validate_example.toml")
    parser.add_argument("-o", "--output", help="report folder: report.html, cells.csv, patches.csv, "
                        "plan.json, raw/*.dng (must not exist unless --force)")
    parser.add_argument("--self", dest="self_check", action="store_true",
                        help="run the simulator's own physics checks and print measured vs reference")
    parser.add_argument("--csv", help="with --self: also write the checks table as CSV")
    parser.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE",
                        help="override a plan key, e.g. --set validate.patch_px=12 (repeatable)")
    parser.add_argument("--force", action="store_true", help="replace an existing report folder")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``spectral-cam validate``.

    Returns
    -------
    int
        0 when every cell (or self-check) passes, 1 when some fail; user errors raise
        :class:`ConfigError` (exit status 2 from the CLI).
    """
    if args.self_check:
        if args.plan or args.output or args.set:
            raise ConfigError("--self takes no plan, -o or --set; run it on its own (optionally with --csv PATH)")
        if args.csv and Path(args.csv).exists() and not args.force:
            raise ConfigError(f"{args.csv} exists; pass --force to overwrite it")
        started = time.perf_counter()
        results = self_checks()
        print(format_checks(results))
        if not args.quiet:
            print(f"({time.perf_counter() - started:.1f} s)", file=sys.stderr)
        if args.csv:
            write_checks_csv(results, args.csv)
        return 0 if all(r.passed for r in results) else 1
    if not args.plan or not args.output:
        raise ConfigError("give a plan and an output folder: spectral-cam validate PLAN.toml -o REPORT_DIR "
                          "(or --self)")
    if args.csv:
        raise ConfigError("--csv belongs to --self; a plan run writes cells.csv and patches.csv into -o")
    plan = load_plan(args.plan, overrides=args.set or [])
    progress = None if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    result = run_plan(plan, args.output, force=args.force, progress=progress)
    failed = [c for c in result.cells if c.status != "pass"]
    if not args.quiet:
        print(f"wrote {args.output}/report.html: {len(result.cells) - len(failed)}/{len(result.cells)} cells pass "
              f"in {result.elapsed_s:.1f} s", file=sys.stderr)
    return 0 if not failed else 1
