"""tools/bench_view_sets.py --quick: the view-set bench prints its table and writes its section."""

from __future__ import annotations

from pathlib import Path

from fixtures.scripts import RunTool, assert_section_holds


def test_quick_bench_prints_a_row_and_writes_its_section(tmp_path: Path,
                                                          run_tool: RunTool) -> None:
    results = tmp_path / "benchmarks.md"
    results.write_text("# Benchmarks\n\nkept\n")
    result = run_tool("bench_view_sets.py", "--quick", "--results", str(results))
    assert result.returncode == 0, result.stderr[-2000:]
    assert any(line.startswith("torus") for line in result.stdout.splitlines())
    assert_section_holds(results, "view_sets", result.stdout)
    assert results.read_text().startswith("# Benchmarks\n\nkept\n")
