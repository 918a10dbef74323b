"""Describe a dataset: the info summary, the dataset card and Croissant metadata.

Every number in these descriptions is computed from the store (its attributes,
model records, failure log and arrays); nothing is typed by hand.

- :func:`dataset_info` / :func:`info_from_reader`: a JSON-safe summary (counts
  per category and split, sizes, conventions, quality statistics, failures),
  rendered for the terminal by :func:`format_info`.
- :func:`render_card`: the ``README.md`` of a release, filled in from
  ``dataset_card/template.md`` with a YAML header in the style of dataset hubs
  and the sections of "Datasheets for Datasets" (Gebru et al.).
- :func:`croissant_jsonld`: Croissant 1.0 JSON-LD metadata whose FileObjects
  carry the SHA-256 of each file.
"""

from __future__ import annotations

import importlib.resources
import json
import math
import string
from collections import Counter
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vptoolkit.conventions import HIGHER_IS_BETTER, MEASURES
from vptoolkit.dataset.parquet import (
    VIEWS_CONFIG,
    Column,
    ParquetShard,
    model_columns,
    view_columns,
)
from vptoolkit.dataset.store import SPLITS, published_split
from vptoolkit.errors import InputError

if TYPE_CHECKING:
    from vptoolkit.dataset.store import StoreReader

__all__ = [
    "SPLIT_ORDER",
    "size_category",
    "info_from_reader",
    "dataset_info",
    "format_info",
    "render_card",
    "hub_yaml",
    "croissant_jsonld",
    "card_sections",
    "rai_fields",
]

SPLIT_ORDER = SPLITS
"""Order of the splits in every table; any other split name follows, sorted."""

LOG_BASE = 2
"""Base of the logarithms in VE, VKL and VMI (``vptoolkit.measures``): values are in bits."""

_MEASURE_NAMES = {
    "VE": ("viewpoint entropy", "bits"),
    "VR": ("visibility ratio", "fraction of the surface area"),
    "VKL": ("viewpoint Kullback-Leibler divergence", "bits"),
    "VMI": ("viewpoint mutual information", "bits"),
}

_ARRAY_MEANINGS = {
    "views": "unit view directions, model centre to camera (Fibonacci sphere)",
    "points": "points sampled uniformly by area on the cleaned mesh",
    "normals": "unit face normal at each point",
    "quality": "normalised quality in [0, 1], 1 = best",
    "quality_raw": "raw measures, NaN where a view sees nothing",
    "best_index": "index into `views` of the best view per measure",
    "best_value": "raw value at the best view",
    "worst_index": "index into `views` of the worst view per measure",
    "worst_value": "raw value at the worst view",
    "mesh_vertices": "cleaned mesh vertices of all models, concatenated",
    "mesh_vertex_offsets": "model m owns vertex rows offsets[m]:offsets[m+1]",
    "mesh_faces": "faces, indices local to the model's vertices",
    "mesh_face_offsets": "model m owns face rows offsets[m]:offsets[m+1]",
    "models_json": "UTF-8 JSON list of model records in row order",
    "failures_json": "UTF-8 JSON list of inputs that could not be processed",
}

_SIZE_STEPS = (
    (10**3, "n<1K"), (10**4, "1K<n<10K"), (10**5, "10K<n<100K"), (10**6, "100K<n<1M"),
    (10**7, "1M<n<10M"), (10**8, "10M<n<100M"), (10**9, "100M<n<1B"),
    (10**10, "1B<n<10B"), (10**11, "10B<n<100B"), (10**12, "100B<n<1T"),
)

_CROISSANT_CONTEXT: dict[str, Any] = {
    "@language": "en",
    "@vocab": "https://schema.org/",
    "arrayShape": "cr:arrayShape",
    "citeAs": "cr:citeAs",
    "column": "cr:column",
    "conformsTo": "dct:conformsTo",
    "containedIn": "cr:containedIn",
    "cr": "http://mlcommons.org/croissant/",
    "rai": "http://mlcommons.org/croissant/RAI/",
    "data": {"@id": "cr:data", "@type": "@json"},
    "dataType": {"@id": "cr:dataType", "@type": "@vocab"},
    "dct": "http://purl.org/dc/terms/",
    "equivalentProperty": "cr:equivalentProperty",
    "examples": {"@id": "cr:examples", "@type": "@json"},
    "extract": "cr:extract",
    "field": "cr:field",
    "fileProperty": "cr:fileProperty",
    "fileObject": "cr:fileObject",
    "fileSet": "cr:fileSet",
    "format": "cr:format",
    "includes": "cr:includes",
    "isArray": "cr:isArray",
    "isLiveDataset": "cr:isLiveDataset",
    "jsonPath": "cr:jsonPath",
    "key": "cr:key",
    "md5": "cr:md5",
    "parentField": "cr:parentField",
    "path": "cr:path",
    "recordSet": "cr:recordSet",
    "references": "cr:references",
    "regex": "cr:regex",
    "repeated": "cr:repeated",
    "replace": "cr:replace",
    "samplingRate": "cr:samplingRate",
    "sc": "https://schema.org/",
    "separator": "cr:separator",
    "source": "cr:source",
    "subField": "cr:subField",
    "transform": "cr:transform",
}

