"""tools/bench_point_clouds.py --quick: every answer for a point cloud is scored and written."""

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
require_package("open3d")

TOOL = "bench_point_clouds.py"


def test_quick_run_scores_every_answer_for_both_cloud_kinds(tmp_path: Path,
                                                            run_tool: RunTool) -> None:
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    for name in ("mug", "teapot"):
        shutil.copyfile(sample_path(name), meshes / sample_path(name).name)
    results = tmp_path / "results.md"
    result = run_tool(TOOL, str(meshes), "--quick", "--cache", str(tmp_path / "cache"),
                      "--results", str(results), "--json", str(tmp_path / "rows.json"), timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    rows = json.loads((tmp_path / "rows.json").read_text())
    assert set(rows) == {"uniform", "scan"}
    expected = {"point search 8 @ 64", "point search 16 @ 64", "network of coordinates alone",
                "unoccluded estimate, normals", "Open3D hidden point removal, 16 views",
                "PCA axis", "random view (expectation)", "mesh search 16 @ 64 (the mesh itself)"}
    for kind in ("uniform", "scan"):
        assert expected <= set(rows[kind])
        for row in rows[kind].values():
            # a score is the normalised quality of a labelled view: within 0 and 100 %
            assert len(row["mean"]) == 4 and all(0.0 <= value <= 100.0 for value in row["mean"])
    # the mesh rows do not depend on the cloud, the cloud rows do
    mesh_row = "mesh search 16 @ 64 (the mesh itself)"
    assert rows["uniform"][mesh_row]["mean"] == rows["scan"][mesh_row]["mean"]
    # the random view is an expectation over the labels: no time, the same in both tables
    assert rows["uniform"]["random view (expectation)"]["ms"] is None
    text = results.read_text()
    assert "<!-- point_clouds:start -->" in text and "### scan clouds" in text
    assert "point search 16 @ 64 minus" in text  # the paired differences


@pytest.mark.parametrize("arguments, message", [
    (["--budgets", "0,4"], "--budgets"),
    (["--hpr-views", "x"], "--hpr-views"),
    (["--models", "0"], "--models"),
    (["no/such/folder"], "not a folder"),
])
def test_bad_arguments_exit_2_in_one_line(arguments: list[str], message: str,
                                          run_tool: RunTool) -> None:
    result = run_tool(TOOL, *arguments)
    assert result.returncode == 2 and message in result.stderr
    assert "Traceback" not in result.stderr
