"""The ``command`` pipeline type: an external program run on the cell's DNG.

:class:`CommandPipeline` runs ``command`` with placeholders for its files (:data:`PLACEHOLDERS`),
without a shell (:func:`substitute_placeholders`: a path goes into an argument as it is, and is
quoted only in a POSIX shell's ``-c`` script) or, with ``shell = true``, through ``/bin/sh -c``
with every placeholder quoted; in the plan's folder, in a session of its own (at ``timeout_s``
its whole process group is killed). Its output file is read (:mod:`.pipeline_output`),
decoded through an embedded ICC profile where ``output = "icc"`` (:mod:`.icc`), and registered
on the frame (:mod:`.registration`).

References
----------
.. [1] IEEE Std 1003.1-2017 (POSIX), Shell Command Language: ``sh -c``, quoting (``shlex``).
.. [2] docs/design.md, "Ground truth and metrics" (commands, registration, ``input_min_bytes``).
"""

from __future__ import annotations

import contextlib
import functools
import os
import shlex
import shutil
import signal
import subprocess
import tempfile
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import ConfigError
from .pipeline_base import CellContext, Pipeline, pipeline_type
from .pipeline_output import OUTPUT_SUFFIXES, check_output, check_output_space, read_image_file, to_linear_srgb
from .registration import check_crop, check_registration, raw_template, register

__all__ = ["CommandPipeline", "PLACEHOLDERS", "POSIX_SHELLS", "MAX_INPUT_MIN_BYTES", "substitute_placeholders"]


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
        output = check_output_space(name, "output", output)
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
        self.shell, self.crop, self.input_min_bytes = shell, check_crop(name, crop), int(input_min_bytes)
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
        # absolute: the program runs in the plan's folder, not where the caller's relative paths start
        with tempfile.TemporaryDirectory(prefix=f"{self.name}-", dir=os.path.abspath(workdir)) as folder:
            folder = Path(folder)
            out = folder / f"output{self.output_suffix}"
            source = self._input(Path(os.path.abspath(dng_path)), folder)
            done = self._run(*self._command_line(source, out, folder, context))
            image = self._read_output(out, done)
        return self._on_frame(image, raw)

    def _command_line(self, source: Path, out: Path, folder: Path,
                      context: "CellContext | None") -> tuple[list[str], dict]:
        """The arguments (placeholders substituted) and the environment of one run: the paths in
        ``$SPECTRAL_CAM_INPUT``/``$SPECTRAL_CAM_OUTPUT``, the cell's context as a JSON file in
        ``$SPECTRAL_CAM_CONTEXT``."""
        import json

        paths = {"{input}": str(source), "{output}": str(out), "{plan_dir}": str(self.base_dir),
                 "{work_dir}": str(folder)}
        env = {**os.environ, "SPECTRAL_CAM_INPUT": str(source), "SPECTRAL_CAM_OUTPUT": str(out)}
        if context is not None:
            (folder / "context.json").write_text(json.dumps(context.to_dict()))
            env["SPECTRAL_CAM_CONTEXT"] = str(folder / "context.json")
        return substitute_placeholders(["/bin/sh", "-c", self.command] if self.shell else self.argv, paths), env

    def _read_output(self, out: Path, done: subprocess.CompletedProcess) -> np.ndarray:
        """The image the program wrote (``output = "icc"``: decoded through the profile it embeds);
        a failed run, or one that wrote no file, is refused with the end of what it printed."""
        if done.returncode != 0:
            tail = (_text(done.stderr) or _text(done.stdout)).strip()[-500:]
            raise ConfigError(f"pipeline {self.name!r}: exit status {done.returncode}: {tail}")
        if not out.is_file():
            said = (_text(done.stderr) or _text(done.stdout)).strip()[-300:]
            raise ConfigError(f"pipeline {self.name!r}: the command wrote no {{output}} file ({out.name})"
                              + (f"; it said: {said}" if said else ""))
        image = check_output(read_image_file(out), self.name)
        if self.output == "icc":
            from .icc import embedded_profile, icc_to_linear_srgb

            profile = embedded_profile(out)
            if profile is None:
                raise ConfigError(f"pipeline {self.name!r}: output = 'icc' but {out.name} embeds no ICC profile; "
                                  "declare the output's encoding (srgb, bt709, linear_srgb, gamma:<γ>)")
            image = icc_to_linear_srgb(image, profile)
        return image

    def _on_frame(self, image: np.ndarray, raw) -> np.ndarray:
        """The tool's image on the frame's pixel grid (:func:`~.registration.register`) in linear
        sRGB, refused where it does not show the chart where the RAW has it."""
        frame = raw.mosaic.shape[:2] if raw.crop is None else tuple(raw.crop[2:])
        template = raw_template(raw)
        if image.shape[:2] != tuple(frame):
            image = register(image, tuple(frame), self.crop, template if self.crop == "auto" else None)
        image = image if self.output == "icc" else to_linear_srgb(image, self.output)
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
