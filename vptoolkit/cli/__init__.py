"""The ``vptool`` command line.

Each command parses its options, calls one library function and prints a
short result. Errors become one line on stderr and an exit code:
0 success, 1 a measurement or verification failure, 2 bad input or a missing
dependency (:mod:`vptoolkit.cli.group`). Heavy packages are imported inside
the commands, so ``--help`` stays fast.

Modules: ``group`` (the click group: one-line errors, exit codes), ``options``
(options and types several commands share, defaults from
:mod:`vptoolkit.conventions`), ``measure`` (measures, views, clean, sample),
``dataset`` (build-dataset, pack, verify, info, import-authors,
export-authors), ``learn`` (train, predict, evaluate), ``best_view`` (best-view)
and ``pictures`` (render, sphere-map, report, thumbnails).
"""

from __future__ import annotations

import click

from vptoolkit.cli import best_view, dataset, learn, measure, pictures
from vptoolkit.cli.group import VptoolGroup

__all__ = ["main"]


@click.group(cls=VptoolGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="vptoolkit")
def main() -> None:
    """Find good viewpoints on 3D models.

    \b
    Example:
      vptool measures bunny.ply --views 1000 --resolution 1024 -o bunny.npz
    """


for _command in (*measure.COMMANDS, *best_view.COMMANDS, *dataset.COMMANDS, *learn.COMMANDS,
                 *pictures.COMMANDS):
    main.add_command(_command)
del _command
