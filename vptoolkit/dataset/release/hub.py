"""The dataset hub's YAML header of a release card: configurations and features.

:func:`hub_yaml` writes the ``configs`` and ``dataset_info`` blocks that the
Hugging Face hub and ``datasets.load_dataset`` read from a card's header: the
Parquet shards of each split and the features of every column, with the
shapes and class names of the store, in the YAML the hub itself writes.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence

from vptoolkit.dataset.release.parquet import (
    VIEWS_CONFIG,
    Column,
    ParquetShard,
    model_columns,
    view_columns,
)
from vptoolkit.measures.registry import PAPER_MEASURES

__all__ = ["hub_yaml", "yaml_str"]


def hub_yaml(shards: Sequence[ParquetShard], *, n_points: int, n_views: int,
             class_names: Sequence[str] = (), measures: Sequence[str] = PAPER_MEASURES) -> str:
    """The ``configs`` and ``dataset_info`` blocks of a card's YAML header.

    Two configurations: ``default`` (the Parquet shards of each split, one row
    per model, columns :func:`~vptoolkit.dataset.release.parquet.model_columns`) and
    ``views`` (the shared view directions, as split ``train``, the hub's
    name for a configuration's only split). ``datasets.load_dataset(release)``
    then reads the shards, offline or streaming, with the declared features.

    Parameters
    ----------
    shards : sequence of ParquetShard
        What :func:`~vptoolkit.dataset.release.parquet.write_parquet_shards` wrote.
    n_points, n_views : int
        Points and views per model, the shapes of the array features.
    class_names : sequence of str
        The store's ``class_names``: the ``label`` feature is a
        ``ClassLabel`` with these names.
    measures : sequence of str
        The store's ``measures``: the measure features hold one column per
        name (default: the paper's four).

    Returns
    -------
    str
        YAML lines without a trailing newline.
    """
    by_split: dict[str, list[ParquetShard]] = {}
    for shard in shards:
        by_split.setdefault(shard.split, []).append(shard)
    model_splits = {split: files for split, files in by_split.items() if split != VIEWS_CONFIG}
    view_splits = {"train": by_split[VIEWS_CONFIG]} if VIEWS_CONFIG in by_split else {}
    lines = ["configs:", "- config_name: default", "  default: true", "  data_files:"]
    lines += _data_files(model_splits)
    if view_splits:
        lines += [f"- config_name: {VIEWS_CONFIG}", "  data_files:", *_data_files(view_splits)]
    lines.append("dataset_info:")
    configs = [("default", model_columns(n_points, n_views, class_names, measures=measures),
                model_splits),
               (VIEWS_CONFIG, view_columns(), view_splits)]
    for config_name, columns, chosen in configs:
        if not chosen:
            continue
        lines += [f"- config_name: {config_name}", "  features:"]
        lines += [_yaml_feature(column) for column in columns]
        lines.append("  splits:")
        for split, files in chosen.items():
            lines += [f"  - name: {split}", f"    num_bytes: {sum(s.num_bytes for s in files)}",
                      f"    num_examples: {sum(s.n_rows for s in files)}"]
        total = sum(s.num_bytes for files in chosen.values() for s in files)
        lines.append(f"  dataset_size: {total}")
    return "\n".join(lines)


def _data_files(splits: Mapping[str, Sequence[ParquetShard]]) -> list[str]:
    """The ``data_files`` entries of a configuration: one path, or the list of a split's shards."""
    lines = []
    for split, files in splits.items():
        if len(files) == 1:
            lines.append(f"  - split: {split}\n    path: {files[0].path}")
        else:
            lines += [f"  - split: {split}", "    path:", *(f"    - {s.path}" for s in files)]
    return lines


def _yaml_feature(column: Column) -> str:
    """One feature of a hub ``dataset_info``, as the hub's YAML writes it."""
    head = f"  - name: {column.name}\n"
    if column.class_names is not None:
        names = "\n".join(f"          '{label}': {yaml_str(name)}"
                          for label, name in enumerate(column.class_names))
        return head + "    dtype:\n      class_label:\n        names:\n" + names
    if not column.shape:
        return head + f"    dtype: {column.dtype}"
    if len(column.shape) == 1:
        return head + f"    list: {column.dtype}\n    length: {column.shape[0]}"
    dims = "\n".join(f"        - {'null' if d is None else d}" for d in column.shape)
    return (head + f"    dtype:\n      array{len(column.shape)}_d:\n        shape:\n{dims}\n"
            f"        dtype: {column.dtype}")


def yaml_str(text: str) -> str:
    """Quote a string for YAML (a JSON string is a valid YAML double-quoted scalar)."""
    return json.dumps(text, ensure_ascii=False)
