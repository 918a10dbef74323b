"""The summary of a dataset store: counts, sizes, conventions, quality statistics, failures.

:func:`info_from_reader` (or :func:`dataset_info` for a path) computes a
JSON-safe summary from the store alone (its attributes, model records,
failure log and arrays); :func:`format_info` renders it for the terminal.
The dataset card (:mod:`vptoolkit.dataset.release.card`) and the Croissant metadata
(:mod:`vptoolkit.dataset.release.croissant`) are written from this summary, with the
few sentence and number helpers kept here so that all three say things the
same way.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vptoolkit.conventions import SPLITS
from vptoolkit.dataset.store.schema import published_split
from vptoolkit.errors import InputError

if TYPE_CHECKING:
    from vptoolkit.dataset.store.reader import StoreReader

__all__ = [
    "CITATION",
    "LOG_BASE",
    "SPLIT_ORDER",
    "camera_sentence",
    "split_count_rows",
    "dataset_info",
    "format_info",
    "format_number",
    "info_from_reader",
    "plural",
    "size_category",
    "source_name",
]

SPLIT_ORDER = SPLITS
"""Order of the splits in every table; any other split name follows, sorted."""


LOG_BASE = 2
"""Base of the logarithms of the measures (``vptoolkit.measures``): VE, VKL, VMI and every
other information measure are in bits."""


CITATION = (
    "@article{schelling2021viewpoint,\n"
    "  title   = {Enabling Viewpoint Learning through Dynamic Label Generation},\n"
    "  author  = {Schelling, Michael and Hermosilla, Pedro and V{\\'a}zquez, Pere-Pau and "
    "Ropinski, Timo},\n"
    "  journal = {Computer Graphics Forum},\n"
    "  volume  = {40},\n"
    "  number  = {2},\n"
    "  year    = {2021}\n"
    "}"
)

_PAPER_UNITS = {
    "VE": "bits",
    "VR": "fraction of the surface area",
    "VKL": "bits",
    "VMI": "bits",
}
"""The raw unit of each of the paper's four measures; the summary gives any other measure
``"-"`` (its unit is stated in its definition, :mod:`vptoolkit.measures.catalog`)."""

_UNKNOWN_TITLE = "not known to this vptoolkit"
"""The name the summary gives a measure the registry does not know."""


_SIZE_STEPS = (
    (10**3, "n<1K"), (10**4, "1K<n<10K"), (10**5, "10K<n<100K"), (10**6, "100K<n<1M"),
    (10**7, "1M<n<10M"), (10**8, "10M<n<100M"), (10**9, "100M<n<1B"),
    (10**10, "1B<n<10B"), (10**11, "10B<n<100B"), (10**12, "100B<n<1T"),
)


def info_from_reader(reader: StoreReader) -> dict[str, Any]:
    """Summarise an open store as JSON types.

    Parameters
    ----------
    reader : StoreReader
        An open store (:func:`vptoolkit.dataset.store.reader.open_store`).

    Returns
    -------
    dict
        ``store`` (file name), ``store_kind``, ``format``, ``schema_version``,
        ``n_models``, ``n_views``, ``n_points`` (per model), ``resolution``,
        ``backend``, ``categories``, ``class_names`` (label ``i`` is
        ``class_names[i]``) and ``splits`` (ordered),
        ``counts`` (category -> split -> models, every pair present),
        ``split_totals``, ``category_totals``, ``measures`` (order: the
        store's names; higher_is_better: as recorded; names, units, log_base,
        normalisation), ``camera``,
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

    order = reader.measures
    best_value = np.asarray(reader.array("best_value")[:], dtype=np.float64).reshape(
        -1, len(order)
    )
    best_stats = {m: _summary(best_value[:, i]) for i, m in enumerate(order)}
    faces = [record["n_faces"] for record in models if record.get("n_faces") is not None]
    vertices = [
        record["n_vertices"] for record in models if record.get("n_vertices") is not None
    ]
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
        "class_names": reader.class_labels()[0],
        "splits": splits,
        "counts": counts,
        "split_totals": split_totals,
        "category_totals": category_totals,
        "measures": {
            "order": list(order),
            "higher_is_better": list(attrs["higher_is_better"]),
            "names": {m: _measure_name(m) for m in order},
            "units": {m: _PAPER_UNITS.get(m, "-") for m in order},
            "log_base": LOG_BASE,
            "normalisation": "per model over its views: (q - worst) / (best - worst); 1 = best",
        },
        "camera": attrs.get("camera"),
        "cleaning": attrs.get("cleaning"),
        "provenance": attrs.get("provenance"),
        "split_file": attrs.get("split_file"),
        "statistics": statistics,
        "n_failures": len(failures),
        "failures": [
            {key: record.get(key) for key in ("source", "category", "reason")}
            for record in failures
        ],
    }
    return _json_safe(info)


