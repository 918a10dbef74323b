"""The vptool group: every command's help, and a missing extra as one error line."""

from __future__ import annotations

from vptoolkit.cli import main


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
