"""tools/bench_best_view.py --quick: one run prints quality against cost and writes its section."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from fixtures.environment import require_package
from fixtures.scripts import RunTool
from vptoolkit.samples import sample_path

require_package("pymeshlab")
require_package("torch")

TOOL = "bench_best_view.py"


@pytest.mark.slow
def test_quick_run_scores_every_answer_and_marks_the_front(tmp_path: Path,
                                                          run_tool: RunTool) -> None:
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    for name in ("mug", "teapot", "suzanne"):
        shutil.copyfile(sample_path(name), meshes / sample_path(name).name)
    results = tmp_path / "results.md"
    result = run_tool(TOOL, str(meshes), "--quick", "--cache", str(tmp_path / "cache"),
                      "--results", str(results), "--json", str(tmp_path / "rows.json"), timeout=900)
    assert result.returncode == 0, result.stderr[-2000:]
    rows = json.loads((tmp_path / "rows.json").read_text())
    assert {"random view (expectation)", "PCA axis", "network alone", "plain search 4 @ 128",
            "unoccluded estimate, faces", "unoccluded estimate, 2000 points with normals",
            "coarse-to-fine 16 @ 128", "network prior + search 16 @ 128",
            "unoccluded prior + search 16 @ 128", "ceiling: best of the 4-view sphere",
            "ceiling: best of the network prior's candidates",
            "ceiling: best of the unoccluded prior's candidates"} <= set(rows)
    assert all(len(row["mean"]) == 4 for row in rows.values())
    # a ceiling is the best of its candidates by the labels: a 4-view search draws exactly
    # the 4-view sphere and picks by its own measurement, so it never beats that ceiling
    ceiling = rows["ceiling: best of the 4-view sphere"]["mean"]
    searched = rows["coarse-to-fine 4 @ 128"]["mean"]
    assert all(c >= s - 1e-9 for c, s in zip(ceiling, searched))
    assert rows["ceiling: best of the 4-view sphere"]["views"] == "4"
    text = results.read_text()
    assert "<!-- best_view:start -->" in text and "## Best views: quality against cost" in text
    assert text.count(" * |") >= 1  # the Pareto front is marked


@pytest.mark.parametrize("arguments, message", [
    (["--budgets", "0,4"], "--budgets"),
    (["--budgets", "a"], "--budgets"),
    (["no/such/folder"], "not a folder"),
])
def test_bad_arguments_exit_2_in_one_line(arguments: list[str], message: str,
                                          run_tool: RunTool) -> None:
    result = run_tool(TOOL, *arguments)
    assert result.returncode == 2 and message in result.stderr
    assert "Traceback" not in result.stderr


def test_the_readme_table_takes_its_rows_from_one_run() -> None:
    import bench_best_view as bench

    search = f"@ {bench.SEARCH_RESOLUTION}"
    labels = [f"coarse-to-fine {bench.BUDGET} {search}",
              f"coarse-to-fine {bench.FEW_VIEWS} {search}",
              f"plain search {bench.FLAT_VIEWS} {search}",
              f"unoccluded estimate, {bench.SCAN_POINTS} points with normals", "network alone",
              "network points alone", "PCA axis", "random view (expectation)"]
    rows = {label: ([10.0 * i + 1, 10.0 * i + 2, 10.0 * i + 3, 10.0 * i + 4],
                    None if label.startswith("random") else 5.0 * (i + 1))
            for i, label in enumerate(labels)}
    text = bench.readme_table(rows, meshes="two meshes", rotations=4, views=1000,
                              resolution=256, source="a test")
    table = [line for line in text.splitlines() if line.startswith("|")]
    assert len(table) == 2 + 7  # header, rule and seven answers
    assert "1.0 / 2.0 / 3.0 / 4.0" in table[2] and "5 ms" in table[2]  # the full budget's row
    assert "11.0 / 12.0 / 13.0 / 14.0" in table[3]  # the few views' row
    assert "`vptool predict -m points`" in table[7] and "51.0 / 52.0" in table[7]
    assert "A random view scores 71.0 / 72.0 / 73.0 / 74.0" in text
    assert text.endswith("From a test.")


def test_the_readme_table_needs_the_full_run(tmp_path: Path, run_tool: RunTool) -> None:
    result = run_tool(TOOL, "--quick", "--readme", str(tmp_path / "README.md"))
    assert result.returncode == 2 and "--readme" in result.stderr


@pytest.mark.slow
def test_cloud_search_writes_the_ratio_of_a_cloud_search_to_a_mesh_search(
        tmp_path: Path, run_tool: RunTool) -> None:
    doc = tmp_path / "benchmarks.md"
    result = run_tool(TOOL, "--cloud-search", str(doc), timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    text = doc.read_text()
    assert "<!-- cloud_search:start -->" in text and "<!-- cloud_search:end -->" in text
    assert "of 20,000 bunny points with normals took " in text
    assert "of the bunny decimated to 9,999 faces " in text and "x (median of 9" in text
