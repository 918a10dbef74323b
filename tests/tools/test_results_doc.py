"""tools/results_doc.py: the tables and docs/results.md sections of every results script."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pytest
import results_doc

from vptoolkit.evaluate.protocol import ProtocolScores


def _scores(rows: list[list[float]]) -> ProtocolScores:
    scores = np.array(rows, dtype=np.float64)
    names = tuple(f"m{i}" for i in range(len(rows)))
    return ProtocolScores(names=names, categories=("c",) * len(rows), scores=scores, n_rotations=1)


def test_write_section_replaces_only_its_own_markers(tmp_path: Path) -> None:
    path = tmp_path / "docs" / "results.md"
    results_doc.write_section(path, "alpha", "first")
    results_doc.write_section(path, "beta", "second")
    results_doc.write_section(path, "alpha", "third")
    text = path.read_text(encoding="utf-8")
    assert text.startswith("# Results\n")
    assert "<!-- alpha:start -->\nthird\n<!-- alpha:end -->" in text
    assert "<!-- beta:start -->\nsecond\n<!-- beta:end -->" in text
    assert "first" not in text
    assert text.index("alpha") < text.index("beta")


def test_printed_section_writes_what_was_printed_and_keeps_the_rest(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "benchmarks.md"
    path.write_text("# Benchmarks\n\n<!-- speed:start -->\nold\n<!-- speed:end -->\n\nafter\n")
    parser = argparse.ArgumentParser()
    results_doc.add_results_option(parser, "speed")
    args = parser.parse_args(["--results", str(path)])
    monkeypatch.setattr(sys, "argv", ["/x/tools/bench_x.py", "--results", str(path)])
    with results_doc.printed_section(args.results, args.section):
        print("mesh  seconds")
        print("torus    0.14")
    assert capsys.readouterr().out == "mesh  seconds\ntorus    0.14\n"
    text = path.read_text(encoding="utf-8")
    assert f"`python tools/bench_x.py --results {path}`" in text
    assert "```text\nmesh  seconds\ntorus    0.14\n```\n<!-- speed:end -->\n\nafter\n" in text
    assert "old" not in text


def test_command_line_records_the_tool_and_its_quoted_arguments(
        monkeypatch: pytest.MonkeyPatch) -> None:
    tool = "/any/where/tools/bench_x.py"
    assert results_doc.command_line(tool, ["--quick", "my meshes"]) == (
        "python tools/bench_x.py --quick 'my meshes'")
    assert results_doc.command_line(tool, []) == "python tools/bench_x.py"
    monkeypatch.setattr(sys, "argv", [tool, "--results", "docs/results.md"])
    assert results_doc.command_line(tool) == "python tools/bench_x.py --results docs/results.md"


def test_results_option_may_name_a_file_written_by_default() -> None:
    parser = argparse.ArgumentParser()
    results_doc.add_results_option(parser, "labels", default=Path("docs/results.md"))
    args = parser.parse_args([])
    assert (args.results, args.section) == (Path("docs/results.md"), "labels")
    assert parser.parse_args(["--section", "x"]).section == "x"


TOOLS = Path(results_doc.__file__).parent


@pytest.mark.parametrize("tool", sorted(path.name for path in TOOLS.glob("*.py")
                                        if path.name != "results_doc.py"))
def test_every_tool_takes_its_section_and_command_line_from_results_doc(tool: str) -> None:
    source = (TOOLS / tool).read_text(encoding="utf-8")
    assert 'add_argument("--section"' not in source
    assert "shlex.join(" not in source and "sys.argv[1:]" not in source


def test_printed_section_writes_nothing_when_the_run_fails(tmp_path: Path) -> None:
    path = tmp_path / "benchmarks.md"
    with pytest.raises(RuntimeError), results_doc.printed_section(path, "speed"):
        print("half a table")
        raise RuntimeError("failed")
    assert not path.exists()


def test_markdown_table_aligns_labels_left_and_numbers_right() -> None:
    lines = results_doc.markdown_table(["method", "VE", "note"], [["a", "1.0", "x"]], align="lrl")
    assert lines == ["| method | VE | note |", "|---|---:|---|", "| a | 1.0 | x |"]
    assert results_doc.markdown_table(["k", "v"], [])[1] == "|---|---:|"


def test_comparison_table_stars_differences_beyond_two_standard_errors() -> None:
    base = [[50.0, 50, 50, 50], [60, 60, 60, 60], [70, 70, 70, 70], [80, 80, 80, 80]]
    better = [[row[0] + 10 + (i % 2), *row[1:]] for i, row in enumerate(base)]
    rows = {"net": _scores(better), "random": _scores(base)}
    lines = results_doc.comparison_table(rows, "net")
    assert lines[0] == "| net minus | VE | VR | VKL | VMI |"
    label, ve, vr = [cell.strip() for cell in lines[2].strip("|").split("|")][:3]
    assert label == "random"
    assert ve.startswith("+10.5 ± 0.3") and ve.endswith("*")
    assert vr == "+0.0 ± 0.0"
    sem = np.std([50, 60, 70, 80], ddof=1) / 2
    assert results_doc.score_cells(rows["random"])[0] == f"65.0 ± {sem:.1f}"


def test_format_seconds_picks_the_unit() -> None:
    formatted = [results_doc.format_seconds(s) for s in (42, 750, 11160)]
    assert formatted == ["42 s", "12.5 min", "3.1 h"]
