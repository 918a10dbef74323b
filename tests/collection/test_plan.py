"""Sizing a collection run before it runs: files, bytes, time and disk, nothing written."""

from __future__ import annotations

import shutil
from pathlib import Path

from vptoolkit.best_view.search import SearchSettings
from vptoolkit.collection.methods import SearchMethod
from vptoolkit.collection.plan import plan_collection
from vptoolkit.samples import sample_path


def test_a_plan_counts_every_file_and_times_a_few(tmp_path: Path):
    root = tmp_path / "coll"
    root.mkdir()
    for name in ("a.off", "b.off", "c.off"):
        shutil.copy(sample_path("ballA.off"), root / name)
    (root / "broken.off").write_text("OFF\n3 1 0\n0 0 0\n")
    method = SearchMethod(SearchSettings(budget=8, resolution=32))
    plan = plan_collection(root, method, sampled=2, extra_bytes_per_file=100)
    assert plan.n_files == 4 and plan.n_sampled == 2
    assert plan.n_bytes == sum(path.stat().st_size for path in root.iterdir())
    assert plan.seconds > 0 and plan.disk_bytes > 4 * 100
    assert sorted(path.name for path in root.iterdir()) == ["a.off", "b.off", "broken.off",
                                                            "c.off"]
    counted = plan_collection(root, method, sampled=0)
    assert counted.n_sampled == 0 and counted.lines()[0].startswith("4 files (")
