"""Synthetic datasets: randomised or swept scenes rendered on a Dask cluster, resumable.

``spectral-cam dataset SPEC.toml -n N -o DIR`` renders N items. The spec is a scene file
(any ``[section] key = value`` of docs/design.md, "Scene file") in which any value may instead be a
distribution, plus a ``[dataset]`` table::

    [dataset]
    scene = "scenes/dof.toml"      # optional base scene file (the spec's tables win)
    seed = 0                       # dataset seed; item seeds derive from (spec, index)
    n = 100                        # default item count (-n wins)
    outputs = ["raw", "image", "depth", "defocus", "all_in_focus", "clean_rgb"]  # + "radiance"
    # sweep = { "exposure.iso" = [100, 800, 3200] }   # optional grid axes (a swept key takes no distribution)

    [sensor]
    model = { choice = ["nikon_d850", "canon_eos_5d_mkiv", "sony_ilce_7m3"] }
    width_px = 256
    [illuminant]
    spd = { choice = ["D65", "A", "blackbody:5000"], weights = [2, 1, 1] }
    illuminance_lux = { log_uniform = [50, 20000] }
    [lens]
    f_number = { log_uniform = [1.4, 16] }
    focus_distance_m = { uniform = [0.5, 5.0] }
    [scene]
    preset = { choice = ["colorchecker", "dof_targets", "slanted_edge"] }
    depths_m = { uniform = [[0.5, 1.0, 2.0], [1.0, 3.0, 8.0]] }   # element-wise bounds

Distributions (:data:`~spectral_cam.apps.dataset.spec.DISTRIBUTIONS`): ``uniform = [low, high]``, ``log_uniform = [low,
high]`` (uniform in log, both > 0), ``choice = [v, ...]`` with optional ``weights``; list
bounds sample list-valued keys element by element; keys whose type is a whole number draw
whole numbers from ceil(low) to floor(high), both ends included (``uniform``: each equally
likely; ``log_uniform``: each with its rounding cell's log-width). ``--sweep key=start:stop:count`` (``:log`` for a geometric series, or
``key=[v1, v2, ...]``) adds a grid axis; several sweeps give their product, and ``-n`` then
counts items per grid point. A sweep renders a contact sheet and, for the ``dof_targets``
and ``point_sources`` presets, a chart of measured blur against depth beside the thin-lens
prediction.

Each item is a folder ``DIR/items/<index:06d>/`` that appears in one rename when complete
(:func:`spectral_cam.io.staged_directory`); each output is one entry of
:data:`~spectral_cam.apps.dataset.labels.LABELS`:

    raw.dng            the simulated RAW                                    ("raw")
    image.png          the developed sRGB image (every isp.outputs format)   ("image")
    radiance.exr       spectral radiance per nm, Fichet et al. layout       ("radiance", opt-in)
    depth.exr          camera-space z (m)                                   ("depth")
    defocus.exr        signed thin-lens CoC diameter in pixels, channel CoC ("defocus")
    all_in_focus.png   the same pose through a pinhole at the same exposure ("all_in_focus")
    clean_rgb.exr      noise-free linear camera RGB (1 = white level − black level)  ("clean_rgb")
    meta.json          resolved config, optics, sensor, seeds, sampled parameters, timings

Items render through a thin lens (``lens.model = "thin"`` unless the spec says otherwise,
so the defocus label always describes the image), ``render.spectral_output`` follows the
``radiance`` output (without it, ``render.bands = "auto"`` may choose the faster camera
film), and the all-in-focus render keeps every setting but the lens model and fixes
``exposure.time_s`` to the main item's resolved exposure. Relative paths in the spec
resolve against its folder (in ``--set`` values, against the working directory).

``DIR/manifest.jsonl`` holds one row per item (status "done", "failed" or, while a run is
under way or after it was interrupted, "pending"; seed, parameters, files, error);
``DIR/dataset.json`` the spec and its hash; ``DIR/contact_sheet.png`` the first items'
images. Items are independent tasks:

- seeds: item *i* draws its parameters from ``SeedSequence(spec hash, (i, 0))`` and renders
  with ``render.seed`` = the first word of ``SeedSequence(spec hash, (i, 1))`` unless the
  spec sets ``render.seed``; the same spec gives the same items on any machine, in any
  order, and ``-n`` can grow a random dataset without changing its first items (in a sweep
  the items per grid point set which index gets which point, so a different ``-n`` re-plans
  them and resume renders the changed ones again);
- resume: an item whose folder is complete (its meta.json lists files that all exist, made
  from the same spec hash with the same seed and parameters, holding the outputs asked
  for) is skipped; anything else is rendered again and replaces the folder atomically;
- a worker that dies mid-item (killed, out of memory) loses only that item, which is
  submitted again (``--retries``, default 2); an item that raises (an impossible value, a
  broken scene file) is recorded as failed with its error and the run goes on;
- a progress bar on stderr shows items done, failures, the rate and the ETA;
- Ctrl-C (or SIGTERM) stops the run at once and keeps every finished item: "interrupted: 11/12
  items done, kept in DIR; rerun the same command to resume" (:class:`~.run.DatasetInterrupted`,
  exit 130; local workers ignore the terminal's SIGINT and are stopped by the driver).

Execution: any ``concurrent.futures.Executor`` (:func:`generate_dataset`); by default a Dask
``LocalCluster`` of spawned worker processes (``--workers K``; one render per worker, one
Dask thread each, Mitsuba's thread pool sized to the worker's share of the cores); with
``--scheduler tcp://HOST:8786`` the same command runs on a running Dask cluster, whose
workers must have spectral_cam installed and see DIR at the same path (a shared file
system). ``--scheduler inline`` runs the items one after another in this process.

``DIR/metadata.jsonl`` holds one row per finished item with a ``file_name`` column (the developed
image, relative to DIR), its seed, sampled parameters and every label's path
(``<label>_file``): Hugging Face ``datasets.load_dataset("imagefolder", data_dir=DIR)`` reads it
as it is. ``DIR/README.md`` is the dataset card (spec, counts, labels with units, layout, sources
and licences). :class:`~.loader.SyntheticDataset` serves the items as NumPy arrays in a form
PyTorch's ``DataLoader`` batches with its default collate (``batch_size=4``, no ``collate_fn``;
the records that do not batch, meta.json and the whole camera.json, through ``records(i)``),
with :class:`~.loader.Crop` and :class:`~.loader.Resize` transforms that keep K consistent.

Modules: :mod:`.spec` (the spec, distributions, sweeps, item plans), :mod:`.labels` (what an
item writes, one module per label: :data:`~.labels.LABELS` entries with writer, reader, description
and size; the defocus map, clean camera RGB, blur against depth, the class map),
:mod:`.run` (the run: executor, Dask cluster, manifest, resume, retries, lock), :mod:`.sheets`
(contact sheet, blur chart), :mod:`.card` (metadata.jsonl, the dataset card), :mod:`.loader`
(reading items back). The command line is :mod:`spectral_cam.cli.dataset`.

Cluster recipes
---------------
SLURM, with dask-jobqueue (``pip install dask-jobqueue``)::

    from dask.distributed import Client
    from dask_jobqueue import SLURMCluster
    from spectral_cam.apps.dataset import generate_dataset, load_spec

    cluster = SLURMCluster(cores=8, processes=1, memory="16GB", walltime="04:00:00",
                           job_extra_directives=["--cpus-per-task=8"],
                           job_script_prologue=["source /path/to/venv/bin/activate"])
    cluster.adapt(minimum_jobs=1, maximum_jobs=32)   # one worker process (one render) per job
    with Client(cluster) as client:
        generate_dataset(load_spec("spec.toml"), "/shared/dataset", n=10000,
                         executor=client.get_executor(pure=False))

(or start the scheduler yourself, ``dask scheduler`` on a login node, and submit jobs that run
``dask worker tcp://LOGIN:8786 --nworkers 1 --nthreads 1``; then run
``spectral-cam dataset spec.toml -n 10000 -o /shared/dataset --scheduler tcp://LOGIN:8786``).
``processes=1`` keeps one render per job, and Mitsuba then uses the job's cores.

Kubernetes, with the Dask Helm chart or dask-kubernetes' operator::

    helm install dask dask/dask --set worker.replicas=16 \\
        --set worker.image.repository=YOUR/spectral-cam-image \\
        --set worker.resources.limits.cpu=4 --set worker.args="{--nthreads,1}"
    # mount the output volume (ReadWriteMany) at the same path in the worker pods and here
    spectral-cam dataset spec.toml -n 10000 -o /data/dataset --scheduler tcp://dask-scheduler:8786

(dask-kubernetes: ``KubeCluster(name="spectral-cam", image=..., n_workers=16,
resources={"limits": {"cpu": "4"}}, worker_command="dask worker --nthreads 1")``, then
``Client(cluster).get_executor(pure=False)`` as above.) Resubmitting the same command after
a pre-empted job resumes where it stopped.

References
----------
.. [1] docs/design.md, "Result folder (job.py)" (an item is a render job's folder plus labels).
.. [2] Rocklin, M. (2015). Dask: parallel computation with blocked algorithms and task
   scheduling. Proc. 14th Python in Science Conference, 130–136.
.. [3] O'Neill, M. E. (2014) and NumPy ``SeedSequence``: independent streams from a root
   entropy and a spawn key (numpy.random.SeedSequence documentation, NEP 19).
.. [4] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10 (circle of confusion).
.. [5] EMVA Standard 1288, Release 4.0 Linear (2021), §2 (mean photo-electrons).

"""

