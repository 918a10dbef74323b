"""tools/bench_train.py --quick: the training benchmark runs end to end, prints its ratios
and writes them into its section of a results file."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from fixtures.environment import require_package
from fixtures.scripts import RunTool, assert_section_holds

require_package("torch")
require_package("zarr")



@pytest.mark.slow
def test_quick_bench_prints_every_row_with_a_rate(tmp_path: Path, run_tool: RunTool) -> None:
    result = run_tool("bench_train.py", "--quick", "--results", str(tmp_path / "benchmarks.md"))
    assert result.returncode == 0, result.stderr[-2000:]
    assert_section_holds(tmp_path / "benchmarks.md", "train", result.stdout)
    rows = [line for line in result.stdout.splitlines() if line.startswith("  ")]
    assert [row.split("  ")[1].strip() for row in rows][:3] == [
        "bare step, plain Adam", "bare step, fused Adam", "train_model, FPS per item"]
    assert len(rows) == 5 and all(re.search(r"\d+\.\d", row) for row in rows)
