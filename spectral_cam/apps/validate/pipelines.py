"""Pipelines under test: the :data:`PIPELINES` registry of pipeline types a plan's ``[[pipeline]]``
``type`` may name.

- ``ours``: :func:`spectral_cam.isp.develop` with any ISP settings (``isp = {...}``); its linear
  sRGB before the tone curve is measured. It develops the exposed RAW in memory, which carries
  the fitted colour corrections the ``"fitted"``/``"root_polynomial"`` colour matrices need (a
  DNG read back does not).
- ``rawpy``: LibRaw through rawpy, always linear (gamma 1), 16-bit, without auto brightening or
  LibRaw's maximum adjustment.
- ``callable``: ``function = "module:function"``, called as ``function(raw_path)`` — or
  ``function(raw_path, context)`` / ``function(raw_path, context=...)`` where it takes one, with
  the cell's :class:`CellContext` (chart layout, illuminant, camera, exposure) — and returning an
  (H, W, 3) array in the space ``output`` names (:data:`OUTPUT_SPACES`); integer arrays are
  scaled by their type's maximum (uint8 / 255, uint16 / 65535), as a command's files are;
  ``python_path`` lists folders (relative to the plan) to import it from.
- ``command``: ``command`` with ``{input}`` (the DNG) and ``{output}`` (a file with suffix
  ``output_suffix``, :data:`OUTPUT_SUFFIXES`) placeholders, run without a shell (placeholders
  substituted into the arguments as they are; quoted only in a ``sh -c`` script).

A pipeline type is one class registered with :func:`pipeline_type`, which names the plan keys
it accepts (besides ``name`` and ``type``); its constructor takes those keys as keyword
arguments and validates them. Plan parsing, ``plan.json`` and the error messages read the
registry (docs/design.md, "Registries").

References
----------
.. [1] rawpy API, ``RawPy.postprocess`` (LibRaw output parameters).
.. [2] docs/design.md, "Ground truth and metrics" (what is measured: ``.linear``, tone curve off).
"""

from __future__ import annotations

import abc
import contextlib
import functools
import importlib
import inspect
import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ...errors import ConfigError
from ...registry import Registry

__all__ = ["PIPELINES", "Pipeline", "CellContext", "pipeline_type", "OursPipeline", "RawpyPipeline", "CallablePipeline",
           "CommandPipeline", "OUTPUT_SPACES", "OUTPUT_SUFFIXES", "RAWPY_WHITE_BALANCE", "RAWPY_OUTPUT_COLOURS"]

#: Pipeline types: name → the class; its entry's ``options`` are the plan keys it accepts.
PIPELINES = Registry("pipeline type")
#: What a user pipeline returns: linear sRGB, CIE XYZ (D65-relative), sRGB-encoded values,
#: BT.709-encoded values (the same primaries, Rec. 709's OETF), ``"icc"`` (a command's file decoded
#: through the ICC profile it embeds, :mod:`~spectral_cam.apps.validate.icc`) or ``"gamma:<γ>"``
#: (sRGB primaries, a plain power law, e.g. ``"gamma:2.2"``).
OUTPUT_SPACES = ("linear_srgb", "xyz", "srgb", "bt709", "icc", "gamma:<γ>")
#: Files a command pipeline may write.
OUTPUT_SUFFIXES = (".npy", ".tif", ".tiff", ".png", ".exr")
#: LibRaw white balance: AsShotNeutral, LibRaw's automatic estimate, its daylight
#: multipliers (from the D65 matrix), or ``wb_gains``.
RAWPY_WHITE_BALANCE = ("camera", "auto", "daylight", "manual")
#: LibRaw output spaces measured (both relative to D65 in LibRaw).
RAWPY_OUTPUT_COLOURS = ("XYZ", "sRGB")
RAWPY_HIGHLIGHT_MODES = ("clip", "ignore", "blend", "reconstruct")
RAWPY_FBDD = ("off", "light", "full")


def pipeline_type(name: str, *, options: tuple[str, ...], description: str):
    """Class decorator: register a :class:`Pipeline` subclass in :data:`PIPELINES` under ``name``.

    Parameters
    ----------
    name : str
        The plan's ``type``.
    options : tuple of str
        Plan keys the type accepts besides ``name`` and ``type``: its constructor's keyword
        arguments and attributes (``plan.json`` lists them).
    description : str
        One line for messages.
    """

    def decorate(cls):
        cls.kind = name
        PIPELINES.add(name, cls, options=options, description=description)
        return cls

    return decorate


@dataclass(frozen=True)
class CellContext:
    """What a pipeline may know of the cell it develops (a callable's ``context``; a command's
    ``$SPECTRAL_CAM_CONTEXT`` JSON file): the chart's layout and what lit and exposed it.

    Attributes
    ----------
    set_name, illuminant, camera, exposure : str
        The cell's coordinates (the illuminant as the plan names it).
    frame_size : (int, int)
        (width, height) of the developed frame, pixels.
    patches : list of dict
        Every patch: ``name``, centre ``column``/``row`` and ``half_width_px``/``half_height_px``
        (pixels, 0 at the frame's top-left corner), ``role`` (``"patch"`` or
        ``"white reference"``).
    white_index : int
        The white reference's place in ``patches``: the metric scales exposure and measures
        white balance on it, so a pipeline that balances on it scores 0° there.
    exposure_s, iso : float
        What the sensor did.
    """

    set_name: str
    illuminant: str
    camera: str
    exposure: str
    frame_size: tuple
    patches: list
    white_index: int
    exposure_s: float
    iso: float

    def to_dict(self) -> dict:
        import dataclasses

        return dataclasses.asdict(self)


