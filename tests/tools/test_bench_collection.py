"""tools/bench_collection.py --quick: the collection benchmark runs both commands with local
and Dask workers, kills and resumes a run, samples memory over a list, and writes what it
printed into its section of a results file."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from fixtures.environment import require_package
from fixtures.scripts import RunTool, assert_section_holds

require_package("pyarrow")
require_package("psutil")


@pytest.mark.slow
def test_quick_bench_measures_runs_resume_and_memory(tmp_path: Path, run_tool: RunTool) -> None:
    results = tmp_path / "benchmarks.md"
    result = run_tool("bench_collection.py", "--quick", "--results", str(results),
                      "--json", str(tmp_path / "collection.json"), "--work", str(tmp_path / "w"))
    assert result.returncode == 0, result.stderr[-2000:]
    assert_section_holds(results, "collection", result.stdout)
    out = result.stdout
    assert out.count("the same table bytes in every run: yes") == 2
    # the kill lands once 4 of 12 are staged; more may be staged by then on a fast machine
    assert re.search(r"\(the \d+ not staged: yes\); table bytes as an uninterrupted run: "
                     r"identical", out)
    assert re.search(r"median over the same 1 files, 1 process:\n  old default \d", out)
    assert len(re.findall(r"at each tenth:( \d+){11}\n", out)) == 2
    figures = json.loads((tmp_path / "collection.json").read_text())
    for command in ("best-view", "thumbnails"):
        runs = figures[command]
        assert {"1 process", "2 processes"} <= set(runs)
        for run in runs.values():
            assert run["files_per_hour"] > 0 and run["failed"] == 0
            assert run["peak_main_mb"] > 0 and set(run["stages"]) == {
                "read", "answer", "draw", "finish", "stage"}
        assert runs["2 processes"]["peak_workers_mb"] > 0
    pictures = figures["thumbnails"]["2 processes"]["stages"]
    assert pictures["draw"] > 0 and pictures["finish"] > 0  # drawn in the workers, written here
    assert figures["best-view"]["2 processes"]["stages"]["draw"] == 0
