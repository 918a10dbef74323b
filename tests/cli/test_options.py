"""The options several vptool commands share: one definition, defaults from conventions."""

from __future__ import annotations

import click
import pytest

from vptoolkit.best_view.search import BUDGET, SEARCH_RESOLUTION
from vptoolkit.cli import main
from vptoolkit.cli.options import Direction
from vptoolkit.conventions import N_VIEWS, RESOLUTION, SEED
from vptoolkit.errors import InputError


def options_named(name: str) -> dict[str, click.Option]:
    """Each command's option ``name`` (e.g. ``--views``), by command."""
    return {command_name: option for command_name, command in main.commands.items()
            for option in command.params if name in getattr(option, "opts", ())}


@pytest.mark.parametrize("name, default", [("--views", N_VIEWS), ("--resolution", RESOLUTION),
                                           ("--seed", SEED)])
def test_shared_options_take_their_defaults_from_conventions(name, default):
    found = options_named(name)
    assert len(found) >= 2, found
    searches = {"--views": BUDGET, "--resolution": SEARCH_RESOLUTION}  # a search's budget
    expected = {command: searches[name] if command in ("best-view", "thumbnails") else default
                for command in found}
    assert {command: option.default for command, option in found.items()} == expected


def test_workers_and_scheduler_are_one_option_for_every_collection_command():
    workers, scheduler = options_named("--workers"), options_named("--scheduler")
    assert {"build-dataset", "best-view", "thumbnails"} <= set(workers)
    assert set(scheduler) == {"build-dataset", "best-view", "thumbnails"}
    for command in scheduler:
        assert workers[command].default == 1 and workers[command].type.min == 1
        assert scheduler[command].help == scheduler["build-dataset"].help


def test_every_direction_option_is_a_direction():
    found = {**options_named("--up"), **options_named("--view"), **options_named("--predicted")}
    assert found and all(isinstance(option.type, Direction) for option in found.values())


@pytest.mark.parametrize("text, expected", [("1,0,0", (1.0, 0.0, 0.0)),
                                            (" 0, -2 ,1e-3", (0.0, -2.0, 0.001))])
def test_direction_parses_three_numbers_as_typed(text, expected):
    option = click.Option(["--view"], type=Direction())
    assert option.type.convert(text, option, None) == expected


@pytest.mark.parametrize("text, message", [
    ("1,2", r"^--view: expected three numbers x,y,z, got '1,2'$"),
    ("a,b,c", r"^--view: expected three numbers x,y,z"),
    ("0,0,0", r"^--view: expected a finite, non-zero direction x,y,z, got '0,0,0'$"),
    ("nan,0,1", r"^--view: expected a finite, non-zero direction x,y,z, got 'nan,0,1'$"),
    ("0,inf,0", r"^--view: expected a finite, non-zero direction x,y,z, got '0,inf,0'$"),
], ids=["short", "words", "zero", "nan", "inf"])
def test_direction_refuses_bad_vectors_in_one_line_naming_the_option(text, message):
    option = click.Option(["--view"], type=Direction())
    with pytest.raises(InputError, match=message):
        option.type.convert(text, option, None)


@pytest.mark.parametrize("command", ["render", "report", "thumbnails"])
def test_a_zero_up_is_one_error_line_with_exit_2(command, tmp_path):
    from click.testing import CliRunner

    arguments = {"render": [str(tmp_path), "--view", "1,0,0", "-o", str(tmp_path / "x.png")],
                 "report": [str(tmp_path), "-o", str(tmp_path / "r")],
                 "thumbnails": [str(tmp_path), str(tmp_path / "t")]}[command]
    result = CliRunner().invoke(main, [command, *arguments, "--up", "0,0,0"])
    assert result.exit_code == 2
    assert result.stderr.strip().splitlines() == [
        "vptool: error: --up: expected a finite, non-zero direction x,y,z, got '0,0,0'"]


def test_every_split_option_is_the_one_split_option():
    found = options_named("--split")
    assert set(found) == {"evaluate", "predict", "best-view", "report"}
    for option in found.values():
        assert list(option.type.choices) == ["train", "validation", "test", "val", "all"]
        context = click.Context(click.Command("x"))
        assert option.process_value(context, "all") is None  # the library's every model
        assert option.process_value(context, "val") == "val"
    assert found["report"].default == "all" and found["evaluate"].default == "test"
