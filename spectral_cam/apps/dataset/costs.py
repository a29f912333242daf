"""What a dataset will cost before it renders: the ``--dry-run`` estimate and the disk check.

:func:`plan_dataset` plans the first few valid items' captures (:func:`~spectral_cam.render.plan.make_plan`)
and scales their time, memory and files to the dataset on its workers; :func:`check_disk` refuses,
before rendering, a dataset whose result files cannot fit on the disk.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

from ...errors import ConfigError
from ...job import RESULT_FILES
from ...scene import scene_from_dict
from .executors import default_workers
from .labels import LABELS
from .spec import DatasetSpec

__all__ = ["PLANNED_SAMPLE", "check_disk", "plan_dataset"]


#: Items whose capture plans stand for the whole dataset in ``--dry-run`` (each renders its depth probe).
PLANNED_SAMPLE = 3


def plan_dataset(spec: DatasetSpec, *, n: int | None = None, workers: int | None = None,
                 scheduler: str | None = None) -> str:
    """What ``spectral-cam dataset --dry-run`` prints: the capture plans of the first
    :data:`PLANNED_SAMPLE` valid items (:func:`spectral_cam.render.plan.make_plan`), and the
    dataset's total from them: time over the cluster's workers (``workers`` local processes,
    default :func:`default_workers`; one process for ``scheduler="inline"``; per item for a
    remote scheduler, whose size is not known here), peak memory per worker, and the files'
    size. Nothing but the probes the plans need and their cost probes is rendered.

    Raises
    ------
    ConfigError
        For an invalid count, or when none of the first items has a valid scene.
    """
    total = spec.item_count(n)
    plans, errors = _sample_plans(spec, total)
    lines = [f"item {item.id} {item.params}:\n  " + plan.summary().replace("\n", "\n  ") for item, plan in plans]
    parallel = 1 if scheduler == "inline" else (None if scheduler else (workers or default_workers()))
    lines.append(_dataset_line(spec, plans, errors, total, parallel, scheduler))
    lines += [f"  invalid item {error}" for error in errors[:5]]
    if len(errors) > 5:
        lines.append(f"  ... {len(errors) - 5} more")
    return "\n".join(lines)


def _sample_plans(spec: DatasetSpec, total: int) -> tuple[list, list[str]]:
    """([(item plan, capture plan)] of the first :data:`PLANNED_SAMPLE` valid items, ["id: error"]
    of the invalid ones met before them, at most 10 × :data:`PLANNED_SAMPLE` + 1).

    Raises
    ------
    ConfigError
        When none of them has a valid scene.
    """
    from ...render.plan import make_plan

    per_point = total // spec.grid_size
    plans, errors = [], []
    for index in range(total):
        item = spec.plan_item(index, per_point)
        if item.scene is None:
            errors.append(f"{item.id}: {item.error}")
        else:
            outputs = [name for name in spec.outputs if name in RESULT_FILES]
            plans.append((item, make_plan(scene_from_dict(item.scene), outputs=outputs, measure=True)))
        if len(plans) == PLANNED_SAMPLE or len(errors) > 10 * PLANNED_SAMPLE:
            break
    if not plans:
        raise ConfigError(f"none of the first items has a valid scene: {'; '.join(errors[:3])}")
    return plans, errors


def _dataset_line(spec: DatasetSpec, plans: list, errors: list[str], total: int, parallel: int | None,
                  scheduler: str | None) -> str:
    """The dry run's total: time (over ``parallel`` workers; per item where their number is not
    known), peak memory a worker and in all, and the files' size, from the sampled plans' means."""
    time_s = sum(p.budget["time_s"] for _, p in plans) / len(plans)
    memory = max(p.budget["memory_bytes"] for _, p in plans)
    files = sum(sum(p.budget["outputs_bytes"].values()) + _label_bytes(item.scene, spec.outputs)
                for item, p in plans) / len(plans)
    where = (f"{parallel} worker process{'es' if parallel != 1 else ''}" if parallel else
             f"the cluster at {scheduler} (its size unknown here: time per item)")
    total_s = time_s * total / parallel if parallel else time_s
    return (f"dataset: {total} items on {where}: about {total_s:.3g} s"
            + (" per item" if not parallel else f" ({time_s:.3g} s an item)")
            + f", peak memory about {memory / 1e9:.2g} GB a worker"
            + (f" ({memory * parallel / 1e9:.2g} GB in all)" if parallel else "")
            + f", files about {files * total / 1e9:.3g} GB (uncompressed: the labels' EXRs and PNGs compress); "
            f"from the plans of {len(plans)} item(s)"
            + (f"; {len(errors)} of the first {len(plans) + len(errors)} items invalid (recorded as failed, "
               f"never rendered):" if errors else ""))


def _label_bytes(scene: Mapping[str, Any], outputs) -> float:
    """Bytes of an item's labels beyond the render job's own files (which its plan sizes from the
    scene): each label's :meth:`~.labels.registry.Label.estimate_bytes` at the item's frame."""
    sensor = scene_from_dict(scene).sensor
    return sum(LABELS[name].estimate_bytes(sensor.width_px, sensor.height_px)
               for name in outputs if name not in RESULT_FILES)


def check_disk(task: Mapping[str, Any], items: int, output: Path) -> None:
    """Refuse a dataset whose result files cannot fit on the disk, before rendering: the first
    item's files (:func:`spectral_cam.budget.estimate_result_bytes`; the labels besides them not
    counted, so it never refuses what fits) times the items left to render."""
    from ...io import check_free_disk
    from ...budget import estimate_result_bytes

    per_item = sum(estimate_result_bytes(scene_from_dict(task["scene"]),
                                         [name for name in task["outputs"] if name in RESULT_FILES]).values())
    check_free_disk(per_item * items, output, what=f"{items} items of about {per_item / 1e6:.3g} MB each",
                    remedy="free space, choose -o elsewhere, render fewer items (-n), or drop outputs such as "
                    "'radiance' (render.radiance_precision = 'half' halves it)")
