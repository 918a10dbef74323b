"""tools/bench_clean.py --baseline: older code cleans each mesh in a child process first."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import require_package

require_package("pymeshlab")
require_package("trimesh")

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "tools" / "bench_clean.py"


@pytest.mark.slow
def test_baseline_code_cleans_the_same_mesh_the_same_way(tmp_path: Path) -> None:
    # The "baseline" is this checkout itself: same faces after every step, a ratio printed.
    result = subprocess.run(
        [sys.executable, str(TOOL), "--sizes", "1500", "--baseline", str(ROOT),
         "--json", str(tmp_path / "records.json")],
        capture_output=True, text=True, timeout=600, check=False,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert "as fast as the baseline code" in result.stdout
    (record,) = json.loads((tmp_path / "records.json").read_text())
    base = record["baseline_code"]
    assert [step["faces_after"] for step in base["steps"]] == [
        step["faces_after"] for step in record["steps"]]
    assert record["speed_up_over_baseline_code"] > 0


def test_a_folder_without_vptoolkit_is_refused(tmp_path: Path) -> None:
    result = subprocess.run(
        [sys.executable, str(TOOL), "--sizes", "--baseline", str(tmp_path)],
        capture_output=True, text=True, timeout=120, check=False,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert result.returncode == 2 and "holds no vptoolkit package" in result.stderr