_CITATION = """@article{schelling2021viewpoint,
  title   = {Enabling Viewpoint Learning through Dynamic Label Generation},
  author  = {Schelling, Michael and Hermosilla, Pedro and V{\\'a}zquez, Pere-Pau and Ropinski, Timo},
  journal = {Computer Graphics Forum},
  volume  = {40},
  number  = {2},
  year    = {2021}
}"""

_ENCODINGS = (
    (".zarr.zip", "application/zip", "Zarr v3 store in a zip file"),
    (".parquet", "application/x-parquet", "Parquet shard"),
    (".csv", "text/csv", "CSV table"),
    (".h5", "application/x-hdf5", "HDF5 file"),
    (".hdf5", "application/x-hdf5", "HDF5 file"),
    (".md", "text/markdown", "dataset card"),
    (".json", "application/json", "JSON metadata"),
)


# --------------------------------------------------------------------------- helpers


def size_category(n_models: int) -> str:
    """Return the dataset-hub size category of ``n_models`` examples.

    Examples
    --------
    >>> size_category(999), size_category(1000), size_category(16000)
    ('n<1K', '1K<n<10K', '10K<n<100K')
    """
    if n_models < 0:
        raise InputError(f"n_models: must be >= 0, got {n_models}")
    for limit, label in _SIZE_STEPS:
        if n_models < limit:
            return label
    return "n>1T"


