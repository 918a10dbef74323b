"""The click group class of ``vptool``: every error becomes one line and an exit code.

Exit codes: 0 success, 1 a measurement or verification failure, 2 bad input
or a missing dependency. Option errors read ``vptool: error: COMMAND: ...``;
toolkit errors read ``vptool: error: ...`` with the error's own message.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import click

from vptoolkit.checks import one_line
from vptoolkit.errors import ArgumentError, InputError, MissingDependencyError, VptoolkitError

__all__ = ["EXIT_FAILURE", "EXIT_BAD_INPUT", "VptoolGroup", "exit_code", "one_line_error",
           "options_named"]

EXIT_FAILURE = 1
EXIT_BAD_INPUT = 2


def exit_code(error: BaseException) -> int:
    """The exit status of a toolkit error, by its class.

    2 for bad input (an :class:`~vptoolkit.errors.InputError`, a bad
    checkpoint included) or a missing package, 1 for everything else (a
    measurement or verification failure).
    """
    if isinstance(error, (InputError, MissingDependencyError)):
        return EXIT_BAD_INPUT
    return EXIT_FAILURE


class VptoolGroup(click.Group):
    """A click group that turns toolkit errors into one line and an exit code."""

    def main(self, args: Any = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True,
             **extra: Any) -> Any:
        """Run the command line; option errors become the same one line as every other error."""
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        try:
            returned = super().main(args, prog_name, complete_var, False, **extra)
        except click.UsageError as error:
            where = (f"{error.ctx.info_name}: "
                     if error.ctx is not None and error.ctx.parent is not None else "")
            click.echo(f"vptool: error: {where}{one_line(error.format_message())}", err=True)
            sys.exit(EXIT_BAD_INPUT)
        except click.ClickException as error:
            click.echo(f"vptool: error: {one_line(error.format_message())}", err=True)
            sys.exit(error.exit_code)
        except click.Abort:
            click.echo("vptool: error: aborted", err=True)
            sys.exit(EXIT_FAILURE)
        sys.exit(returned if isinstance(returned, int) else 0)

    def invoke(self, context: click.Context) -> Any:
        """Run the subcommand; a toolkit, import, file or memory error becomes one line."""
        try:
            return super().invoke(context)
        except VptoolkitError as error:
            click.echo(f"vptool: error: {one_line_error(error)}", err=True)
            sys.exit(exit_code(error))
        except ModuleNotFoundError as error:
            click.echo(f"vptool: error: {_missing_module_line(error)}", err=True)
            sys.exit(EXIT_BAD_INPUT)
        except OSError as error:
            where = f"{error.filename}: " if error.filename else ""
            click.echo(f"vptool: error: {where}{one_line(error.strerror or error)}", err=True)
            sys.exit(EXIT_BAD_INPUT)
        except MemoryError:
            click.echo(f"vptool: error: {context.invoked_subcommand or 'vptool'}: not enough "
                       "memory for these options; ask for less", err=True)
            sys.exit(EXIT_BAD_INPUT)


def one_line_error(error: BaseException) -> str:
    """The message of an error on one line, without the length cap of :func:`one_line`."""
    return " ".join(str(error).replace("<br>", " ").split()) or type(error).__name__


def _missing_module_line(error: ModuleNotFoundError) -> str:
    """One line for a package this install lacks: which one, and the extra that brings it.

    A plain ``pip install vptoolkit`` is the light reader; a command that needs
    a heavy stack (measures, cleaning, learning, pictures) lands here.
    """
    from vptoolkit.optional import install_hint

    module = error.name or "a package"
    return f"{module}: not installed; this command needs it: {install_hint(module)}"


@contextmanager
def options_named(**names: str) -> Iterator[None]:
    """Say the command line's option for a library argument in the errors of the calls inside.

    The library's :class:`~vptoolkit.errors.ArgumentError` names the argument
    it is about (``val_split``, ``category=``) as a template; a command maps
    each argument on to its option, e.g. ``options_named(val_split="--val-split")``,
    and the error is said again with the option in the argument's places
    (:meth:`~vptoolkit.errors.ArgumentError.named`). A key ending in ``_``
    stands for the argument written with ``=`` (``category_`` for
    ``category=``). The error keeps its class, so the exit code is unchanged.
    """
    try:
        yield
    except ArgumentError as error:
        options = {(f"{name[:-1]}=" if name.endswith("_") else name): option
                   for name, option in names.items()}
        if error.argument not in options:
            raise
        raise error.named(options[error.argument]) from error