class Pipeline(abc.ABC):
    """A pipeline under test: turns one RAW into a linear sRGB image of the whole frame."""

    #: The registered type name (set by :func:`pipeline_type`).
    kind = ""
    #: Plan keys a type cannot do without → how to write them (for the error message).
    required: dict[str, str] = {}

    def __init__(self, name: str):
        self.name = name

    @classmethod
    def from_table(cls, name: str, options: Mapping[str, Any], *, base_dir: Path, where: str) -> "Pipeline":
        """The pipeline of a plan's ``[[pipeline]]`` table (``options``: its keys but ``name``
        and ``type``, already checked against the registry)."""
        for key, hint in cls.required.items():
            if key not in options:
                raise ConfigError(f"{where}: a {cls.kind} pipeline needs {hint}")
        return cls(name, **options)

    @abc.abstractmethod
    def develop(self, raw, dng_path: Path, workdir: Path, context: "CellContext | None" = None) -> np.ndarray:
        """Develop a RAW.

        Parameters
        ----------
        raw : RawImage
            The exposed RAW in memory (with the simulator's metadata).
        dng_path : pathlib.Path
            The same RAW written as a DNG.
        workdir : pathlib.Path
            A scratch folder.
        context : CellContext, optional
            What the cell is: the chart's layout, the illuminant, the camera, the exposure.

        Returns
        -------
        numpy.ndarray
            (H, W, 3) linear sRGB (D65), unclipped; any exposure scale.
        """

    @abc.abstractmethod
    def describe(self) -> str:
        """One line for the report."""

    def to_dict(self) -> dict:
        """JSON-friendly settings (for plan.json): name, type and every option of the type."""
        out: dict[str, Any] = {"name": self.name, "type": self.kind}
        for key in PIPELINES[self.kind].options:
            value = getattr(self, key)
            out[key] = value.to_dict() if hasattr(value, "to_dict") else list(value) if isinstance(value, tuple) \
                else value
        return out


@pipeline_type("ours", options=("isp",), description="spectral_cam's own ISP (isp = {...} settings)")
class OursPipeline(Pipeline):
    """spectral_cam's own ISP with the given :class:`~spectral_cam.isp.ISPConfig`.

    The measured image is :attr:`DevelopedImage.linear` (linear sRGB before tone curve and
    sharpening), so ΔE is measured with the tone curve off, as docs/design.md prescribes.
    """

    def __init__(self, name: str, *, isp=None):
        from ...isp import ISPConfig

        super().__init__(name)
        self.isp = ISPConfig() if isp is None else isp

    @classmethod
    def from_table(cls, name: str, options: Mapping[str, Any], *, base_dir: Path, where: str) -> "OursPipeline":
        from ...isp import ISPConfig

        isp = options.get("isp", {})
        if not isinstance(isp, Mapping):
            raise ConfigError(f"{where}: isp must be a table of ISP settings, e.g. isp = {{ demosaic = 'menon2007' }}")
        return cls(name, isp=ISPConfig.from_dict(dict(isp)))

    def develop(self, raw, dng_path: Path, workdir: Path, context: "CellContext | None" = None) -> np.ndarray:
        from ...isp import develop

        return np.asarray(develop(raw, self.isp).linear, dtype=np.float64)

    def describe(self) -> str:
        from ...isp import ISPConfig

        default = ISPConfig().to_dict()
        changed = {k: v for k, v in self.isp.to_dict().items() if default.get(k) != v}
        return "spectral_cam ISP" + (f" ({', '.join(f'{k}={v}' for k, v in changed.items())})" if changed else "")


def _choice(name: str, key: str, value: Any, valid: Sequence[str], *, fold: bool = False, note: str = "",
            after: str = "") -> str:
    """``value`` if it is one of ``valid`` (any case with ``fold``, then spelled as ``valid``
    spells it), else a :class:`ConfigError` listing the valid ones."""
    spelled = {(v.casefold() if fold else v): v for v in valid}
    key_of = str(value).casefold() if fold else value
    if not isinstance(key_of, str) or key_of not in spelled:
        raise ConfigError(f"pipeline {name!r}: {key} = {value!r}; valid{note}: {', '.join(valid)}{after}")
    return spelled[key_of]


@pipeline_type("rawpy", options=("demosaic", "white_balance", "wb_gains", "output_color", "highlight_mode",
                                 "fbdd_noise_reduction", "median_filter_passes"),
               description="LibRaw through rawpy, linear 16-bit output")
