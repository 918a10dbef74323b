"""The per-mesh licence table of a release: ``LICENSES.csv``.

:func:`read_licenses` reads a publisher's table (``--licenses FILE.csv``: one
row per model name with its licence, author and URL);
:func:`write_licenses` writes the table of a release from the model records'
``provenance``, in model order, so the same records give the same bytes.
"""

from __future__ import annotations

import csv
import io
import unicodedata
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from vptoolkit.errors import InputError

__all__ = ["LICENSES_NAME", "LICENSE_COLUMNS", "read_licenses", "write_licenses"]

LICENSES_NAME = "LICENSES.csv"
"""File name of the table in a release folder."""

LICENSE_COLUMNS = ("name", "license", "author", "url")
"""Header of a per-mesh licence table (``--licenses FILE.csv``)."""


def read_licenses(path: Path | str) -> dict[str, dict[str, str]]:
    """Read a per-mesh licence table.

    Parameters
    ----------
    path : Path or str
        A UTF-8 CSV file whose header holds ``name``, ``license``, ``author``
        and ``url`` (other columns are ignored); one row per model name.

    Returns
    -------
    dict
        Model name -> ``{"license", "author", "url"}`` (empty cells dropped).

    Raises
    ------
    InputError
        On a missing column, an empty name or licence, a repeated name, a
        control character (a tab, a line break, an escape) in a cell or a row
        the CSV reader refuses (a cell longer than its field limit); the
        message names the file and the line.
    """
    source = Path(path)
    try:
        text = source.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"{source.name}: cannot read ({err})") from err
    rows = csv.DictReader(io.StringIO(text, newline=""))  # rows end at line breaks only
    try:
        return _licence_rows(source, rows)
    except csv.Error as err:  # a cell beyond csv.field_size_limit(), a stray NUL
        line = rows.line_num + 1
        raise InputError(f"{source.name}: line {line} is not a CSV row ({err})") from err


def _licence_rows(source: Path, rows: csv.DictReader[str]) -> dict[str, dict[str, str]]:
    missing = [c for c in LICENSE_COLUMNS if c not in (rows.fieldnames or [])]
    if missing:
        raise InputError(f"{source.name}: header lacks the column(s) {', '.join(missing)}")
    table: dict[str, dict[str, str]] = {}
    for line, row in enumerate(rows, start=2):
        name = (row.get("name") or "").strip()
        licence = (row.get("license") or "").strip()
        if not name or not licence:
            raise InputError(f"{source.name}: line {line} needs a name and a license")
        if name in table:
            raise InputError(f"{source.name}: line {line} repeats the model {name!r}")
        for key in LICENSE_COLUMNS:
            control = next((c for c in row.get(key) or "" if unicodedata.category(c) == "Cc"), None)
            if control is not None:
                raise InputError(f"{source.name}: line {line}: the {key} cell holds the control "
                                 f"character U+{ord(control):04X}; remove it")
        table[name] = {key: (row.get(key) or "").strip() for key in LICENSE_COLUMNS[1:]
                       if (row.get(key) or "").strip()}
    return table


def write_licenses(path: Path, records: Sequence[Mapping[str, Any]]) -> None:
    """Write ``LICENSES.csv``: a header, then one row per model record (name, provenance)."""
    lines = [",".join(LICENSE_COLUMNS)]
    for record in records:
        provenance = record.get("provenance") or {}
        cells = [record["name"], *(provenance.get(key, "") for key in LICENSE_COLUMNS[1:])]
        lines.append(",".join(_csv_cell(str(cell)) for cell in cells))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8", newline="\n")


def _csv_cell(text: str) -> str:
    """A CSV cell, quoted when it holds a comma, a quote or a newline."""
    if any(c in text for c in ',"\n'):
        return '"' + text.replace('"', '""') + '"'
    return text
