"""tools/bench_point_clouds.py --quick: every answer for a point cloud is scored, kept, written."""

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


def test_quick_run_scores_every_answer_for_both_cloud_kinds_and_resumes(
        tmp_path: Path, run_tool: RunTool) -> None:
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    for name in ("mug", "teapot"):
        shutil.copyfile(sample_path(name), meshes / sample_path(name).name)
    results, scores = tmp_path / "results.md", tmp_path / "scores"
    common = [str(meshes), "--quick", "--cache", str(tmp_path / "cache"), "--scores", str(scores)]
    result = run_tool(TOOL, *common, "--results", str(results),
                      "--json", str(tmp_path / "rows.json"), timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    rows = json.loads((tmp_path / "rows.json").read_text())
    assert set(rows) == {"uniform", "scan"}
    default = "`vptool best-view CLOUD` (SearchSettings(): 64 views @ 128)"
    expected = {default, "anytime point search 8 @ 64", "anytime point search 16 @ 64",
                "flat point search 8 @ 64", "flat point search 16 @ 64",
                "Poisson depth 8 + mesh search 64 @ 128", "ball pivoting + mesh search 64 @ 128",
                "network of coordinates alone", "unoccluded estimate, normals",
                "Open3D hidden point removal, 16 views",
                "Open3D hidden point removal, 100 views", "PCA axis", "random view (expectation)",
                "plain search 16 @ 32 (the mesh itself)", "mesh search 16 @ 64 (the mesh itself)"}
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
    assert f"{default} minus" in text  # the paired differences
    assert "plain search 16 @ 32 (the mesh itself) |" in text
    assert "2 of 2 cases complete" in text

    # every score was kept, one line per model, kind and cloud row, and per model and mesh row
    stored = [json.loads(line) for line in (scores / "scores.jsonl").read_text().splitlines()]
    cloud_rows = len(expected) - 3  # less the random view and the two mesh rows named above
    mesh_rows = 2 + 1  # the plain search and the mesh searches at budgets 8 and 16
    assert len(stored) == 2 * (2 * cloud_rows + mesh_rows)
    # a rerun computes nothing and reports the same numbers from the kept scores
    readme = tmp_path / "README.md"
    again = run_tool(TOOL, *common, "--report-only", "--json", str(tmp_path / "again.json"),
                     "--readme", str(readme), timeout=600)
    assert again.returncode == 0, again.stderr[-2000:]
    assert json.loads((tmp_path / "again.json").read_text()) == rows
    # the README's short table: the rows this run has, the command's default search first
    table = readme.read_text()
    assert "<!-- readme_point_clouds:start -->" in table
    default_cells = " / ".join(f"{value:.1f}" for value in rows["uniform"][default]["mean"])
    assert f"| one cloud, or a few | `vptool best-view cloud.ply` (64 views) | {default_cells} |" \
        in table
    assert "`vptool predict -m points cloud.npy`" in table
    assert (scores / "scores.jsonl").read_text().count("\n") == len(stored)
    # scores kept under other settings are refused, in one line
    settings = json.loads((scores / "settings.json").read_text())
    (scores / "settings.json").write_text(json.dumps({**settings, "quick": False}))
    other = run_tool(TOOL, *common, "--report-only")
    assert other.returncode == 2 and "another --scores folder" in other.stderr


@pytest.mark.parametrize("arguments, message", [
    (["--budgets", "0,4"], "--budgets"),
    (["--hpr-views", "x"], "--hpr-views"),
    (["--models", "0"], "--models"),
    (["no/such/folder"], "not a folder"),
    (["--report-only"], "--report-only"),
])
def test_bad_arguments_exit_2_in_one_line(arguments: list[str], message: str,
                                          run_tool: RunTool) -> None:
    result = run_tool(TOOL, *arguments)
    assert result.returncode == 2 and message in result.stderr
    assert "Traceback" not in result.stderr
