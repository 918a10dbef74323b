"""What every results script in ``tools/`` shares: markdown tables and ``docs/results.md`` sections.

``docs/results.md`` is written by several scripts, each owning the sections
between its markers ``<!-- NAME:start -->`` and ``<!-- NAME:end -->``
(:func:`write_section`). A results table is markdown (:func:`markdown_table`);
a score cell is ``mean ± standard error`` (:func:`score_cells`), and a
comparison is the paired difference of one row against the others, starred
beyond two standard errors (:func:`comparison_table`). A heading names the
machine (:func:`machine`), the command that ran (:func:`command_line`) and
the wall time (:func:`format_seconds`). Every script that writes a section
takes ``--results FILE`` and ``--section NAME`` (:func:`add_results_option`);
a benchmark that prints its table as plain text writes what it printed into
its section of ``docs/benchmarks.md`` (:func:`printed_section`).

The scripts import this module as a sibling (``import results_doc``): Python
puts a script's own folder first on ``sys.path``, and the tests put
``tools/`` there through pytest's ``pythonpath`` setting.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import platform
import shlex
import sys
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path

from vptoolkit.evaluate.protocol import ProtocolScores, paired_difference
from vptoolkit.measures.registry import PAPER_MEASURES


def machine() -> str:
    """One line naming this machine: platform, processor and CPU count."""
    return (f"{platform.platform(terse=True)}, {platform.processor() or platform.machine()}, "
            f"{os.cpu_count()} CPUs, no GPU used")


def format_seconds(seconds: float) -> str:
    """A wall time in the largest fitting unit: ``42 s``, ``12.5 min`` or ``3.1 h``."""
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


def markers(section: str) -> tuple[str, str]:
    """The start and end markers of ``section`` in a results file."""
    return f"<!-- {section}:start -->", f"<!-- {section}:end -->"


def write_section(path: Path, section: str, text: str) -> None:
    """Replace the text between the markers of ``section`` in ``path`` by ``text``.

    The file (and its folder) is created if missing; a section not yet in it
    is appended, so several scripts can each own their sections of one file.
    """
    start, end = markers(section)
    path.parent.mkdir(parents=True, exist_ok=True)
    old = path.read_text(encoding="utf-8") if path.exists() else "# Results\n\n"
    block = f"{start}\n{text}\n{end}"
    if start in old and end in old:
        new = old[: old.index(start)] + block + old[old.index(end) + len(end):]
    else:
        new = old.rstrip() + "\n\n" + block + "\n"
    path.write_text(new, encoding="utf-8")


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[str]], *,
                   align: str | None = None) -> list[str]:
    """A markdown table, one string per line.

    ``align`` has one letter per column, ``l`` (left) or ``r`` (right); by
    default the first column (the labels) is left-aligned and the others
    (numbers) right-aligned.
    """
    align = align or "l" + "r" * (len(header) - 1)
    rule = "|" + "".join("---:|" if side == "r" else "---|" for side in align)
    lines = ["| " + " | ".join(header) + " |", rule]
    return lines + ["| " + " | ".join(row) + " |" for row in rows]


def score_cells(scores: ProtocolScores) -> list[str]:
    """``mean ± standard error`` of each measure, one decimal (percent)."""
    return [f"{mean:.1f} ± {sem:.1f}" for mean, sem in zip(scores.mean, scores.sem)]


def comparison_table(rows: Mapping[str, ProtocolScores], reference: str) -> list[str]:
    """``reference`` minus every other row, paired over models, per measure.

    A cell is ``difference ± standard error``, starred where the difference
    lies beyond two standard errors.
    """
    lines = []
    for label, scores in rows.items():
        if label == reference:
            continue
        delta, sem = paired_difference(rows[reference], scores)
        lines.append([label, *(f"{d:+.1f} ± {e:.1f}{' *' if abs(d) > 2 * e else ''}"
                               for d, e in zip(delta, sem))])
    return markdown_table([f"{reference} minus", *PAPER_MEASURES], lines)


def add_results_option(parser: argparse.ArgumentParser, section: str, *,
                       default: Path | None = None) -> None:
    """Add ``--results FILE`` and ``--section NAME`` (default ``section``) to ``parser``.

    ``default`` is the file written without ``--results`` (default: None, the
    table is only printed).
    """
    parser.add_argument("--results", type=Path, default=default,
                        help="also write the table into this markdown file, e.g. "
                             "docs/benchmarks.md" if default is None
                        else f"write the table into this markdown file (default: {default})")
    parser.add_argument("--section", default=section,
                        help=f"the section of --results to replace, between its "
                             f"<!-- NAME:start/end --> markers (default: {section})")


def command_line(script: str | os.PathLike[str], argv: Sequence[str] | None = None) -> str:
    """The command that ran, as a section records it: ``python tools/SCRIPT ARGUMENTS``.

    ``script`` is the tool's path (its ``__file__``), ``argv`` its arguments
    (default: ``sys.argv[1:]``), quoted for a POSIX shell.
    """
    arguments = sys.argv[1:] if argv is None else list(argv)
    return shlex.join(["python", f"tools/{Path(script).name}", *arguments])


@contextlib.contextmanager
def printed_section(path: Path | None, section: str) -> Iterator[None]:
    """Print as usual; with ``path``, also write what was printed into ``section`` of it.

    The section holds the command that ran (the script and its arguments), the
    machine (:func:`machine`) and the printed text as a code block. Nothing is
    written if the block raises.
    """
    if path is None:
        yield
        return
    captured, original = io.StringIO(), sys.stdout

    class Tee(io.TextIOBase):
        def write(self, text: str) -> int:
            captured.write(text)
            return original.write(text)

        def flush(self) -> None:
            original.flush()

    command = command_line(sys.argv[0])
    with contextlib.redirect_stdout(Tee()):
        yield
    write_section(path, section, f"`{command}`, {machine()}:\n\n```text\n"
                                 f"{captured.getvalue().strip()}\n```")
