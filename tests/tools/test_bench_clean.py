"""tools/bench_clean.py --baseline: older code cleans each mesh in a child process first."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fixtures.environment import require_package
from fixtures.paths import REPO
from fixtures.scripts import RunTool

require_package("pymeshlab")
require_package("trimesh")

TOOL = "bench_clean.py"


@pytest.mark.slow
def test_baseline_code_cleans_the_same_mesh_the_same_way(tmp_path: Path,
                                                         run_tool: RunTool) -> None:
    # The "baseline" is this checkout itself: same faces after every step, a ratio printed.
    result = run_tool(TOOL, "--sizes", "1500", "--baseline", str(REPO),
                      "--json", str(tmp_path / "records.json"))
    assert result.returncode == 0, result.stderr[-2000:]
    assert "as fast as the baseline code" in result.stdout
    (record,) = json.loads((tmp_path / "records.json").read_text())
    base = record["baseline_code"]
    assert [step["faces_after"] for step in base["steps"]] == [
        step["faces_after"] for step in record["steps"]]
    assert record["speed_up_over_baseline_code"] > 0


def test_a_folder_without_vptoolkit_is_refused(tmp_path: Path, run_tool: RunTool) -> None:
    result = run_tool(TOOL, "--sizes", "--baseline", str(tmp_path), timeout=120)
    assert result.returncode == 2 and "holds no vptoolkit package" in result.stderr