class RawpyPipeline(Pipeline):
    """LibRaw (rawpy) development of the DNG, linear 16-bit output, measured as is.

    References
    ----------
    .. [1] rawpy API, ``RawPy.postprocess`` (LibRaw output parameters).
    """

    def __init__(self, name: str, *, demosaic: str = "AHD", white_balance: str = "camera",
                 wb_gains: Sequence[float] = (), output_color: str = "XYZ", highlight_mode: str = "clip",
                 fbdd_noise_reduction: str = "off", median_filter_passes: int = 0):
        import rawpy

        super().__init__(name)
        supported = [a.name for a in rawpy.DemosaicAlgorithm if a.isSupported]
        self.demosaic = _choice(name, "demosaic", demosaic, supported, fold=True, note=" (this LibRaw)")
        self.white_balance = _choice(name, "white_balance", white_balance, RAWPY_WHITE_BALANCE)
        self.wb_gains = tuple(float(g) for g in wb_gains)
        if white_balance == "manual" and (len(self.wb_gains) != 3 or not all(g > 0 for g in self.wb_gains)):
            raise ConfigError(f"pipeline {name!r}: white_balance = 'manual' needs wb_gains = [r, g, b] (all > 0)")
        self.output_color = _choice(name, "output_color", output_color, RAWPY_OUTPUT_COLOURS, fold=True,
                                    after=" (LibRaw's D65-relative spaces)")
        self.highlight_mode = _choice(name, "highlight_mode", highlight_mode, RAWPY_HIGHLIGHT_MODES)
        self.fbdd_noise_reduction = _choice(name, "fbdd_noise_reduction", fbdd_noise_reduction, RAWPY_FBDD)
        if isinstance(median_filter_passes, bool) or not isinstance(median_filter_passes, int) \
                or not 0 <= median_filter_passes <= 10:
            raise ConfigError(f"pipeline {name!r}: median_filter_passes = {median_filter_passes!r}; "
                              "must be a whole number in 0..10")
        self.median_filter_passes = median_filter_passes

    def _postprocess_options(self) -> dict:
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

    def develop(self, raw, dng_path: Path, workdir: Path, context: "CellContext | None" = None) -> np.ndarray:
        import rawpy

        from ...colour_ground_truth import xyz_to_linear_srgb

        with rawpy.imread(str(dng_path)) as handle:
            _check_libraw_tile(raw.cfa, handle)
            image = handle.postprocess(**self._postprocess_options()).astype(np.float64) / 65535.0
        return xyz_to_linear_srgb(image) if self.output_color == "XYZ" else image

    def describe(self) -> str:
        import rawpy

        return (f"LibRaw {'.'.join(map(str, rawpy.libraw_version))} via rawpy "
                f"({self.demosaic}, wb {self.white_balance}, {self.output_color} output)")


def _libraw_tile(handle) -> list[str]:
    """The colour-filter tile LibRaw reads from an opened file, one string of colour letters per
    row (``raw_pattern`` through ``color_desc``; LibRaw calls an RGBW DNG's four colours GMCY)."""
    pattern = handle.raw_pattern
    if pattern is None:
        return []
    letters = bytes(handle.color_desc).decode("ascii", errors="replace")
    return ["".join(letters[int(i)] if int(i) < len(letters) else "?" for i in row) for row in np.asarray(pattern)]


def _check_libraw_tile(cfa: str, handle) -> None:
    """Refuse a RAW whose colour-filter tile LibRaw does not read as written: LibRaw maps a DNG's
    CFAPattern onto its 2×2 or X-Trans tables, so a Quad Bayer tile (4×4) comes back as a 2×2
    ``RR/GG`` and an RGBW tile as four other colours (GMCY); developing that scores the misread
    mosaic (mean ΔE2000 26–28), not the pipeline.

    Raises
    ------
    ConfigError
        Naming the tile the DNG holds and the one LibRaw reads.

    References
    ----------
    .. [1] LibRaw API, ``imgdata.idata.filters`` / ``xtrans`` (the CFA layouts it represents);
       Adobe DNG Specification 1.7.1.0, CFARepeatPatternDim, CFAPattern.
    """
    from ...cfa import MONOCHROME, cfa_pattern

    if str(cfa).lower() in (MONOCHROME, "linear"):
        return
    written = ["".join("RGBW"[int(i)] for i in row) for row in cfa_pattern(cfa)]
    read = _libraw_tile(handle)
    # LibRaw names Bayer's second green "G" too (color_desc "RGBG"); compare the letters
    if read != written:
        raise ConfigError(f"LibRaw cannot read this RAW's {cfa} colour filter tile ({len(written)}×{len(written[0])}: "
                          f"{' / '.join(written)}); it reads {' / '.join(read) or 'no tile'} — its image would "
                          "measure the misread mosaic, not a pipeline, so the cell is not scored. Develop this "
                          "sensor with type = 'ours' (or a program that reads the DNG's CFAPattern)")


def _output_space(name: str, key: str, value: Any) -> str:
    """``output`` checked: one of :data:`OUTPUT_SPACES`, ``"gamma:<γ>"`` with 0.2 ≤ γ ≤ 5."""
    if isinstance(value, str) and value.lower().startswith("gamma:"):
        try:
            gamma = float(value.split(":", 1)[1])
        except ValueError:
            gamma = float("nan")
        if not 0.2 <= gamma <= 5.0:
            raise ConfigError(f"pipeline {name!r}: {key} = {value!r}; give the gamma as a number in 0.2..5, "
                              "e.g. 'gamma:2.2'")
        return f"gamma:{gamma:g}"
    return _choice(name, key, value, OUTPUT_SPACES[:-1], after=", or 'gamma:<γ>' (e.g. 'gamma:2.2')")


