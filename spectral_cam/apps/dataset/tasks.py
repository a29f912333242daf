"""One dataset item as a task: the plain data a worker gets, and the function it runs.

:func:`item_task` turns a planned item (:class:`~.spec.ItemPlan`) into a picklable dict (its scene,
seed, parameters, folder, outputs and the spec's class map); :func:`render_item` runs on a worker,
writes the item's folder (:func:`~.labels.write_item`) and returns its manifest row, recording an
item that raises as failed rather than taking the run down.

References
----------
.. [1] Python ``concurrent.futures`` (PEP 3148): a task's return value travels back to the driver.
"""

from __future__ import annotations

import os
import time
import traceback
from pathlib import Path
from typing import Any, Mapping

from ...errors import ConfigError
from ...render.variants import set_render_threads
from ...scene import scene_from_dict
from .labels import CLASS_LABELS, spec_class_table, write_item
from .spec import DatasetSpec, ItemPlan

__all__ = ["item_task", "render_item", "class_map"]


def item_task(spec: DatasetSpec, plan: ItemPlan, output: str | Path, *,
              render_threads: int | None = None) -> dict:
    """The task :func:`render_item` takes for a planned item (plain data: it travels to the
    worker by pickling).

    Parameters
    ----------
    spec
        The dataset spec (its hash and outputs go into the item's meta.json).
    plan
        From :meth:`DatasetSpec.plan_item`; must have a scene (``plan.error`` None).
    output
        The dataset folder; the item goes to ``<output>/items/<id>``.
    render_threads
        Mitsuba threads on the worker (None: Mitsuba's default, all cores).

    Returns
    -------
    dict
        ``{"index", "id", "split", "seed", "params", "scene", "path", "outputs", "spec_hash",
        "render_threads", "measure_blur", "classes"}`` (``classes``: the spec's class map,
        :func:`~.labels.spec_class_table`, where an output names classes; else None).

    Raises
    ------
    ConfigError
        When the plan has no valid scene.
    """
    if plan.scene is None:
        raise ConfigError(f"item {plan.id} has no valid scene: {plan.error}")
    return {"index": plan.index, "id": plan.id, "split": spec.split_of(plan.index), "seed": plan.seed,
            "params": plan.params, "scene": plan.scene,
            "path": str(Path(output).resolve() / "items" / plan.id), "outputs": list(spec.outputs),
            "spec_hash": spec.hash, "render_threads": render_threads, "measure_blur": bool(spec.sweeps),
            "classes": class_map(spec)}


def class_map(spec: DatasetSpec) -> list[dict] | None:
    """The spec's class map (one per spec: its ids are the same for every item), where its outputs name classes."""
    if not set(spec.outputs) & set(CLASS_LABELS):
        return None
    if spec.hash not in _CLASS_MAPS:  # the hash holds everything the scenes come from
        _CLASS_MAPS[spec.hash] = spec_class_table(spec)
    return _CLASS_MAPS[spec.hash]


#: Class maps by spec hash (planning calls :func:`class_map` once per item).
_CLASS_MAPS: dict[str, list[dict]] = {}


def render_item(task: Mapping[str, Any]) -> dict:
    """Render one dataset item on a worker; never raises for a bad item.

    Parameters
    ----------
    task
        From :func:`item_task`.

    Returns
    -------
    dict
        A manifest row: ``status`` "done" with ``files``, or "failed" with ``error`` (the
        exception and message) and ``traceback``; ``seconds`` on this worker.

    References
    ----------
    .. [1] Python ``concurrent.futures``: a task's return value travels back to the driver;
       catching here keeps one poison item from failing the whole run.
    """
    started = time.perf_counter()
    row = {"index": task["index"], "id": task["id"], "seed": task["seed"], "params": task["params"]}
    try:
        set_render_threads(task.get("render_threads"))
        config = scene_from_dict(task["scene"])
        record = {key: task[key] for key in ("index", "id", "seed", "spec_hash", "params")}
        meta = write_item(config, task["path"], outputs=task["outputs"], measure_blur=task.get("measure_blur", False),
                          dataset={**record, "outputs": list(task["outputs"])}, classes=task.get("classes"))
        row.update(status="done", files=meta["files"], error=None, exposure_s=meta["sensor"]["exposure_s"],
                   variant=meta["render"]["variant"], file_checks=meta["dataset"]["file_checks"],
                   labels=meta["dataset"]["labels"])
    except Exception as exc:  # a poison item: record it, never take the run down
        row.update(status="failed", files=[], error=f"{type(exc).__name__}: {exc}",
                   traceback=traceback.format_exc(limit=8))
    row["seconds"] = time.perf_counter() - started
    row["worker_pid"] = os.getpid()
    return row
