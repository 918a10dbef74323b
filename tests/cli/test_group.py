"""The vptool group: every command's help, a missing extra as one error line, options named."""

from __future__ import annotations

import pytest

from vptoolkit.cli import main
from vptoolkit.cli.group import options_named
from vptoolkit.errors import ArgumentError, InputError


def test_every_command_has_help_with_an_example(runner):
    for command in main.commands:
        result = runner.invoke(main, [command, "--help"])
        assert result.exit_code == 0 and "Example" in result.output, command


def test_a_command_needing_an_extra_says_which_in_one_line(monkeypatch, tmp_path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    def missing(*args: object, **kwargs: object) -> None:
        raise ModuleNotFoundError("No module named 'trimesh'", name="trimesh")

    import vptoolkit.io

    monkeypatch.setattr(vptoolkit.io, "load", missing)
    mesh = tmp_path / "a.off"
    mesh.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    result = CliRunner().invoke(main, ["measures", str(mesh)])
    assert result.exit_code == 2
    assert result.stderr == ("vptool: error: trimesh: not installed; this command needs it: "
                             "pip install 'vptoolkit[measures]'\n")


def test_options_named_says_the_option_where_the_library_names_its_argument() -> None:
    template = "{argument}: split 'test' of d.zarr has no models; choose another with {argument}"
    with pytest.raises(ArgumentError) as said:
        with options_named(val_split="--val-split"):
            raise ArgumentError(template, "val_split")
    assert str(said.value) == ("--val-split: split 'test' of d.zarr has no models; choose "
                               "another with --val-split")
    with pytest.raises(ArgumentError, match="pass --category here"):
        with options_named(category_="--category"):
            raise ArgumentError("pass {argument} here", "category=")
    with pytest.raises(InputError, match="^val_split: as written$"):  # not an ArgumentError
        with options_named(val_split="--val-split"):
            raise InputError("val_split: as written")
