"""What a dataset folder tells the tools that read it: ``metadata.jsonl`` (one row per finished
item, with a ``file_name`` column: Hugging Face ``datasets``' ImageFolder reads it as it is) and a
dataset card ``README.md`` (the spec, counts, every label with its units as :data:`~.labels.LABELS`
describes it, sources and licences).

References
----------
.. [1] Hugging Face ``datasets``, "Create an image dataset" (ImageFolder, ``metadata.jsonl``,
   ``file_name``, ``drop_labels``); "Dataset cards" (the README's YAML header).
.. [2] Gebru, T., et al. (2021). Datasheets for datasets. Commun. ACM 64(12), 86–92.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Mapping, Sequence

from ...io import atomic_path
from ...records import json_ready, read_json
from .hf import hf_configs, parquet_shards, webdataset_shards
from .labels import LABELS

__all__ = ["write_metadata", "write_card", "written_labels", "DATA_SOURCES"]

#: The data every item may draw on, and the terms each comes under.
DATA_SOURCES = (
    ("camera spectral sensitivities (17 cameras)", "pbrt-v4 / PhysLight measurements", "Apache-2.0"),
    ("illuminants, CIE 1931 CMFs, ColorChecker, CIE 2017, CRI and CQS samples, rawtoaces training set",
     "colour-science datasets (CIE 15:2004, CIE 224:2017, CIE 13.3, NIST, BabelColor, AMPAS)", "BSD-3-Clause"),
    ("leaf, dry vegetation, soil, wood and stone reflectances", "USGS Spectral Library Version 7 (Kokaly et al. 2017)",
     "public domain"),
    ("leaf reflectance and transmittance", "PROSPECT-D (Féret et al. 2017), computed by the `prosail` package",
     "generated at render time (the package's licence covers its code)"),
    ("lens prescriptions", "ISET/iset3d-v3; ray-optics; optiland (see spectral_cam/data/lenses)", "MIT / BSD-3-Clause"),
    ("Adobe's default tone curve", "Adobe DNG SDK 1.7", "DNG SDK License Agreement (royalty free, any purpose)"),
)


def _image_name(files: Sequence[str]) -> str | None:
    for name in files:
        if Path(name).stem == "image" and Path(name).suffix.lower() in (".png", ".jpg", ".jpeg", ".tif", ".tiff"):
            return name
    return None


def metadata_rows(rows: Mapping[int, dict]) -> list[dict]:
    """One row per finished item, in index order: ``file_name`` (the developed image, relative
    to the dataset folder), ``id``, ``index``, ``split``, ``seed``, every sampled parameter (its scene key)
    and ``<label>_file`` for every file the item holds."""
    out = []
    for index in sorted(rows):
        row = rows[index]
        if row.get("status") != "done":
            continue
        files = list(row.get("files") or [])  # relative to the dataset folder
        entry = {"file_name": _image_name(files), "id": row["id"], "index": row["index"],
                 "split": row.get("split") or "train", "seed": row.get("seed"), "exposure_s": row.get("exposure_s")}
        entry.update(row.get("params") or {})
        entry.update({f"{Path(name).stem}_file": name for name in files})
        out.append(entry)
    return out


def written_labels(row: Mapping) -> set[str]:
    """The outputs a finished item wrote a file for: its manifest row's ``labels`` (what each
    output wrote), or for a row from before they were recorded, the outputs named like one of
    its files (every label's main file is named after it: ``health`` → ``health.exr``)."""
    labels = row.get("labels")
    if isinstance(labels, Mapping):
        return {name for name, files in labels.items() if files}
    stems = {Path(name).stem for name in row.get("files") or []}
    return {name for name in LABELS if name in stems}


def write_metadata(output: Path, rows: Mapping[int, dict]) -> Path:
    """``output/metadata.jsonl`` (:func:`metadata_rows`), atomically."""
    path = Path(output) / "metadata.jsonl"
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as handle:
            for entry in metadata_rows(rows):
                handle.write(json.dumps(json_ready(entry), ensure_ascii=False, allow_nan=False, default=str) + "\n")
    return path


def _class_section(output: Path) -> list[str]:
    """The card's "Classes" section: classes.json's table (id, name, category, colour, pixels,
    items), or nothing for a dataset without it."""
    try:
        classes = json.loads((output / "classes.json").read_text(encoding="utf-8"))["classes"]
    except (OSError, ValueError, KeyError):
        return []
    lines = ["## Classes", "",
             "[`classes.json`](classes.json) is the class map of `semantic.png` (uint16 class ids, 0 = unlabelled: no "
             "surface, or sky where the scene has one and the class `sky` is listed) and of each instance's "
             "`class_id` in meta.json's `segmentation.instances` (`segmentation.png`: uint16 instance ids, 0 = "
             "none, the parts of one object one instance; each with its `bbox` [x, y, w, h] px, `area` px, "
             "`truncated`, `amodal_pixels` (its occlusion-free mask in the frame) and `visible_fraction` = area / "
             "amodal_pixels). Ids are fixed by the spec, the same in every "
             "item and resumed run; classes no item shows are left out.", "",
             "| id | class | category | colour (sRGB) | pixels | items |", "|---|---|---|---|---|---|"]
    lines += [f"| {c['id']} | `{c['name']}` | {c['category']} | {tuple(c['colour'])} | {c['pixels']} | {c['items']} |"
              for c in classes]
    return lines + [""]


def _split_lines(spec, done: Sequence[Mapping]) -> list[str]:
    """The card's "Splits" section: each split's fraction and items, and how items are assigned."""
    counts = {name: sum(1 for row in done if (row.get("split") or "train") == name) for name, _ in spec.splits}
    lines = ["", "## Splits", "", "| split | fraction | items |", "|---|---|---|"]
    lines += [f"| `{name}` | {fraction:g} | {counts[name]} |" for name, fraction in spec.splits]
    lines += ["", f"Each item's split is drawn from SHA-256 of (split seed {spec.effective_split_seed}, its index) "
              "alone: an item keeps its split when the dataset grows or resumes, and the counts are binomial about "
              "the fractions. `metadata.jsonl` and `manifest.jsonl` carry it in `split`."]
    return lines


def _preview_lines(output: Path) -> list[str]:
    """The card's "Previews" section, linking the label grid and the contact sheet where written."""
    shown = [(name, what) for name, what in (("label_preview.png", "labels of the first items beside their images"),
                                             ("contact_sheet.png", "developed images with their sampled values"))
             if (Path(output) / name).is_file()]
    if not shown:
        return []
    lines = ["", "## Previews", ""] + [f"- [{name}]({name}): {what}" for name, what in shown]
    if (Path(output) / "label_preview.png").is_file():
        lines += ["", "![labels of the first items](label_preview.png)"]
    return lines


def _scale_note(path: Path, name: str) -> str:
    """The scale an export folder's record states (the depth PNGs': metres per unit), as the card says it."""
    record = read_json(path / f"{name}.json") if path.is_dir() else None
    if not isinstance(record, dict) or "scale_m_per_unit" not in record:
        return ""
    scale = float(record["scale_m_per_unit"])
    return (f"; written here with **depth in metres = value × {scale:g}** ({record.get('convention', 'custom')} "
            f"convention, camera-space z, steps of {scale:g} m up to {65535 * scale:g} m; 0 = no depth)")


def _export_lines(output: Path, spec) -> list[str]:
    """The card's "Exports" section: each export the spec names (``[dataset] exports``) that is
    written, linked, with its units and conventions (the depth PNGs' scale as written)."""
    from .exports import EXPORTS, EXPORTS_DIR, exported

    found = {name: path for name, path in exported(output).items() if name in dict(spec.exports)}
    if not found:
        return []
    lines = ["", "## Exports", "", f"Written by the run into `{EXPORTS_DIR}/` from the finished items (replaced at "
             "each run; `spectral-cam export DIR --format NAME -o OUT` writes them anywhere):", ""]
    for name, path in found.items():
        link = path.relative_to(output).as_posix()
        target = link if path.is_file() else f"{link}/README.md"
        lines.append(f"- [`{link}`]({target}) (`{name}`): {EXPORTS[name].description}{_scale_note(path, name)}")
    return lines


def _in_order(shards: Mapping[str, list], splits: Sequence[str]) -> dict[str, list]:
    """Shards by split in the spec's split order (others after, by name)."""
    return {name: shards[name] for name in [*splits, *sorted(set(shards) - set(splits))] if name in shards}


def _hf_lines(parquet: Mapping, tars: Mapping) -> list[str]:
    """How to load the shards (the typed Parquet rows; the WebDataset tars), or how to add them."""
    lines = []
    if parquet:
        lines += ["Hugging Face `datasets` reads the typed rows in `data/` (the YAML header above names them per "
                  "split; PNG labels as `Image`, EXR, DNG and JSON labels as arrays and numbers, `meta_json`, "
                  "`camera_json` and `illuminant_json` whole), from any working folder:", "", "```python",
                  "import datasets",
                  "splits = datasets.load_dataset('DATASET_DIR')                     # DatasetDict: "
                  + ", ".join(parquet),
                  "part = splits['" + next(iter(parquet)) + "'].with_format('numpy')   # part[0]['depth']: "
                  "(H, W) float32 m", "```", ""]
    else:
        lines += ["Typed Hugging Face rows (every label decoded, one split each) are written where the `datasets` "
                  "package is installed: `pip install 'spectral_cam[hf]'`, then rerun the same "
                  "`spectral-cam dataset` command (it resumes and writes `data/`).", ""]
    if tars:
        first = next(iter(tars))
        lines += ["WebDataset tars stream the item files as they are (keys are item ids):", "", "```python",
                  "import webdataset as wds",
                  f"for sample in wds.WebDataset('webdataset/split={first}/{{000000..{len(tars[first]) - 1:06d}}}.tar', "
                  "shardshuffle=False):",
                  "    sample['__key__'], sample['image.png'], sample['depth.exr']    # bytes of each file",
                  "```", ""]
    return lines


def write_card(output: Path, spec, rows: Mapping[int, dict], *, spec_hash: str) -> Path:
    """``output/README.md``: the dataset card (a YAML header Hugging Face reads, then the spec,
    counts, the labels the items hold with units, layout, how to load it, sources and
    licences). A label asked for but written by no item (``health`` on a ColorChecker) is not in
    the table but listed apart with what it needs; one written by some items says by how many."""
    done = [r for r in rows.values() if r.get("status") == "done"]
    failed = sum(1 for r in rows.values() if r.get("status") == "failed")
    outputs = list(spec.outputs)
    splits = [name for name, _ in spec.splits]
    parquet, tars = (_in_order(found, splits) for found in (parquet_shards(output), webdataset_shards(output)))
    lines = ["---", "pretty_name: spectral_cam synthetic camera dataset",
             "tags: [synthetic, raw, spectral, depth, camera-simulation]",
             *(hf_configs(parquet, splits) if parquet else ["configs:", "- config_name: default", "  drop_labels: true"]),
             "---", "",
             "# Synthetic camera dataset (spectral_cam)", "",
             f"{len(done)} items rendered ({failed} failed, {len(rows)} planned) from a spectral scene through a "
             "thin lens, a simulated sensor (photons, shot, read and dark noise, ADC) and an ISP, by "
             "spectral_cam. Spec hash `" + spec_hash[:16] + "`; `dataset.json` holds the whole spec, "
             "`manifest.jsonl` every item's status, seed and parameters.", "",
             "## Labels", "", "| label | file | values and units |", "|---|---|---|"]
    written = {name: sum(1 for row in done if name in written_labels(row)) for name in outputs}
    for name in outputs:  # each label's own description: "<file>: <values and units>"
        if written[name]:
            file, _, units = LABELS[name].description.partition(": ")
            share = "" if written[name] == len(done) else f" (in {written[name]} of the {len(done)} items)"
            lines.append(f"| `{name}` | `{file}` | {units}{share} |")
    missing = [name for name in outputs if not written[name]]
    if missing and done:
        lines += ["", "Asked for but written by no item (the scenes here cannot produce them):", ""]
        lines += [f"- `{name}`: {LABELS[name].description}" for name in missing]
    lines += ["", "Every item folder also holds `meta.json`: the resolved scene, optics, sensor (gain, exposure, "
              "noise parameters, seeds), the model decisions and the sampled parameters.", ""]
    lines += _class_section(Path(output))
    lines += ["## Sampled parameters", ""]
    if spec.distributions:
        lines += [f"- `{key}`: {json.dumps(json_ready(value.to_dict()))}" for key, value in sorted(spec.distributions.items())]
    if spec.sweeps:
        lines += [f"- sweep `{sweep.key}`: {json.dumps(json_ready(list(sweep.values)))}" for sweep in spec.sweeps]
    if not spec.distributions and not spec.sweeps:
        lines.append("None: every item is the same scene with its own noise and sample seeds.")
    lines += _split_lines(spec, done)
    lines += _preview_lines(output)
    lines += _export_lines(Path(output), spec)
    lines += ["", "## Layout", "", "    metadata.jsonl        one row per item: file_name (the image), id, split, seed, "
              "parameters, <label>_file paths",
              "    manifest.jsonl        every planned item: status, seed, parameters, files, errors",
              "    items/NNNNNN/         one folder per item: the labels above and meta.json",
              *(["    data/split=S/*.parquet  typed Hugging Face rows of split S: every label decoded (below)"]
                if parquet else []),
              *(["    webdataset/split=S/*.tar  WebDataset shards of split S: each item's files as <id>.<file name>"]
                if tars else []),
              *(["    exports/              COCO instances, 16-bit depth PNGs, .flo flow (Exports, above)"]
                if spec.exports else []), "",
              "## Loading", "", *_hf_lines(parquet, tars), "```python",
              "from spectral_cam.apps.dataset import SyntheticDataset   # NumPy arrays per item",
              "item = SyntheticDataset('.')[0]                          # item['image'], item['depth'], ...",
              "", "import datasets                                          # Hugging Face, the image and label paths",
              "files = datasets.load_dataset('imagefolder', data_dir='.', split='train')   # from metadata.jsonl",
              "```", "",
              "`SyntheticDataset` is a map-style dataset whose items PyTorch's default collate batches: "
              "`torch.utils.data.DataLoader(SyntheticDataset('.'), batch_size=4)` (items of one size; "
              "`transform=[Resize(h, w), Crop(h, w)]` makes them so and keeps `camera['K']` consistent; "
              "`records(i)` holds meta.json).", "",
              "## Sources and licences", "", "| data | source | licence |", "|---|---|---|"]
    lines += [f"| {what} | {source} | {licence} |" for what, source, licence in DATA_SOURCES]
    lines += ["", "Images, labels and metadata here were generated by spectral_cam; they carry no third-party "
              "image content.", ""]
    path = Path(output) / "README.md"
    with atomic_path(path) as tmp:
        Path(tmp).write_text("\n".join(lines), encoding="utf-8")
    return path