def _to_linear_srgb(image, space: str) -> np.ndarray:
    """(H, W, 3) values in ``space`` → linear sRGB (unclipped).

    References
    ----------
    .. [1] IEC 61966-2-1:1999 (sRGB); ITU-R BT.709-6 (its OETF, inverted; the primaries are sRGB's).
    """
    import colour

    from ...colour_ground_truth import xyz_to_linear_srgb

    if space == "xyz":
        return xyz_to_linear_srgb(image)
    if space == "srgb":
        return np.asarray(colour.cctf_decoding(image, function="sRGB"), dtype=np.float64)
    if space == "bt709":
        return np.asarray(colour.models.oetf_inverse_BT709(image), dtype=np.float64)
    if space.startswith("gamma:"):
        return np.sign(image) * np.abs(image) ** float(space.split(":", 1)[1])
    return image


def _unit_range(array: np.ndarray) -> np.ndarray:
    """An image as float64 with integers scaled by their type's maximum (uint8 / 255, uint16 /
    65535), so 1 is full scale whatever the type a pipeline returns or writes."""
    if array.dtype == bool:
        raise ConfigError("a boolean image is not a developed image")
    if np.issubdtype(array.dtype, np.integer):
        return array.astype(np.float64) / float(np.iinfo(array.dtype).max)
    return array.astype(np.float64)


def _check_output(image, name: str) -> np.ndarray:
    try:
        array = _unit_range(np.asarray(image))
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"pipeline {name!r} returned something that is not a numeric array ({exc})") from None
    if array.ndim == 3 and array.shape[-1] == 4:
        array = array[..., :3]  # drop alpha
    if array.ndim != 3 or array.shape[-1] != 3:
        raise ConfigError(f"pipeline {name!r} returned shape {array.shape}; expected (H, W, 3)")
    if not np.all(np.isfinite(array)):
        raise ConfigError(f"pipeline {name!r} returned NaN or infinite values")
    return array


@pipeline_type("callable", options=("function", "output", "python_path"),
               description="a Python function(raw_path) -> (H, W, 3) array")
