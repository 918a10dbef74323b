"""``vptool sphere-map`` of other measures: the .npz's recorded ones, and a mesh's measures
computed first (``--measures all``: the registry's 22 on one figure)."""

from __future__ import annotations

from pathlib import Path

import pytest

from fixtures.environment import require_package
from fixtures.pictures import read_png
from vptoolkit.cli import main
from vptoolkit.measures.registry import all_measures
from vptoolkit.samples import sample_path

MUG = str(sample_path("mug.obj"))
SMALL = ["--views", "60", "--resolution", "32"]


@pytest.fixture(scope="module")
def three(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``vptool measures mug.obj --measures NVT,SL,MD -o mug.npz``."""
    from click.testing import CliRunner

    out = tmp_path_factory.mktemp("three") / "mug.npz"
    result = CliRunner().invoke(main, ["measures", MUG, "--measures", "NVT,SL,MD", *SMALL,
                                       "-o", str(out)])
    assert result.exit_code == 0, result.output
    return out


def one_error_line(result) -> str:
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("vptool: error: ")
    return lines[0]


def test_an_npz_of_three_measures_draws_them_all_or_one(runner, three, tmp_path):
    require_package("matplotlib")
    grid = tmp_path / "grid.png"
    result = runner.invoke(main, ["sphere-map", str(three), "--measures", "all", "-o", str(grid)])
    assert result.exit_code == 0, result.output
    assert read_png(grid).shape[:2] == (340, 1200)
    single = tmp_path / "sl.png"
    result = runner.invoke(main, ["sphere-map", str(three), "--measure", "sl", "--dpi", "50",
                                  "-o", str(single)])
    assert result.exit_code == 0, result.output
    assert read_png(single).shape[:2] == (270, 320)
    first = runner.invoke(main, ["sphere-map", str(three), "-o", str(tmp_path / "first.png")])
    assert first.exit_code == 0, first.output


def test_all_measures_of_a_mesh_on_one_figure(runner, tmp_path):
    require_package("matplotlib")
    out = tmp_path / "all.png"
    result = runner.invoke(main, ["sphere-map", MUG, "--measures", "all", *SMALL, "--dpi", "40",
                                  "-o", str(out)])
    assert result.exit_code == 0, result.output
    names = list(all_measures())
    assert result.stdout.strip() == f"wrote {out} ({', '.join(names)})"
    rows = -(-len(names) // 4)
    assert read_png(out).shape[:2] == (round(40 * 3.4 * rows), 480)
    one = tmp_path / "ins.png"
    result = runner.invoke(main, ["sphere-map", MUG, "--measure", "ins", *SMALL, "-o", str(one)])
    assert result.exit_code == 0, result.output
    assert read_png(one).shape[:2] == (540, 640) and "(INS)" in result.stdout


@pytest.mark.parametrize(("arguments", "message"), [
    (["--measures", "VE,XX"], "--measures: unknown measure 'XX'"),
    (["--measure", "XX"], "--measure: unknown measure 'XX'"),
    (["--measure", "VE", "--measures", "all"], "give --measure or --measures, not both"),
    (["--measures", "VE"], "mug.npz: measure: no column for measure 'VE'; the quality has "
                           "NVT, SL, MD"),
    (["--measure", "vkl"], "mug.npz: measure: no column for measure 'VKL'"),
], ids=["unknown-list", "unknown-one", "both", "unrecorded-list", "unrecorded-one"])
def test_bad_measures_are_one_line(runner, three, tmp_path, arguments, message):
    out = tmp_path / "map.png"
    result = runner.invoke(main, ["sphere-map", str(three), *arguments, "-o", str(out)])
    assert result.exit_code == 2
    assert message in one_error_line(result)
    assert not out.exists()
