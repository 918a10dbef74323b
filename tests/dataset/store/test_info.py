"""The summary of a store (dataset_info, format_info), which the card and Croissant are
written from."""

from __future__ import annotations

import json
import re
from collections import Counter
from pathlib import Path

import pytest

from fixtures.releases import CATEGORIES, FAILURES, source_records
from fixtures.stores import N_POINTS, N_VIEWS


@pytest.mark.parametrize(("n_models", "label"), [
    (0, "n<1K"), (999, "n<1K"), (1000, "1K<n<10K"), (16000, "10K<n<100K"),
    (250_000, "100K<n<1M"), (10**6, "1M<n<10M"),
])
def test_size_category(n_models: int, label: str) -> None:
    from vptoolkit.dataset.store.info import size_category

    assert size_category(n_models) == label


def test_dataset_info_counts_per_category_and_split(build: Path, release) -> None:
    from vptoolkit.dataset.store.info import dataset_info, format_info

    records = source_records(build)
    for path in (build, release.path, release.hdf5):
        info = dataset_info(path)
        json.dumps(info, allow_nan=False)  # JSON-safe
        assert info["n_models"] == len(records)
        assert info["n_views"] == N_VIEWS and info["n_points"] == N_POINTS
        assert info["resolution"] == 64 and info["backend"] == "raster"
        assert info["categories"] == sorted(CATEGORIES)
        assert info["splits"] == ["train", "validation", "test"]
        for category in CATEGORIES:
            for split in info["splits"]:
                expected = sum(r["category"] == category and r["split"] == split for r in records)
                assert info["counts"][category][split] == expected
        assert info["split_totals"] == dict(Counter(r["split"] for r in records))
        assert info["measures"]["order"] == ["VE", "VR", "VKL", "VMI"]
        assert info["measures"]["higher_is_better"] == [True, True, False, False]
        assert info["measures"]["log_base"] == 2
        assert info["camera"]["fov_deg"] == 45.0
        assert info["toolkit_version"] == "0.1.0" and info["created"] == "2025-01-02T03:04:05Z"
        assert info["n_failures"] == len(FAILURES) and info["failures"] == FAILURES
    text = format_info(info)
    assert re.search(r"^airplane\s+\d+\s+\d+\s+\d+\s+5$", text, re.MULTILINE)
    assert re.search(rf"^total\s+\d+\s+\d+\s+\d+\s+{len(records)}$", text, re.MULTILINE)
    assert "no view sees the model" in text


def test_release_info_json_matches_dataset_info(release) -> None:
    from vptoolkit.dataset.store.info import dataset_info

    stored = json.loads((release.path / "dataset_info.json").read_text(encoding="utf-8"))
    live = dataset_info(release.zarr_zip)
    live.pop("path")
    assert stored == live
