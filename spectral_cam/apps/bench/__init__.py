"""Speed against accuracy: benchmarks that chart one against the other.

``spectral-cam bench -o DIR [--quick] [--only NAME]`` runs, each in one process so every time
ratio has its baseline measured in the same run:

- ``spp``: samples per pixel for the LLVM and scalar variants — time against Monte-Carlo
  noise and against ΔE2000 of the developed ColorChecker;
- ``bands``: spectral sampling — the camera film (3 measured curves + CMFs) and 8/16/31
  bands against a 1-nm reference integration, under D65 and FL11: render time against
  ΔE2000 and per-channel bias;
- ``isp``: demosaic methods and denoisers — time against PSNR and ΔE2000;
- ``rawpy``: our ISP against LibRaw (LINEAR, AHD, DCB) on the same DNG — time against ΔE2000.

Each writes ``DIR/<name>.csv`` and ``DIR/<name>.png`` with the Pareto front marked.

Modules: ``common`` (Pareto front, timing, the benchmarks' scene, CSV and chart),
``sampling`` (``spp``, ``bands``), ``isp`` (``isp``, ``rawpy``), ``run`` (the
:data:`BENCHMARKS` registry and :func:`run_benchmarks`). See docs/design.md, "Where to make
a change".

References
----------
.. [1] Pharr, Jakob & Humphreys (2023). Physically Based Rendering, 4th ed., §2.1
   (Monte-Carlo error falls as 1/√spp).
.. [2] Sharma, Wu & Dalal (2005). The CIEDE2000 colour-difference formula.
"""

from .common import pareto_front
from .run import BENCHMARKS, run_benchmarks

__all__ = ["run_benchmarks", "pareto_front", "BENCHMARKS"]