def _json_safe(value: Any) -> Any:
    """Turn numpy scalars and arrays, tuples and non-finite floats into JSON types."""
    if isinstance(value, Mapping):
        return {str(key): _json_safe(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(item) for item in value]
    if isinstance(value, np.ndarray):
        return _json_safe(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        number = float(value)
        return number if math.isfinite(number) else None
    return value


def _ordered_splits(splits: Sequence[str] | set[str]) -> list[str]:
    present = set(splits)
    return [s for s in SPLIT_ORDER if s in present] + sorted(present - set(SPLIT_ORDER))


def _summary(values: Sequence[float] | np.ndarray) -> dict[str, float | None]:
    """Mean, min and max ignoring NaN; None where there is nothing to summarise."""
    array = np.asarray(values, dtype=np.float64)
    finite = array[np.isfinite(array)]
    if finite.size == 0:
        return {"mean": None, "min": None, "max": None}
    return {"mean": float(finite.mean()), "min": float(finite.min()), "max": float(finite.max())}


def _fmt(value: float | int | None, digits: int = 4) -> str:
    """Format a statistic for a table: ``-`` for missing, integers as is."""
    if value is None:
        return "-"
    if isinstance(value, int) or (math.isfinite(value) and float(value).is_integer()):
        return str(int(value))
    if abs(value) >= 10 ** digits:
        return f"{value:.1f}"
    return f"{value:.{digits}g}"


def _plural(count: int, noun: str) -> str:
    """``1 model``, ``2 models``."""
    return f"{count} {noun}{'' if count == 1 else 's'}"


def _cell(text: Any) -> str:
    """Escape a value for a Markdown table cell."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def _yaml_str(text: str) -> str:
    """Quote a string for YAML (a JSON string is a valid YAML double-quoted scalar)."""
    return json.dumps(text, ensure_ascii=False)


# --------------------------------------------------------------------------- info


def info_from_reader(reader: StoreReader) -> dict[str, Any]:
    """Summarise an open store as JSON types.

    Parameters
    ----------
    reader : StoreReader
        An open store (:func:`vptoolkit.dataset.store.open_store`).

    Returns
    -------
    dict
        ``store`` (file name), ``store_kind``, ``format``, ``schema_version``,
        ``n_models``, ``n_views``, ``n_points`` (per model), ``resolution``,
        ``backend``, ``categories`` and ``splits`` (ordered),
        ``counts`` (category -> split -> models, every pair present),
        ``split_totals``, ``category_totals``, ``measures`` (order,
        higher_is_better, log_base, units, normalisation), ``camera``,
        ``cleaning``, ``split_seed``, ``split_fractions``, ``source``,
        ``toolkit_version``, ``created``, ``dataset_version`` (of a release,
        else None), ``statistics`` (best raw value per
        measure; vertex and face counts) and ``failures`` (records with
        ``source``, ``category``, ``reason``) with ``n_failures``.
    """
    attrs = dict(reader.attrs)
    models = [{**record, "split": published_split(str(record["split"]))}
              for record in reader.models()]
    failures = reader.failures()
    if isinstance(attrs.get("split_fractions"), Mapping):
        attrs["split_fractions"] = {published_split(str(name)): value
                                    for name, value in attrs["split_fractions"].items()}
    categories = sorted({str(record["category"]) for record in models})
    splits = _ordered_splits({str(record["split"]) for record in models})
    pairs = Counter((str(record["category"]), str(record["split"])) for record in models)
    counts = {c: {s: int(pairs[(c, s)]) for s in splits} for c in categories}
    split_totals = {s: sum(counts[c][s] for c in categories) for s in splits}
    category_totals = {c: sum(counts[c].values()) for c in categories}

    best_value = np.asarray(reader.array("best_value")[:], dtype=np.float64).reshape(-1, len(MEASURES))
    best_stats = {m: _summary(best_value[:, i]) for i, m in enumerate(MEASURES)}
    faces = [record.get("n_faces") for record in models if record.get("n_faces") is not None]
    vertices = [record.get("n_vertices") for record in models if record.get("n_vertices") is not None]
    cleaning_records = [record["cleaning"] for record in models if record.get("cleaning")]
    faces_before = [
        report["faces_before"] for report in cleaning_records if "faces_before" in report
    ]
    statistics: dict[str, Any] = {
        "best_value": best_stats,
        "faces": _summary(faces),
        "vertices": _summary(vertices),
        "total_faces": int(sum(faces)),
        "total_vertices": int(sum(vertices)),
        "n_cleaned": len(cleaning_records),
        "faces_before_cleaning": _summary(faces_before),
    }

    higher = attrs.get("higher_is_better", list(HIGHER_IS_BETTER))
    order = attrs.get("measures", list(MEASURES))
    info = {
        "store": Path(reader.path).name,
        "store_kind": reader.kind,
        "format": attrs.get("format"),
        "schema_version": attrs.get("schema_version"),
        "n_models": len(models),
        "n_views": attrs.get("n_views", int(reader.array("views").shape[0])),
        "n_points": attrs.get("n_points"),
        "resolution": attrs.get("resolution"),
        "backend": attrs.get("backend"),
        "source": attrs.get("source"),
        "toolkit_version": attrs.get("toolkit_version"),
        "created": attrs.get("created"),
        "dataset_version": attrs.get("dataset_version"),
        "split_seed": attrs.get("split_seed"),
        "split_fractions": attrs.get("split_fractions"),
        "categories": categories,
        "splits": splits,
        "counts": counts,
        "split_totals": split_totals,
        "category_totals": category_totals,
        "measures": {
            "order": list(order),
            "higher_is_better": list(higher),
            "names": {m: _MEASURE_NAMES.get(m, (m, ""))[0] for m in order},
            "units": {m: _MEASURE_NAMES.get(m, (m, ""))[1] for m in order},
            "log_base": LOG_BASE,
            "normalisation": "per model over its views: (q - worst) / (best - worst); 1 = best",
        },
        "camera": attrs.get("camera"),
        "cleaning": attrs.get("cleaning"),
        "statistics": statistics,
        "n_failures": len(failures),
        "failures": [
            {key: record.get(key) for key in ("source", "category", "reason")}
            for record in failures
        ],
    }
    return _json_safe(info)  # type: ignore[no-any-return]


def dataset_info(path: Path | str) -> dict[str, Any]:
    """Summarise the dataset at ``path`` as JSON types.

    Parameters
    ----------
    path : Path or str
        A store, a build folder or a release folder (anything
        :func:`vptoolkit.dataset.store.find_store` accepts).

    Returns
    -------
    dict
        See :func:`info_from_reader`; ``path`` holds the store that was read.
    """
    from vptoolkit.dataset.store import find_store, open_store

    store_path = find_store(path)
    with open_store(store_path) as reader:
        info = info_from_reader(reader)
    info["path"] = str(store_path)
    return info


def _count_rows(info: Mapping[str, Any]) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the category x split table, with totals."""
    splits = list(info["splits"])
    header = ["category", *splits, "total"]
    rows = []
    for category in info["categories"]:
        row_counts = [info["counts"][category][s] for s in splits]
        rows.append([category, *map(str, row_counts), str(info["category_totals"][category])])
    totals = [info["split_totals"][s] for s in splits]
    rows.append(["total", *map(str, totals), str(info["n_models"])])
    return header, rows


def _text_table(header: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(line[i]) for line in [header, *rows]) for i in range(len(header))]

    def line(cells: list[str]) -> str:
        first = cells[0].ljust(widths[0])
        rest = [cell.rjust(width) for cell, width in zip(cells[1:], widths[1:])]
        return "  ".join([first, *rest]).rstrip()

    return "\n".join([line(header), *(line(row) for row in rows)])


def _camera_sentence(camera: Mapping[str, Any] | None) -> str:
    if not camera:
        return "not recorded"
    parts = [str(camera.get("projection", "perspective"))]
    if camera.get("fov_deg") is not None:
        parts.append(f"field of view {_fmt(camera['fov_deg'])} deg")
    if camera.get("distance_factor") is not None:
        unit = camera.get("distance_unit", "bounding-box diagonal")
        parts.append(f"distance {_fmt(camera['distance_factor'])} x {unit}")
    if camera.get("target"):
        parts.append(f"looking at the {camera['target']}")
    if camera.get("up") is not None:
        parts.append("up " + "(" + ", ".join(_fmt(c) for c in camera["up"]) + ")")
    if "cull_back_faces" in camera:
        parts.append("back faces culled" if camera["cull_back_faces"] else "back faces visible")
    return ", ".join(parts)


def _measures_sentence(info: Mapping[str, Any]) -> str:
    measures = info["measures"]
    parts = [
        f"{m} ({'higher' if hi else 'lower'} is better)"
        for m, hi in zip(measures["order"], measures["higher_is_better"])
    ]
    return (f"{', '.join(parts)}; logarithms base {measures['log_base']}; "
            f"normalised {measures['normalisation']}")


def format_info(info: Mapping[str, Any]) -> str:
    """Render :func:`dataset_info` as text for the terminal.

    Returns
    -------
    str
        Several lines, without a trailing newline.
    """
    lines = [
        f"{info.get('path', info['store'])} ({info['store_kind']}, schema "
        f"{info.get('schema_version')})",
        f"models {info['n_models']}, views {info['n_views']}, points per model "
        f"{info['n_points']}, resolution {info['resolution']} px ({info['backend']})",
        f"source {info['source']}, created {info['created']}, vptoolkit "
        f"{info['toolkit_version']}"
        + (f", dataset version {info['dataset_version']}" if info.get("dataset_version") else ""),
        f"measures: {_measures_sentence(info)}",
        f"camera: {_camera_sentence(info.get('camera'))}",
        "",
        _text_table(*_count_rows(info)),
        "",
    ]
    stats = info["statistics"]
    header = ["best raw value", "mean", "min", "max"]
    rows = [
        [m, _fmt(s["mean"]), _fmt(s["min"]), _fmt(s["max"])]
        for m, s in stats["best_value"].items()
    ]
    rows.append(["faces per model", _fmt(stats["faces"]["mean"]), _fmt(stats["faces"]["min"]),
                 _fmt(stats["faces"]["max"])])
    lines.append(_text_table(header, rows))
    lines.append("")
    lines.append(f"failures: {info['n_failures']}")
    for record in info["failures"]:
        lines.append(f"  {record.get('source')}: {record.get('reason')}")
    return "\n".join(lines)


# --------------------------------------------------------------------------- hub YAML


def _yaml_feature(column: Column) -> str:
    """One feature of a hub ``dataset_info``, as the hub's YAML writes it."""
    head = f"  - name: {column.name}\n"
    if not column.shape:
        return head + f"    dtype: {column.dtype}"
    if len(column.shape) == 1:
        return head + f"    list: {column.dtype}\n    length: {column.shape[0]}"
    dims = "\n".join(f"        - {'null' if d is None else d}" for d in column.shape)
    return (head + f"    dtype:\n      array{len(column.shape)}_d:\n        shape:\n{dims}\n"
            f"        dtype: {column.dtype}")


def hub_yaml(shards: Sequence[ParquetShard], *, n_points: int, n_views: int) -> str:
    """The ``configs`` and ``dataset_info`` blocks of a card's YAML header.

    Two configurations: ``default`` (one Parquet shard per split, one row
    per model, columns :func:`~vptoolkit.dataset.parquet.model_columns`) and
    ``views`` (the shared view directions, as split ``train``, the hub's
    name for a configuration's only split). ``datasets.load_dataset(release)``
    then reads the shards, offline or streaming, with the declared features.

    Parameters
    ----------
    shards : sequence of ParquetShard
        What :func:`~vptoolkit.dataset.parquet.write_parquet_shards` wrote.
    n_points, n_views : int
        Points and views per model, the shapes of the array features.

    Returns
    -------
    str
        YAML lines without a trailing newline.
    """
    model_shards = [shard for shard in shards if shard.split != VIEWS_CONFIG]
    view_shards = [shard for shard in shards if shard.split == VIEWS_CONFIG]
    lines = ["configs:", "- config_name: default", "  default: true", "  data_files:"]
    lines += [f"  - split: {shard.split}\n    path: {shard.path}" for shard in model_shards]
    for shard in view_shards:
        lines += [f"- config_name: {VIEWS_CONFIG}", "  data_files:",
                  f"  - split: train\n    path: {shard.path}"]
    lines.append("dataset_info:")
    configs = [("default", model_columns(n_points, n_views), model_shards),
               (VIEWS_CONFIG, view_columns(), view_shards)]
    for config_name, columns, chosen in configs:
        if not chosen:
            continue
        lines += [f"- config_name: {config_name}", "  features:"]
        lines += [_yaml_feature(column) for column in columns]
        lines.append("  splits:")
        for shard in chosen:
            split = "train" if config_name == VIEWS_CONFIG else shard.split
            lines += [f"  - name: {split}", f"    num_bytes: {shard.num_bytes}",
                      f"    num_examples: {shard.n_rows}"]
        lines.append(f"  dataset_size: {sum(shard.num_bytes for shard in chosen)}")
    return "\n".join(lines)


# --------------------------------------------------------------------------- card


def _load_template(name: str) -> str:
    resource = importlib.resources.files("vptoolkit.dataset_card").joinpath(name)
    return resource.read_text(encoding="utf-8")


def _markdown_table(header: Sequence[str], rows: Sequence[Sequence[Any]],
                    align: Sequence[str] | None = None) -> str:
    align = align or ["l"] + ["r"] * (len(header) - 1)
    rule = ["---:" if a == "r" else "---" for a in align]
    lines = ["| " + " | ".join(_cell(h) for h in header) + " |",
             "| " + " | ".join(rule) + " |"]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def _source_name(info: Mapping[str, Any]) -> str:
    return str(info.get("source") or "unknown")


def _array_rows(reader: StoreReader) -> list[list[str]]:
    rows = []
    for name in sorted(reader.array_names()):
        array = reader.array(name)
        shape = "(" + ", ".join(str(int(n)) for n in array.shape) + ("," if len(array.shape) == 1 else "") + ")"
        rows.append([f"`{name}`", shape, str(np.dtype(array.dtype)),
                     _ARRAY_MEANINGS.get(name, "")])
    return rows


def render_card(
    reader: StoreReader,
    files: Mapping[str, str],
    *,
    license: str = "other",  # noqa: A002 - the dataset-hub field is called license
    pretty_name: str | None = None,
    file_sizes: Mapping[str, int] | None = None,
    shards: Sequence[ParquetShard] | None = None,
    version: str = "1.0.0",
    created: str | None = None,
    source_url: str | None = None,
    license_name: str | None = None,
    license_link: str | None = None,
    warnings: Sequence[str] = (),
) -> str:
    """Fill ``dataset_card/template.md`` into a release ``README.md``.

    Parameters
    ----------
    reader : StoreReader
        The store the card describes.
    files : mapping of str to str
        Release file name -> SHA-256 hex digest, listed in the card.
    license : str
        Licence identifier for the YAML header (default: ``"other"``; the
        toolkit cannot know the source meshes' licences, which apply).
    pretty_name : str, optional
        Human-readable title (default: derived from the source folder name).
    file_sizes : mapping of str to int, optional
        Release file name -> size in bytes, listed beside the digests.
    shards : sequence of ParquetShard, optional
        The release's Parquet shards; the YAML header then carries the hub's
        ``configs`` and a full ``dataset_info`` (see :func:`hub_yaml`).
    version : str
        Dataset version (default: ``"1.0.0"``).
    created : str, optional
        Release time (default: the store's ``created``).
    source_url : str, optional
        Where the source meshes come from.
    license_name, license_link : str, optional
        The hub's fields for a licence ``other``.
    warnings : sequence of str
        Lines shown in a warning block at the top (an empty split, say).

    Returns
    -------
    str
        Markdown with a YAML front matter block. Each model record's
        ``provenance`` (licence, author, url) is tabled under the licence
        note.
    """
    info = info_from_reader(reader)
    source = _source_name(info)
    title = pretty_name or f"Viewpoint quality of {source} models"
    stats = info["statistics"]
    sizes = file_sizes or {}
    measures = info["measures"]
    cleaning = info.get("cleaning") or {}
    fractions = info.get("split_fractions") or {}

    if shards:
        yaml_hub = hub_yaml(shards, n_points=int(info["n_points"] or 0),
                            n_views=int(info["n_views"]))
    else:
        yaml_splits = "\n".join(
            f"  - name: {_yaml_str(s)}\n    num_examples: {info['split_totals'][s]}"
            for s in info["splits"]
        ) or "  []"
        yaml_hub = f"dataset_info:\n  config_name: default\n  splits:\n{yaml_splits}"

    count_header, count_rows = _count_rows(info)
    measure_rows = [
        [m, measures["names"][m], "higher" if hi else "lower", measures["units"][m],
         _fmt(stats["best_value"][m]["mean"]), _fmt(stats["best_value"][m]["min"]),
         _fmt(stats["best_value"][m]["max"])]
        for m, hi in zip(measures["order"], measures["higher_is_better"])
    ]
    file_rows = [[f"`{name}`", str(sizes[name]) if name in sizes else "-", f"`{digest}`"]
                 for name, digest in sorted(files.items())]
    failure_rows = [[f"`{r.get('source')}`", r.get("category") or "-", r.get("reason") or "-"]
                    for r in info["failures"]]
    reasons = Counter(str(r.get("reason")) for r in info["failures"])
    if cleaning.get("enabled"):
        cleaning_sentence = (
            "Every mesh went through the toolkit's cleaning pipeline (`vptoolkit.clean`): "
            "self-intersections resolved, faces hidden from every view removed, then "
            f"simplified to at most {cleaning.get('max_faces')} faces. Each model record "
            "keeps the cleaning report (`cleaning`)."
        )
    else:
        cleaning_sentence = ("The meshes were not cleaned (built with `--no-clean`); "
                             "the measures are computed on the source meshes as read.")
    split_sentence = ", ".join(f"{name} {_fmt(value)}" for name, value in fractions.items())

    license_extra = "".join(
        f"\n{key}: {_yaml_str(value)}"
        for key, value in (("license_name", license_name), ("license_link", license_link))
        if value
    )
    records = reader.models()
    licensed = [r for r in records if r.get("provenance")]
    provenance_rows = [
        [f"`{r['name']}`", r["provenance"].get("license", "-"),
         r["provenance"].get("author", "-"), r["provenance"].get("url", "-")]
        for r in licensed
    ]
    if licensed:
        provenance_sentence = (
            f"The licence and attribution of {_plural(len(licensed), 'source mesh')}"
            f"{'' if len(licensed) == len(records) else f' (of {len(records)})'} are "
            "recorded per model (`provenance` in each model record, the `license`, `author` "
            "and `url` columns of the Parquet shards, and `LICENSES.csv`):"
        )
    else:
        provenance_sentence = ("vptoolkit was given no licence table for them "
                               "(`vptool pack --licenses FILE.csv`); check them before "
                               "redistributing.")
    formats = [label for suffix, label in ((".zarr.zip", "a Zarr v3 zip store"),
                                           (".h5", "an HDF5 file"),
                                           (".parquet", "Parquet shards per split"))
               if any(name.endswith(suffix) for name in files)]
    archives = [name for name in sorted(files) if name.endswith(".zarr.zip")]
    hdf5_files = [name for name in sorted(files) if name.endswith((".h5", ".hdf5"))]
    n_failures = info["n_failures"]
    values = {
        "models_phrase": _plural(info["n_models"], "model"),
        "failures_phrase": (
            f"{_plural(n_failures, 'input')} could not be processed; "
            f"{'it is' if n_failures == 1 else 'they are'} listed below and in the "
            "`failures_json` array." if n_failures else "No input failed."
        ),
        "zarr_zip_name": archives[0] if archives else "dataset.zarr.zip",
        "hdf5_name": hdf5_files[0] if hdf5_files else "dataset.h5",
        "yaml_pretty_name": _yaml_str(title),
        "yaml_license": _yaml_str(license),
        "yaml_license_extra": license_extra,
        "version": version,
        "source_url_sentence": f" Source meshes: <{source_url}>." if source_url else "",
        "warnings_block": "".join(f"\n> **Warning.** {line}.\n" for line in warnings),
        "provenance_sentence": provenance_sentence,
        "provenance_table": (_markdown_table(["model", "licence", "author", "url"],
                                             provenance_rows, ["l", "l", "l", "l"])
                             if provenance_rows else ""),
        "formats_sentence": " and ".join(formats) or "no archive",
        "split_names": ", ".join(f"`{s}`" for s in info["splits"]),
        "yaml_size_category": _yaml_str(size_category(info["n_models"])),
        "yaml_hub": yaml_hub,
        "title": title,
        "license": license,
        "source": source,
        "n_models": info["n_models"],
        "n_categories": len(info["categories"]),
        "categories": ", ".join(f"`{c}`" for c in info["categories"]) or "none",
        "n_views": info["n_views"],
        "n_points": info["n_points"],
        "resolution": info["resolution"],
        "backend": info["backend"],
        "camera": _camera_sentence(info.get("camera")),
        "measure_order": ", ".join(measures["order"]),
        "log_base": measures["log_base"],
        "normalisation": measures["normalisation"],
        "split_seed": info.get("split_seed"),
        "split_fractions": split_sentence or "not recorded",
        "toolkit_version": info.get("toolkit_version"),
        "created": created or info.get("created"),
        "cleaning_sentence": cleaning_sentence,
        "n_failures": info["n_failures"],
        "failure_reasons": (
            "; ".join(f"{reason} ({n})" for reason, n in sorted(reasons.items()))
            or "none"
        ),
        "failures_table": (_markdown_table(["source", "category", "reason"], failure_rows,
                                           ["l", "l", "l"])
                           if failure_rows else ""),
        "count_table": _markdown_table(count_header, count_rows),
        "measure_table": _markdown_table(
            ["measure", "name", "best", "raw unit", "best raw mean", "best raw min",
             "best raw max"], measure_rows, ["l", "l", "l", "l", "r", "r", "r"]),
        "schema_table": _markdown_table(["array", "shape", "dtype", "meaning"],
                                        _array_rows(reader), ["l", "l", "l", "l"]),
        "files_table": _markdown_table(["file", "bytes", "sha256"], file_rows,
                                       ["l", "r", "l"]),
        "mean_faces": _fmt(stats["faces"]["mean"]),
        "min_faces": _fmt(stats["faces"]["min"]),
        "max_faces": _fmt(stats["faces"]["max"]),
        "mean_vertices": _fmt(stats["vertices"]["mean"]),
        "n_cleaned": stats["n_cleaned"],
        "mean_faces_before": _fmt(stats["faces_before_cleaning"]["mean"]),
        "citation": _CITATION,
    }
    template = string.Template(_load_template("template.md"))
    try:
        return template.substitute({key: str(value) for key, value in values.items()})
    except (KeyError, ValueError) as err:
        raise InputError(f"template.md: cannot fill placeholder ({err})") from err


# --------------------------------------------------------------------------- croissant


def _encoding(name: str) -> tuple[str, str]:
    for suffix, mime, description in _ENCODINGS:
        if name.endswith(suffix):
            return mime, description
    return "application/octet-stream", "file"


_CROISSANT_TYPES = {
    "string": "sc:Text",
    "float32": "cr:Float32",
    "float64": "cr:Float64",
    "int32": "cr:Int32",
    "int64": "cr:Int64",
}

_RAI_SECTIONS = (
    # (rai property, card section, bullet prefix or None for the whole section)
    ("rai:dataCollection", "Collection process", None),
    ("rai:dataCollectionType", "Collection process", "- The source meshes"),
    ("rai:dataPreprocessingProtocol", "Preprocessing, cleaning and labeling", None),
    ("rai:dataAnnotationProtocol", "Preprocessing, cleaning and labeling", "- Labels are"),
    ("rai:dataUseCases", "Uses", None),
    ("rai:dataLimitations", "Uses", "- Not suitable"),
    ("rai:dataBiases", "Uses", "- Results depend"),
    ("rai:personalSensitiveInformation", "Composition", "- *Confidential or personal data?*"),
    ("rai:dataReleaseMaintenancePlan", "Maintenance", None),
)


def card_sections(card: str) -> dict[str, str]:
    """The ``## `` sections of a card's Markdown body, heading -> text.

    Text is joined into single spaces, with Markdown emphasis and code marks
    kept; the YAML header is skipped.
    """
    body = card.split("\n---\n", 1)[1] if card.startswith("---\n") else card
    sections: dict[str, list[str]] = {}
    current: list[str] | None = None
    for line in body.splitlines():
        if line.startswith("## "):
            current = sections.setdefault(line[3:].strip(), [])
        elif line.startswith("# "):
            current = None
        elif current is not None:
            current.append(line)
    return {heading: "\n".join(lines).strip() for heading, lines in sections.items()}


def _bullets(text: str) -> list[str]:
    """The bullets of a section, each joined onto one line."""
    items: list[str] = []
    for line in text.splitlines():
        if line.startswith("- "):
            items.append(line.strip())
        elif items and line.startswith("  ") and line.strip():
            items[-1] += " " + line.strip()
    return items


def rai_fields(card: str) -> dict[str, str]:
    """The Croissant RAI fields, each taken from a section (or one bullet) of the datasheet."""
    sections = card_sections(card)
    fields = {}
    for key, heading, prefix in _RAI_SECTIONS:
        bullets = _bullets(sections.get(heading, ""))
        if prefix is not None:
            bullets = [item for item in bullets if item.startswith(prefix)]
        text = " ".join(item[2:] for item in bullets)
        if text:
            fields[key] = text
    return fields


def _croissant_field(record_set: str, column: Column, source: dict[str, Any]) -> dict[str, Any]:
    spec: dict[str, Any] = {
        "@type": "cr:Field",
        "@id": f"{record_set}/{column.name}",
        "name": column.name,
        "description": column.description,
        "dataType": _CROISSANT_TYPES[column.dtype],
        "source": {**source, "extract": {"column": column.name}},
    }
    if column.shape:
        spec["isArray"] = True
        spec["arrayShape"] = ",".join("-1" if d is None else str(d) for d in column.shape)
    return spec


def croissant_jsonld(
    reader: StoreReader,
    files: Mapping[str, str],
    *,
    license: str = "other",  # noqa: A002 - the Croissant field is called license
    name: str | None = None,
    file_sizes: Mapping[str, int] | None = None,
    shards: Sequence[ParquetShard] | None = None,
    card: str | None = None,
    version: str = "1.0.0",
    date_published: str | None = None,
    url: str | None = None,
    source_url: str | None = None,
    creator: str | None = None,
) -> dict[str, Any]:
    """Return Croissant 1.1 JSON-LD metadata of a release.

    Parameters
    ----------
    reader : StoreReader
        The store the metadata describes.
    files : mapping of str to str
        Release file name -> SHA-256 hex digest; each becomes a
        ``cr:FileObject`` with ``contentUrl`` (relative to the metadata file),
        ``encodingFormat``, ``sha256`` and ``contentSize`` where known.
    license : str
        Licence identifier or URL (default: ``"other"``).
    name : str, optional
        Dataset name (default: derived from the source name).
    file_sizes : mapping of str to int, optional
        File name -> size in bytes (``contentSize``).
    shards : sequence of ParquetShard, optional
        The Parquet shards. Record sets are read from them (mlcroissant
        reads Parquet, not HDF5 or Zarr): ``models`` (one record per model,
        the columns of :func:`~vptoolkit.dataset.parquet.model_columns`,
        arrays with ``isArray``/``arrayShape``) from the FileSet
        ``model-shards``, and ``views`` from the FileObject of the views shard.
        Without shards there are no record sets.
    card : str, optional
        The release's ``README.md``; the ``rai:`` fields are taken from its
        datasheet sections.
    version : str
        Dataset version, ``MAJOR.MINOR.PATCH`` (default: ``"1.0.0"``).
    date_published : str, optional
        ISO 8601 time of the release (default: the store's ``created``).
    url : str, optional
        Where the dataset is published (default: ``source_url``).
    source_url : str, optional
        Where the source meshes come from (``isBasedOn``).
    creator : str, optional
        Who made the release (default: ``"vptoolkit"``).

    Returns
    -------
    dict
        JSON types only; ``mlcroissant validate`` reports no error.
    """
    info = info_from_reader(reader)
    source = _source_name(info)
    sizes = file_sizes or {}
    distribution: list[dict[str, Any]] = []
    for file_name, digest in sorted(files.items()):
        mime, description = _encoding(file_name)
        entry: dict[str, Any] = {
            "@type": "cr:FileObject",
            "@id": file_name,
            "name": file_name,
            "description": description,
            "contentUrl": file_name,
            "encodingFormat": mime,
            "sha256": digest,
        }
        if file_name in sizes:
            entry["contentSize"] = f"{int(sizes[file_name])} B"
        distribution.append(entry)
    record_sets: list[dict[str, Any]] = []
    model_shards = [s for s in shards or () if s.split != VIEWS_CONFIG]
    view_shards = [s for s in shards or () if s.split == VIEWS_CONFIG]
    n_views, n_points = info["n_views"], info["n_points"]
    if model_shards:
        folder = model_shards[0].path.rsplit("/", 1)[0]
        distribution.append({
            "@type": "cr:FileSet",
            "@id": "model-shards",
            "name": "model-shards",
            "description": (f"Parquet shards, one per split ({', '.join(s.split for s in model_shards)}),"
                            " one row per model"),
            "encodingFormat": "application/x-parquet",
            "includes": f"{folder}/*.parquet",
        })
        columns = model_columns(int(n_points or 0), int(n_views))
        record_sets.append({
            "@type": "cr:RecordSet",
            "@id": "models",
            "name": "models",
            "description": (f"One record per model, {info['n_models']} in all; the split of each "
                            f"is one of {', '.join(SPLITS)}"),
            "key": {"@id": "models/name"},
            "field": [_croissant_field("models", c, {"fileSet": {"@id": "model-shards"}})
                      for c in columns],
        })
    for shard in view_shards:
        record_sets.append({
            "@type": "cr:RecordSet",
            "@id": VIEWS_CONFIG,
            "name": VIEWS_CONFIG,
            "description": f"The {n_views} view directions shared by every model",
            "key": {"@id": f"{VIEWS_CONFIG}/view_index"},
            "field": [_croissant_field(VIEWS_CONFIG, c, {"fileObject": {"@id": shard.path}})
                      for c in view_columns()],
        })
    title = name or f"Viewpoint quality of {source} models"
    document: dict[str, Any] = {
        "@context": dict(_CROISSANT_CONTEXT),
        "@type": "sc:Dataset",
        "conformsTo": "http://mlcommons.org/croissant/1.1",
        "name": title,
        "description": (
            f"{_plural(info['n_models'], 'model')} from {len(info['categories'])} categories of "
            f"{source}, each with {n_points} surface points and normals and the viewpoint "
            f"quality measures {', '.join(info['measures']['order'])} for {n_views} views on "
            f"a Fibonacci sphere (rendered at {info['resolution']} px). Records come from the "
            "Parquet shards; the Zarr v3 zip and the HDF5 file hold the same arrays with the "
            "layout of SCHEMA.md."
        ),
        "license": license,
        "citeAs": _CITATION,
        "version": version,
        "datePublished": date_published or info.get("created"),
        "dateCreated": info.get("created"),
        "creator": {"@type": "sc:Organization", "name": creator or "vptoolkit"},
        "keywords": ["3D", "point cloud", "mesh", "viewpoint selection", "viewpoint quality",
                     *info["categories"]],
        "isAccessibleForFree": True,
    }
    if url or source_url:
        document["url"] = url or source_url
    if source_url:
        document["isBasedOn"] = source_url
    if card:
        document.update(rai_fields(card))
    document["distribution"] = distribution
    document["recordSet"] = record_sets
    return document
