"""Which benchmarks there are (:data:`BENCHMARKS`) and running them (:func:`run_benchmarks`).

Adding a benchmark is one function ``bench_<name>(out, *, quick) -> rows`` in the module of
its family and one entry here (docs/design.md, "Where to make a change").
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

from ...registry import Registry
from .isp import bench_isp, bench_rawpy
from .sampling import bench_bands, bench_spp

__all__ = ["BENCHMARKS", "run_benchmarks"]

#: Every benchmark: name → ``function(out: Path, *, quick: bool) -> list[dict]``, which writes
#: ``out/<name>.csv`` and its charts and returns the rows.
BENCHMARKS = Registry("benchmark")
BENCHMARKS.add("spp", bench_spp, description="samples per pixel: render time vs Monte-Carlo noise and ΔE2000")
BENCHMARKS.add("bands", bench_bands, description="camera film and 8/16/31 bands vs a 1-nm reference: time vs "
                                                 "ΔE2000 and channel bias")
BENCHMARKS.add("isp", bench_isp, description="demosaic methods and denoisers: develop time vs PSNR and ΔE2000")
BENCHMARKS.add("rawpy", bench_rawpy, description="our ISP vs LibRaw (LINEAR, AHD, DCB) on the same DNG: time vs "
                                                 "ΔE2000")


def run_benchmarks(output: str | Path, *, quick: bool = False, only: list[str] | None = None,
                   log: Callable[[str], None] = print, force: bool = False) -> dict[str, list[dict]]:
    """Run the benchmarks, each in this process so every time ratio has its baseline
    measured in the same run, and write their CSVs and PNG charts.

    Parameters
    ----------
    output : path-like
        Folder for ``<name>.csv`` and ``<name>*.png`` (created; other files in it are left
        alone).
    quick : bool
        Small sizes (about 5 s on 2 cores, 20 s without).
    only : list of str, optional
        Names from :data:`BENCHMARKS` to run (default all, in registry order).
    log : callable
        Receives one line per finished benchmark.
    force : bool
        Replace the results of an earlier run in ``output``; without it they are refused.

    Returns
    -------
    dict
        Benchmark name → its rows.

    Raises
    ------
    ConfigError
        For an unknown benchmark name (listing the valid ones), or earlier results in
        ``output`` without ``force``.

    References
    ----------
    .. [1] docs/design.md, "CLI" (``spectral-cam bench``).
    """
    from ...errors import ConfigError

    names = list(only or BENCHMARKS)
    unknown = [n for n in names if n not in BENCHMARKS]
    if unknown:
        raise ConfigError(f"unknown benchmark(s) {', '.join(unknown)}; valid: {', '.join(BENCHMARKS)}")
    out = Path(output)
    earlier = [f"{name}.csv" for name in names if (out / f"{name}.csv").exists()]
    if earlier and not force:
        raise ConfigError(f"{out} holds results of an earlier run ({', '.join(earlier)}); pass --force "
                          "(force=True) to replace them, or choose another folder")
    out.mkdir(parents=True, exist_ok=True)
    results = {}
    for name in names:
        t0, started = time.perf_counter(), time.time()
        results[name] = BENCHMARKS[name](out, quick=quick)
        # charts are named by what they show (isp writes demosaic.png and denoise.png): list what was written
        written = sorted(p.name for p in out.iterdir() if p.is_file() and p.stat().st_mtime >= started - 1)
        log(f"bench {name}: {len(results[name])} rows in {time.perf_counter() - t0:.1f} s -> {out}/ "
            f"({', '.join(written)})")
    return results