class CallablePipeline(Pipeline):
    """A user's Python function ``function(raw_path) -> (H, W, 3) array``.

    The function is called as ``function(raw_path)``, or with the cell's :class:`CellContext`
    as ``function(raw_path, context)`` where it has a second positional parameter, or
    ``function(raw_path, context=context)`` where it has a ``context`` parameter (or
    ``**kwargs``).

    Notes
    -----
    The user's function takes ``raw_path`` (str, the cell's DNG, an absolute path) and,
    optionally, ``context`` (:class:`CellContext`: what the cell is; a command gets the same as
    JSON in ``$SPECTRAL_CAM_CONTEXT``), whose attributes are

    - ``set_name``, ``illuminant``, ``camera``, ``exposure`` (str): the cell's coordinates as
      the plan names them;
    - ``frame_size`` ((int, int)): (width, height) of the developed frame, pixels;
    - ``patches`` (list of dict): every patch's ``name``, centre ``column``/``row`` and
      ``half_width_px``/``half_height_px`` (pixels, 0 at the frame's top-left corner) and
      ``role`` (``"patch"`` or ``"white reference"``);
    - ``white_index`` (int): the white reference's place in ``patches`` (the metric matches
      exposure and scores white balance on it: balancing on it scores that patch's own tint);
    - ``exposure_s`` (float, seconds) and ``iso`` (float): what the sensor did.

    It returns an (H, W, 3) array of the whole frame in the space ``output`` names
    (:data:`OUTPUT_SPACES`); integer arrays are scaled by their type's maximum.
    """

    required = {"function": "function = 'module:function'"}

    def __init__(self, name: str, *, function: str, output: str = "linear_srgb",
                 python_path: Sequence[str] = (), base_dir: Path = Path(".")):
        super().__init__(name)
        if not isinstance(function, str) or function.count(":") != 1 or not all(function.split(":")):
            raise ConfigError(f"pipeline {name!r}: function = {function!r}; use 'module:function' "
                              "(e.g. 'my_isp:develop')")
        self.function, self.output = function, _output_space(name, "output", output)
        if self.output == "icc":
            raise ConfigError(f"pipeline {name!r}: output = 'icc' reads the profile a command's file embeds; a "
                              "callable returns an array: declare its encoding (linear_srgb, xyz, srgb, bt709, "
                              "gamma:<γ>)")
        paths = [python_path] if isinstance(python_path, str) else list(python_path)
        self.python_path = [str((base_dir / Path(p).expanduser()).resolve()) for p in paths]
        self._callable = self._resolve()

    @classmethod
    def from_table(cls, name: str, options: Mapping[str, Any], *, base_dir: Path, where: str) -> "CallablePipeline":
        return super().from_table(name, {**options, "base_dir": base_dir}, base_dir=base_dir, where=where)

    @contextlib.contextmanager
    def _on_path(self):
        """``python_path`` on ``sys.path`` for the duration of an import or a call only."""
        added = [entry for entry in reversed(self.python_path) if entry not in sys.path]
        for entry in added:
            sys.path.insert(0, entry)
        try:
            yield
        finally:
            for entry in added:
                if entry in sys.path:
                    sys.path.remove(entry)

    def _resolve(self) -> Callable:
        module_name, attribute = self.function.split(":")
        try:
            with self._on_path():
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

    def _context_argument(self) -> str | None:
        """How the function takes the cell's context: ``"keyword"`` (a ``context`` parameter or
        ``**kwargs``), ``"positional"`` (a second positional parameter) or None (the path only)."""
        try:
            parameters = inspect.signature(self._callable).parameters.values()
        except (TypeError, ValueError):  # a builtin without a signature: the path only
            return None
        if any(p.name == "context" or p.kind is p.VAR_KEYWORD for p in parameters):
            return "keyword"
        positional = [p for p in parameters if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
        if len(positional) >= 2 or any(p.kind is p.VAR_POSITIONAL for p in parameters):
            return "positional"
        return None

    def develop(self, raw, dng_path: Path, workdir: Path, context: "CellContext | None" = None) -> np.ndarray:
        how = self._context_argument() if context is not None else None
        with self._on_path():
            if how == "keyword":
                image = self._callable(str(dng_path), context=context)
            elif how == "positional":
                image = self._callable(str(dng_path), context)
            else:
                image = self._callable(str(dng_path))
        return _to_linear_srgb(_check_output(image, self.name), self.output)

    def describe(self) -> str:
        return f"Python callable {self.function} → {self.output}"


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
    return _unit_range(np.asarray(data))


#: Programs that parse their ``-c`` argument as shell code: a placeholder there is shell-quoted.
POSIX_SHELLS = ("sh", "bash", "dash", "zsh", "ksh", "mksh", "ash", "busybox")


def _shell_script_index(argv: Sequence[str]) -> int | None:
    """Where ``argv`` holds shell code: the argument after a POSIX shell's ``-c`` (``sh -c
    "prog {input}"``, ``bash -ec '...'``), or None when no shell parses any argument."""
    if not argv or Path(argv[0]).name not in POSIX_SHELLS:
        return None
    for i, argument in enumerate(argv[1:], start=1):
        if argument.startswith("-") and not argument.startswith("--") and "c" in argument[1:]:
            return i + 1 if i + 1 < len(argv) else None
    return None


def substitute_placeholders(argv: Sequence[str], paths: Mapping[str, str]) -> list[str]:
    """A command's arguments with their placeholders replaced by the paths.

    The program gets each argument as it is (no shell parses it), so a path goes in as it is,
    whole or inside a longer argument (``--configdir={work_dir}/config``): quotes there would
    reach the program as part of the path. Only the script a POSIX shell runs (``sh -c "prog
    {input}"``) gets the paths quoted (``shlex.quote``), so no folder name can inject a command.

    Examples
    --------
    >>> paths = {"{work_dir}": "/tmp/out dir/w"}
    >>> substitute_placeholders(["prog", "--configdir={work_dir}/config"], paths)
    ['prog', '--configdir=/tmp/out dir/w/config']
    >>> substitute_placeholders(["sh", "-c", "prog {work_dir}"], paths)
    ['sh', '-c', "prog '/tmp/out dir/w'"]
    """
    script = _shell_script_index(argv)
    out = []
    for i, argument in enumerate(argv):
        for placeholder, path in paths.items():
            argument = argument.replace(placeholder, shlex.quote(path) if i == script else path)
        out.append(argument)
    return out


def raw_template(raw) -> np.ndarray:
    """The frame as the RAW saw it: the mosaic above black, averaged over 3 × 3 (centred; every CFA
    colour in it), on the frame's pixels (inside the DNG's default crop) — what a tool's image is
    registered against (:func:`find_crop`)."""
    from scipy.ndimage import uniform_filter

    mosaic = np.asarray(raw.mosaic, dtype=np.float64)
    mosaic = mosaic.mean(axis=-1) if mosaic.ndim == 3 else mosaic
    level = uniform_filter(mosaic - np.mean(raw.black_level), size=3, mode="nearest")  # centred, CFA averaged
    if raw.crop is not None:
        top, left, height, width = raw.crop
        level = level[top:top + height, left:left + width]
    return level


def find_crop(image: np.ndarray, template: np.ndarray, *, search_px: int = 16) -> tuple[int, int, int, int]:
    """Where a tool's image lies on the frame: the offset (within ± ``search_px``) at which its
    luminance correlates best with ``template`` (the frame's own luminance, :func:`raw_template`),
    weighted by the share of the image that lands on the frame (a chart repeats, and a shift by
    one patch period correlates almost as well but leaves part of the image off the frame);
    returned as ``(top, bottom, left, right)``, the pixels the tool removed from each side."""
    height, width = template.shape
    luminance = np.nan_to_num(np.asarray(image, dtype=np.float64)[..., :3].mean(axis=-1))
    best, where = -np.inf, (0, 0)
    for top in range(-search_px, search_px + 1):
        for left in range(-search_px, search_px + 1):
            # the image's pixel (r, c) lies at the frame's (r + top, c + left)
            r0, c0 = max(top, 0), max(left, 0)
            r1, c1 = min(height, top + luminance.shape[0]), min(width, left + luminance.shape[1])
            if r1 - r0 < height // 2 or c1 - c0 < width // 2:
                continue
            a = template[r0:r1, c0:c1].ravel()
            b = luminance[r0 - top:r1 - top, c0 - left:c1 - left].ravel()
            if a.std() == 0 or b.std() == 0:
                continue
            score = float(np.corrcoef(a, b)[0, 1]) * a.size / luminance.size
            if score > best + 1e-9:
                best, where = score, (top, left)
    if best == -np.inf:
        raise ConfigError(f"cannot register the tool's {luminance.shape[1]} × {luminance.shape[0]} px image on the "
                          f"{width} × {height} frame: no offset within ±{search_px} px lays half of it on the frame "
                          "with any contrast; declare crop = [top, bottom, left, right] (pixels the tool removed)")
    top, left = where
    return top, height - top - luminance.shape[0], left, width - left - luminance.shape[1]


#: A tool's image whose luminance correlates with the RAW's own less than this is misregistered:
#: the example plan's tools, registered, measure r = 0.92–0.94; the same images flipped 0.33–0.54.
MIN_REGISTRATION_CORRELATION = 0.75


def check_registration(image: np.ndarray, template: np.ndarray, *, name: str) -> None:
    """Refuse a tool's image (on the frame's grid) that does not show the chart where the RAW
    has it: Pearson's r between its luminance and :func:`raw_template` over the pixels it
    covers below :data:`MIN_REGISTRATION_CORRELATION` (shifted, flipped, rotated, or another
    crop than declared). The message says what was measured.

    Raises
    ------
    ConfigError
        With the correlation and the share of the frame the image covers.
    """
    luminance = np.asarray(image, dtype=np.float64)[..., :3].mean(axis=-1)
    covered = np.isfinite(luminance)
    if covered.sum() < 2 or np.ptp(template[covered]) == 0 or np.ptp(luminance[covered]) == 0:
        r = float("nan")
    else:
        r = float(np.corrcoef(luminance[covered], template[covered])[0, 1])
    if not r >= MIN_REGISTRATION_CORRELATION:
        raise ConfigError(f"pipeline {name!r}: its image is misregistered on the frame: its luminance correlates with "
                          f"the RAW's at r = {r:.2f} (registered images measure 0.92–0.94) over the "
                          f"{100 * covered.mean():.0f} % of the frame it covers — shifted, flipped, rotated or cropped "
                          "other than declared; check crop = [top, bottom, left, right] (pixels the tool removed)")


def register(image: np.ndarray, frame: tuple[int, int], crop, template: np.ndarray | None = None) -> np.ndarray:
    """A tool's image on the frame's pixel grid.

    ``crop = [top, bottom, left, right]``: the pixels the tool removed from each side of the
    frame (negative: added). ``"auto"``: found against ``template`` where it is given
    (:func:`find_crop`: any offset within 16 px), else the difference split evenly (RawTherapee
    trims 4 px a side for demosaicing; a tool that keeps the DNG's border outside its default
    crop adds even margins). Pixels the tool removed come back as NaN (no patch interior lies
    there).

    Raises
    ------
    ConfigError
        For an uneven difference under ``"auto"`` without a template, or a declared crop that
        does not add up.
    """
    height, width = frame
    dy, dx = height - image.shape[0], width - image.shape[1]
    if crop == "auto" and template is not None:
        top, bottom, left, right = find_crop(image, template)
    elif crop == "auto":
        if dy % 2 or dx % 2:
            raise ConfigError(f"the image is {image.shape[1]} × {image.shape[0]} px, the frame {width} × {height}: "
                              "not an even margin; declare crop = [top, bottom, left, right] (pixels the tool removed)")
        top, bottom, left, right = dy // 2, dy // 2, dx // 2, dx // 2
    else:
        top, bottom, left, right = (int(v) for v in crop)
        if top + bottom != dy or left + right != dx:
            raise ConfigError(f"crop = {list(crop)} does not turn {image.shape[1]} × {image.shape[0]} px into the "
                              f"frame's {width} × {height}")
    canvas = np.full((height, width, image.shape[2]), np.nan)
    source = image[max(-top, 0):image.shape[0] - max(-bottom, 0), max(-left, 0):image.shape[1] - max(-right, 0)]
    canvas[max(top, 0):height - max(bottom, 0), max(left, 0):width - max(right, 0)] = source
    return canvas


def _check_crop(name: str, crop: Any):
    if crop == "auto" or crop is None:
        return "auto"
    if (isinstance(crop, (list, tuple)) and len(crop) == 4
            and all(isinstance(v, int) and not isinstance(v, bool) for v in crop)):
        return [int(v) for v in crop]
    raise ConfigError(f"pipeline {name!r}: crop = {crop!r}; give 'auto' or [top, bottom, left, right] in pixels the "
                      "tool removed (negative: added)")


def _kill_group(process: subprocess.Popen) -> None:
    """Kill a program's whole process group (it leads its own session) and reap it."""
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(process.pid, signal.SIGKILL)
    process.communicate()


def _text(data: bytes | None) -> str:
    """A program's output as text whatever it wrote (binary on stdout decodes with replacements)."""
    return (data or b"").decode("utf-8", errors="replace")


#: The largest ``input_min_bytes``: the padded copy is written for every cell (size floors of raw
#: developers are ~100 kB; a larger value is a typo, and 2**62 asked the memory for it).
MAX_INPUT_MIN_BYTES = 2 ** 30

#: Placeholders of a command: the DNG, the output file, the plan's folder, a scratch folder.
PLACEHOLDERS = ("{input}", "{output}", "{plan_dir}", "{work_dir}")


@pipeline_type("command", options=("command", "output", "output_suffix", "timeout_s", "shell", "crop",
                                   "input_min_bytes", "version_command", "optional"),
               description="an external program: command = '... {input} ... {output} ...'")
class CommandPipeline(Pipeline):
    """An external program run as ``command`` with placeholders for its files.

    ``{input}`` is the DNG, ``{output}`` a fresh file path with ``output_suffix`` that the
    program must write, ``{plan_dir}`` the plan's folder, ``{work_dir}`` a scratch folder of the
    cell (for a tool's own settings and cache). The program runs in the plan's folder, so relative
    paths in the command mean what they mean beside the plan.

    Without ``shell`` the command line is split like a POSIX shell would (``shlex``) and run
    without one: a placeholder becomes the path as it is, a whole argument or part of one
    (``--configdir={work_dir}/config``), except in the script of a POSIX shell's ``-c`` (``sh -c
    "prog {input}"``), where the path is quoted for that shell (``shlex.quote``;
    :func:`substitute_placeholders`). With ``shell = true`` the line runs through ``/bin/sh -c``
    with every placeholder quoted, so redirections work (``dcraw -c {input} > {output}``). Either
    way no folder name can inject a command. The program leads a session of its own: at
    ``timeout_s`` its whole process group is killed (a shell's children too). The paths are also in ``$SPECTRAL_CAM_INPUT``,
    ``$SPECTRAL_CAM_OUTPUT``, and the cell's :class:`CellContext` as JSON in the file
    ``$SPECTRAL_CAM_CONTEXT``. What the program prints is read as bytes (a tool may write its
    image to stdout) and shown, decoded with replacements, when it fails. A plan, like a Python
    script, is code the user trusts: it runs the programs it names.

    The image is registered on the frame (:func:`register`: ``crop``); ``input_min_bytes`` pads
    a copy of the DNG with trailing zeros to that size for tools with a size floor (RawTherapee
    5.9 refuses raw files under 100 000 bytes; TIFF readers ignore trailing bytes);
    ``version_command``'s first line of output is the tool's version in the report;
    ``optional = true`` drops the pipeline from the plan, with a note, where its program is not
    installed.
    """

    required = {"command": "command = '... {input} ... {output} ...'"}

    def __init__(self, name: str, *, command: str, output: str = "linear_srgb", output_suffix: str = ".tiff",
                 timeout_s: float = 300.0, shell: bool = False, crop: Any = "auto", input_min_bytes: int = 0,
                 version_command: str = "", optional: bool = False, base_dir: Path = Path(".")):
        super().__init__(name)
        if not isinstance(command, str) or "{input}" not in command or "{output}" not in command:
            raise ConfigError(f"pipeline {name!r}: command = {command!r}; it must contain the {{input}} and "
                              "{output} placeholders")
        try:
            self.argv = shlex.split(command)
        except ValueError as exc:
            raise ConfigError(f"pipeline {name!r}: cannot split command ({exc})") from None
        output = _output_space(name, "output", output)
        suffix = str(output_suffix).lower()
        if not suffix.startswith("."):
            suffix = "." + suffix
        if suffix not in OUTPUT_SUFFIXES:
            raise ConfigError(f"pipeline {name!r}: output_suffix = {output_suffix!r}; valid: {', '.join(OUTPUT_SUFFIXES)}")
        if isinstance(timeout_s, bool) or not isinstance(timeout_s, (int, float)) or not timeout_s > 0:
            raise ConfigError(f"pipeline {name!r}: timeout_s = {timeout_s!r}; must be a number of seconds > 0")
        for key, value in (("shell", shell), ("optional", optional)):
            if not isinstance(value, bool):
                raise ConfigError(f"pipeline {name!r}: {key} = {value!r}; give true or false")
        if isinstance(input_min_bytes, bool) or not isinstance(input_min_bytes, int) \
                or not 0 <= input_min_bytes <= MAX_INPUT_MIN_BYTES:
            raise ConfigError(f"pipeline {name!r}: input_min_bytes = {input_min_bytes!r}; give a whole number of bytes "
                              f"in 0..{MAX_INPUT_MIN_BYTES} (1 GiB; RawTherapee's floor is 100000)")
        self.command, self.output, self.output_suffix, self.timeout_s = command, output, suffix, float(timeout_s)
        self.shell, self.crop, self.input_min_bytes = shell, _check_crop(name, crop), int(input_min_bytes)
        self.version_command, self.optional, self.base_dir = str(version_command), optional, Path(base_dir).resolve()

    @classmethod
    def from_table(cls, name: str, options: Mapping[str, Any], *, base_dir: Path, where: str) -> "CommandPipeline":
        return super().from_table(name, {**options, "base_dir": base_dir}, base_dir=base_dir, where=where)

    @property
    def program(self) -> str:
        """The program the command runs (its first word; under ``shell``, the shell line's)."""
        return self.argv[0]

    def installed(self) -> bool:
        """Whether the program is found (on PATH, or as a path relative to the plan's folder)."""
        program = self.program.replace("{plan_dir}", str(self.base_dir))
        return shutil.which(program) is not None or (self.base_dir / program).is_file()

    @functools.cached_property
    def version(self) -> str:
        """The first line ``version_command`` prints (empty without one, or where the tool is
        absent); run when first asked (the report), not when the plan is read."""
        if not self.version_command or not self.installed():
            return ""
        try:
            done = subprocess.run(shlex.split(self.version_command), capture_output=True, timeout=30,
                                  cwd=self.base_dir, check=False)
        except (OSError, subprocess.TimeoutExpired):
            return ""
        lines = [line.strip() for line in _text(done.stdout + done.stderr).splitlines() if line.strip()]
        return lines[0][:120] if lines else ""

    def _input(self, dng_path: Path, folder: Path) -> Path:
        """The DNG, or a copy padded with trailing zeros to ``input_min_bytes``."""
        size = dng_path.stat().st_size
        if size >= self.input_min_bytes:
            return dng_path
        padded = folder / dng_path.name
        shutil.copyfile(dng_path, padded)
        with padded.open("r+b") as handle:
            handle.truncate(self.input_min_bytes)  # zeros, without holding them in memory
        return padded

    def _run(self, argv: list[str], env: dict) -> subprocess.CompletedProcess:
        """Run the program in the plan's folder, in a session of its own: at ``timeout_s`` the
        whole process group is killed (a shell's children too, which a plain kill of the shell
        leaves running)."""
        try:
            process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                                       cwd=self.base_dir, start_new_session=True)
        except FileNotFoundError:
            raise ConfigError(f"pipeline {self.name!r}: program {argv[0]!r} not found") from None
        try:
            stdout, stderr = process.communicate(timeout=self.timeout_s)
        except subprocess.TimeoutExpired:
            _kill_group(process)
            raise ConfigError(f"pipeline {self.name!r}: no result within {self.timeout_s:g} s (stopped it and "
                              "every process it started)") from None
        except BaseException:  # Ctrl-C: nothing it started outlives the run
            _kill_group(process)
            raise
        return subprocess.CompletedProcess(argv, process.returncode, stdout, stderr)

    def develop(self, raw, dng_path: Path, workdir: Path, context: "CellContext | None" = None) -> np.ndarray:
        import json

        # absolute: the program runs in the plan's folder, not where the caller's relative paths start
        with tempfile.TemporaryDirectory(prefix=f"{self.name}-", dir=os.path.abspath(workdir)) as folder:
            folder = Path(folder)
            out = folder / f"output{self.output_suffix}"
            source = self._input(Path(os.path.abspath(dng_path)), folder)
            paths = {"{input}": str(source), "{output}": str(out), "{plan_dir}": str(self.base_dir),
                     "{work_dir}": str(folder)}
            env = {**os.environ, "SPECTRAL_CAM_INPUT": str(source), "SPECTRAL_CAM_OUTPUT": str(out)}
            if context is not None:
                (folder / "context.json").write_text(json.dumps(context.to_dict()))
                env["SPECTRAL_CAM_CONTEXT"] = str(folder / "context.json")
            argv = substitute_placeholders(["/bin/sh", "-c", self.command] if self.shell else self.argv, paths)
            done = self._run(argv, env)
            if done.returncode != 0:
                tail = (_text(done.stderr) or _text(done.stdout)).strip()[-500:]
                raise ConfigError(f"pipeline {self.name!r}: exit status {done.returncode}: {tail}")
            if not out.is_file():
                said = (_text(done.stderr) or _text(done.stdout)).strip()[-300:]
                raise ConfigError(f"pipeline {self.name!r}: the command wrote no {{output}} file ({out.name})"
                                  + (f"; it said: {said}" if said else ""))
            image = _check_output(_read_image_file(out), self.name)
            if self.output == "icc":
                from .icc import embedded_profile, icc_to_linear_srgb

                profile = embedded_profile(out)
                if profile is None:
                    raise ConfigError(f"pipeline {self.name!r}: output = 'icc' but {out.name} embeds no ICC profile; "
                                      "declare the output's encoding (srgb, bt709, linear_srgb, gamma:<γ>)")
                image = icc_to_linear_srgb(image, profile)
        frame = raw.mosaic.shape[:2] if raw.crop is None else tuple(raw.crop[2:])
        template = raw_template(raw)
        if image.shape[:2] != tuple(frame):
            image = register(image, tuple(frame), self.crop, template if self.crop == "auto" else None)
        image = image if self.output == "icc" else _to_linear_srgb(image, self.output)
        check_registration(image, template, name=self.name)
        return image

    def describe(self) -> str:
        version = f" ({self.version})" if self.version else ""
        return f"command `{self.command}`{version} → {self.output}"

    def to_dict(self) -> dict:
        out = super().to_dict()
        out.pop("base_dir", None)
        out["version"] = self.version
        return out