def _measure_name(name: str) -> str:
    """What the summary calls a measure: its registry title, or that it is unknown."""
    from vptoolkit.measures.registry import all_measures

    known = all_measures()
    return known[name].title if name in known else _UNKNOWN_TITLE


def dataset_info(path: Path | str) -> dict[str, Any]:
    """Summarise the dataset at ``path`` as JSON types.

    Parameters
    ----------
    path : Path or str
        A store, a build folder or a release folder (anything
        :func:`vptoolkit.dataset.store.containers.find_store` accepts).

    Returns
    -------
    dict
        See :func:`info_from_reader`; ``path`` holds the store that was read.
    """
    from vptoolkit.dataset.store.containers import find_store
    from vptoolkit.dataset.store.reader import open_store

    store_path = find_store(path)
    with open_store(store_path) as reader:
        info = info_from_reader(reader)
    info["path"] = str(store_path)
    return info


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
        f"camera: {camera_sentence(info.get('camera'))}",
        "",
        _text_table(*split_count_rows(info)),
        "",
    ]
    stats = info["statistics"]
    header = ["best raw value", "mean", "min", "max"]
    rows = [
        [m, format_number(s["mean"]), format_number(s["min"]), format_number(s["max"])]
        for m, s in stats["best_value"].items()
    ]
    rows.append(["faces per model", format_number(stats["faces"]["mean"]),
                 format_number(stats["faces"]["min"]), format_number(stats["faces"]["max"])])
    lines.append(_text_table(header, rows))
    lines.append("")
    lines.append(f"failures: {info['n_failures']}")
    for record in info["failures"]:
        lines.append(f"  {record.get('source')}: {record.get('reason')}")
    return "\n".join(lines)


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


def source_name(info: Mapping[str, Any]) -> str:
    return str(info.get("source") or "unknown")


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


def split_count_rows(info: Mapping[str, Any]) -> tuple[list[str], list[list[str]]]:
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


def camera_sentence(camera: Mapping[str, Any] | None) -> str:
    if not camera:
        return "not recorded"
    parts = [str(camera.get("projection", "perspective"))]
    if camera.get("fov_deg") is not None:
        parts.append(f"field of view {format_number(camera['fov_deg'])} deg")
    if camera.get("distance_factor") is not None:
        unit = camera.get("distance_unit", "bounding-box diagonal")
        parts.append(f"distance {format_number(camera['distance_factor'])} x {unit}")
    if camera.get("target"):
        parts.append(f"looking at the {camera['target']}")
    if camera.get("up") is not None:
        parts.append("up " + "(" + ", ".join(format_number(c) for c in camera["up"]) + ")")
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


def format_number(value: float | int | None, digits: int = 4) -> str:
    """Format a statistic for a table: ``-`` for missing, integers as is."""
    if value is None:
        return "-"
    if isinstance(value, int) or (math.isfinite(value) and float(value).is_integer()):
        return str(int(value))
    if abs(value) >= 10 ** digits:
        return f"{value:.1f}"
    return f"{value:.{digits}g}"


def plural(count: int, noun: str) -> str:
    """``1 model``, ``2 models``."""
    return f"{count} {noun}{'' if count == 1 else 's'}"
