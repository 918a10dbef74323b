"""tools/bench_measures.py --quick: the measure bench prints its tables, the cost of all
measures against the paper's four, and writes its section."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from fixtures.scripts import RunTool, assert_section_holds
from vptoolkit.measures.measure import FAMILIES
from vptoolkit.measures.registry import all_measures


@pytest.mark.slow
def test_quick_bench_prints_the_cost_of_all_measures_and_writes_its_section(
        tmp_path: Path, run_tool: RunTool) -> None:
    results = tmp_path / "benchmarks.md"
    results.write_text("# Benchmarks\n\nkept\n")
    result = run_tool("bench_measures.py", "--quick", "--results", str(results))
    assert result.returncode == 0, result.stderr[-2000:]
    lines = result.stdout.splitlines()
    assert any(line.startswith("torus ") for line in lines)
    assert (f"all {len(all_measures())} measures against the paper's four: torus, 8700 faces, "
            "100 views at 256 px") in result.stdout
    assert re.search(r"^  the four: [\d.]+ s; all: [\d.]+ s; ratio [\d.]+$", result.stdout,
                     re.MULTILINE)
    assert re.search(r"^  drawing: [\d.]+ s; with depth and silhouette statistics: [\d.]+ s",
                     result.stdout, re.MULTILINE)
    for family in FAMILIES:
        names = ", ".join(m.name for m in all_measures().values() if m.family == family)
        assert re.search(rf"^  {family} +[\d.]+ s on the drawn views  \({names}\)$",
                         result.stdout, re.MULTILINE), family
    assert_section_holds(results, "measures", result.stdout)
    assert results.read_text().startswith("# Benchmarks\n\nkept\n")


def test_costs_only_prints_the_comparison_alone_into_its_own_section(
        tmp_path: Path, run_tool: RunTool) -> None:
    results = tmp_path / "benchmarks.md"
    result = run_tool("bench_measures.py", "--quick", "--costs-only", "--repeat", "1",
                      "--results", str(results), "--section", "measure_costs")
    assert result.returncode == 0, result.stderr[-2000:]
    assert "the four:" in result.stdout and "JIT" not in result.stdout
    assert_section_holds(results, "measure_costs", result.stdout)


def test_memory_only_prints_the_peak_memory_of_one_measure_and_the_four(
        tmp_path: Path, run_tool: RunTool) -> None:
    results = tmp_path / "benchmarks.md"
    result = run_tool("bench_measures.py", "--quick", "--memory-only",
                      "--results", str(results), "--section", "measure_memory")
    assert result.returncode == 0, result.stderr[-2000:]
    assert ("peak memory of compute_view_quality: torus, 8700 faces, 100 views at 256 px"
            in result.stdout)
    for spec in ("VE", "paper", "VE,NVT"):
        assert re.search(rf"^  --measures {spec} +traced peak +[\d.]+ MiB, "
                         r"resident peak +[\d.]+ MiB$", result.stdout, re.MULTILINE), spec
    assert_section_holds(results, "measure_memory", result.stdout)


def test_neighbour_memory_prints_the_peak_memory_per_view_count(
        tmp_path: Path, run_tool: RunTool) -> None:
    results = tmp_path / "benchmarks.md"
    result = run_tool("bench_measures.py", "--quick", "--neighbour-memory",
                      "--results", str(results), "--section", "neighbour_memory")
    assert result.returncode == 0, result.stderr[-2000:]
    rows = [line.split() for line in result.stdout.splitlines() if re.match(r"^ +[\d,]+ ", line)]
    assert [row[0] for row in rows] == ["200", "2,000"]
    assert all(float(row[1]) > 0 and float(row[3]) > 0 for row in rows)
    assert_section_holds(results, "neighbour_memory", result.stdout)
