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
registry (docs/design.md, "Registries"). The registry and the base class are
:mod:`.pipeline_base`'s, the output spaces and image files :mod:`.pipeline_output`'s, the
command type :mod:`.command_pipeline`'s (its images registered on the frame by
:mod:`.registration`); this module holds the types that run in the process.

References
----------
.. [1] rawpy API, ``RawPy.postprocess`` (LibRaw output parameters).
.. [2] docs/design.md, "Ground truth and metrics" (what is measured: ``.linear``, tone curve off).
"""

from __future__ import annotations

import contextlib
import importlib
import inspect
import sys
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ...errors import ConfigError
# the registry and the base class, the output spaces and the command type live in their own
# modules; their names stay importable from here, where plans and users' modules look for them
from .pipeline_base import PIPELINES, CellContext, Pipeline, check_choice, pipeline_type
from .pipeline_output import OUTPUT_SPACES, OUTPUT_SUFFIXES, check_output, check_output_space, to_linear_srgb
from .registration import MIN_REGISTRATION_CORRELATION, check_registration, find_crop, raw_template, register

__all__ = ["PIPELINES", "Pipeline", "CellContext", "pipeline_type", "OursPipeline", "RawpyPipeline", "CallablePipeline",
           "CommandPipeline", "OUTPUT_SPACES", "OUTPUT_SUFFIXES", "RAWPY_WHITE_BALANCE", "RAWPY_OUTPUT_COLOURS"]

#: LibRaw white balance: AsShotNeutral, LibRaw's automatic estimate, its daylight
#: multipliers (from the D65 matrix), or ``wb_gains``.
RAWPY_WHITE_BALANCE = ("camera", "auto", "daylight", "manual")
#: LibRaw output spaces measured (both relative to D65 in LibRaw).
RAWPY_OUTPUT_COLOURS = ("XYZ", "sRGB")
RAWPY_HIGHLIGHT_MODES = ("clip", "ignore", "blend", "reconstruct")
RAWPY_FBDD = ("off", "light", "full")


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
        self.demosaic = check_choice(name, "demosaic", demosaic, supported, fold=True, note=" (this LibRaw)")
        self.white_balance = check_choice(name, "white_balance", white_balance, RAWPY_WHITE_BALANCE)
        self.wb_gains = tuple(float(g) for g in wb_gains)
        if white_balance == "manual" and (len(self.wb_gains) != 3 or not all(g > 0 for g in self.wb_gains)):
            raise ConfigError(f"pipeline {name!r}: white_balance = 'manual' needs wb_gains = [r, g, b] (all > 0)")
        self.output_color = check_choice(name, "output_color", output_color, RAWPY_OUTPUT_COLOURS, fold=True,
                                         after=" (LibRaw's D65-relative spaces)")
        self.highlight_mode = check_choice(name, "highlight_mode", highlight_mode, RAWPY_HIGHLIGHT_MODES)
        self.fbdd_noise_reduction = check_choice(name, "fbdd_noise_reduction", fbdd_noise_reduction, RAWPY_FBDD)
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
        self.function, self.output = function, check_output_space(name, "output", output)
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
        return to_linear_srgb(check_output(image, self.name), self.output)

    def describe(self) -> str:
        return f"Python callable {self.function} → {self.output}"


# imported last so that the command type registers after the three above: the registry's order is
# the order the messages list the types in (ours, rawpy, callable, command); no cycle, as
# command_pipeline imports pipeline_base, not this module
from .command_pipeline import (MAX_INPUT_MIN_BYTES, PLACEHOLDERS, POSIX_SHELLS, CommandPipeline,  # noqa: E402
                               substitute_placeholders)
