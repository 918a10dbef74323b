"""tools/bench_inference.py --quick: the inference benchmark times clouds single, batched and
by stage, and writes what it printed into its section of a results file."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from fixtures.environment import require_package
from fixtures.scripts import RunTool, assert_section_holds

require_package("torch")


@pytest.mark.slow
def test_quick_bench_prints_single_batched_and_stages(tmp_path: Path, run_tool: RunTool) -> None:
    results = tmp_path / "benchmarks.md"
    result = run_tool("bench_inference.py", "--quick", "--threads", "1", "--results",
                      str(results), "--json", str(tmp_path / "inference.json"))
    assert result.returncode == 0, result.stderr[-2000:]
    assert_section_holds(results, "inference", result.stdout)
    rows = [line.split("  ")[1].strip() for line in result.stdout.splitlines()
            if line.startswith("  ") and re.search(r"\d+\.\d ms", line)]
    assert rows == ["single", "batch of 8", "canonical order and key",
                    "farthest point sampling (1024)", "choose 16 inputs",
                    "Morton codes and sort", "hierarchy of 16 inputs", "network on 16 inputs",
                    "consensus"]
    written = json.loads((tmp_path / "inference.json").read_text())
    assert written["batch"] == 8 and written["threads"] == 1
    assert written["single_ms"] > 0 and written["batched_ms_per_cloud"] > 0
    assert written["single_cpu_ms"] > 0 and written["batched_cpu_ms_per_cloud"] > 0


@pytest.mark.slow
def test_inputs_sets_the_consensus_size(tmp_path: Path, run_tool: RunTool) -> None:
    result = run_tool("bench_inference.py", "--quick", "--threads", "1", "--inputs", "1",
                      "--json", str(tmp_path / "inference.json"))
    assert result.returncode == 0, result.stderr[-2000:]
    assert "1 inputs of 4096 points each" in result.stdout
    assert "network on 1 inputs" in result.stdout
    assert json.loads((tmp_path / "inference.json").read_text())["inputs"] == 1
