"""tools/bench_cloud_memory.py: vptool best-view on a written cloud file, its memory measured."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fixtures.scripts import RunTool, assert_section_holds

TOOL = "bench_cloud_memory.py"


def test_a_small_cloud_is_written_searched_and_measured(tmp_path: Path,
                                                        run_tool: RunTool) -> None:
    results, work = tmp_path / "benchmarks.md", tmp_path / "work"
    result = run_tool(TOOL, "--points", "3000", "--work", str(work), "--results", str(results))
    assert result.returncode == 0, result.stderr[-2000:]
    # the file the command read: 3000 points of the bunny with unit normals, float32
    table = np.load(work / "bunny_3000.npy", allow_pickle=False)
    assert table.shape == (3000, 6) and table.dtype == np.float32
    assert np.allclose(np.linalg.norm(table[:, 3:], axis=1), 1.0, atol=1e-5)
    row = next(line for line in result.stdout.splitlines() if line.startswith("| 3,000 |"))
    _, _, file_mib, peak_mib, wall_s, search_s, _ = row.split("|")
    # a fresh Python with numpy and numba holds tens of MiB at least; the search is in the wall
    assert float(peak_mib) > 30 and 0 <= float(search_s) <= float(wall_s)  # 0.1 s steps
    assert float(file_mib) == round((work / "bunny_3000.npy").stat().st_size / 2**20, 1)
    assert_section_holds(results, "cloud_memory", result.stdout)


def test_bad_counts_exit_2_in_one_line(run_tool: RunTool) -> None:
    result = run_tool(TOOL, "--points", "2,x")
    assert result.returncode == 2 and "--points" in result.stderr
    assert "Traceback" not in result.stderr