from .labels import (
                     BLUR_PRESETS,
                     DEFAULT_OUTPUTS,
                     LABELS,
                     Item,
                     clean_camera_rgb,
                     defocus_map_px,
                     measure_scene_blur,
                     write_item,
)
from .run import (
                     MANIFEST_EVERY_S,
                     DatasetInterrupted,
                     DatasetSummary,
                     ProgressBar,
                     default_workers,
                     generate_dataset,
                     item_task,
                     local_cluster,
                     PLANNED_SAMPLE,
                     plan_dataset,
                     render_item,
)
from .card import write_card, write_metadata
from .loader import FRAME_LABELS, LOADABLE_LABELS, Crop, Resize, SyntheticDataset, batchable, read_item
from .sheets import CONTACT_SHEET_MAX, write_blur_chart, write_contact_sheet
from .spec import (
                     DISTRIBUTIONS,
                     FORMAT_VERSION,
                     DatasetSpec,
                     Distribution,
                     ItemPlan,
                     Sweep,
                     load_spec,
                     parse_sweep,
                     spec_from_dict,
                     with_exports,
)

__all__ = [
    "LOADABLE_LABELS",
    "FRAME_LABELS",
    "SyntheticDataset",
    "batchable",
    "Crop",
    "Resize",
    "read_item",
    "write_card",
    "write_metadata",
    "DISTRIBUTIONS", "FORMAT_VERSION", "Distribution", "Sweep", "parse_sweep", "DatasetSpec", "ItemPlan",
    "spec_from_dict", "load_spec", "with_exports",
    "LABELS", "DEFAULT_OUTPUTS", "BLUR_PRESETS", "Item", "write_item", "defocus_map_px", "clean_camera_rgb",
    "measure_scene_blur",
    "DatasetSummary", "DatasetInterrupted", "generate_dataset", "item_task", "render_item", "local_cluster", "default_workers", "plan_dataset",
    "PLANNED_SAMPLE",
    "ProgressBar", "MANIFEST_EVERY_S",
    "CONTACT_SHEET_MAX", "write_contact_sheet", "write_blur_chart",
]
