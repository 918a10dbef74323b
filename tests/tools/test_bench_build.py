"""tools/bench_build.py --meshes: the benchmark builds a folder of the user's meshes
and writes its table into its section of a results file."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from fixtures.environment import require_package
from fixtures.scripts import RunTool, assert_section_holds
from vptoolkit.samples import sample_path

require_package("pymeshlab")

TOOL = "bench_build.py"


def test_meshes_folder_is_built_instead_of_the_samples(tmp_path: Path,
                                                        run_tool: RunTool) -> None:
    meshes = tmp_path / "meshes" / "nested"
    meshes.mkdir(parents=True)
    for name in ("table", "bottle"):
        shutil.copyfile(sample_path(name), meshes / sample_path(name).name)
    (meshes / "notes.txt").write_text("not a mesh")
    result = run_tool(TOOL, "--quick", "--workers", "1", "--meshes", str(tmp_path / "meshes"),
                    "--json", str(tmp_path / "bench.json"),
                    "--results", str(tmp_path / "benchmarks.md"))
    assert result.returncode == 0, result.stderr[-2000:]
    assert_section_holds(tmp_path / "benchmarks.md", "build", result.stdout)
    assert f"2 files from 2 meshes under {tmp_path / 'meshes'}" in result.stdout
    record = json.loads((tmp_path / "bench.json").read_text())
    assert record["n_files"] == 2
    assert [(run["n_models"], run["n_failures"]) for run in record["runs"]] == [(2, 0)]


def test_a_folder_without_meshes_is_refused(tmp_path: Path, run_tool: RunTool) -> None:
    (tmp_path / "notes.txt").write_text("not a mesh")
    result = run_tool(TOOL, "--quick", "--meshes", str(tmp_path))
    assert result.returncode == 2 and "no mesh file under" in result.stderr
    result = run_tool(TOOL, "--quick", "--meshes", str(tmp_path / "missing"))
    assert result.returncode == 2 and "is not a folder" in result.stderr
