"""tools/appearance_figures.py: the before and after sheets of the samples, small PNG files."""

from __future__ import annotations

from pathlib import Path

from fixtures.environment import require_package
from fixtures.pictures import read_png
from fixtures.scripts import RunTool


def test_figures_are_two_small_sheets_and_a_timing(tmp_path: Path, run_tool: RunTool) -> None:
    require_package("PIL")
    require_package("matplotlib")
    result = run_tool("appearance_figures.py", str(tmp_path))
    assert result.returncode == 0, result.stderr[-2000:]
    sheets = [tmp_path / "appearance_before.png", tmp_path / "appearance_after.png"]
    for sheet in sheets:
        assert sheet.stat().st_size < 300_000
    before, after = (read_png(sheet) for sheet in sheets)
    assert before.shape == after.shape and before.shape[1] > 6 * 128  # six tiles a row
    assert (before != after).any()
    assert sum("Duck.glb 256 px" in line for line in result.stdout.splitlines()) == 2
