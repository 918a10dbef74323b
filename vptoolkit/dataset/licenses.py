"""The per-mesh licence table of a release: ``LICENSES.csv``.

:func:`read_licenses` reads a publisher's table (``--licenses FILE.csv``: one
row per model name with its licence, author and URL);
:func:`write_licenses` writes the table of a release from the model records'
``provenance``, in model order, so the same records give the same bytes.
:func:`check_license` accepts a licence only as an SPDX identifier (from the
common ones of :data:`SPDX_IDS`, or a ``LicenseRef-`` of one's own) or as
the URL of its text, so that a release's licences can be read by machines;
:func:`check_licenses` checks a table given as a mapping as a file's rows are
checked, and :func:`hub_license` gives the hub's licence fields of a release.
"""

from __future__ import annotations

import csv
import io
import re
import unicodedata
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from vptoolkit.dataset.manifest import CARD_NAME
from vptoolkit.errors import InputError

__all__ = ["LICENSES_NAME", "LICENSE_COLUMNS", "SPDX_IDS", "check_license", "check_licenses",
           "hub_license", "read_licenses", "write_licenses"]

LICENSES_NAME = "LICENSES.csv"
"""File name of the table in a release folder."""

LICENSE_COLUMNS = ("name", "license", "author", "url")
"""Header of a per-mesh licence table (``--licenses FILE.csv``)."""

_CREATIVE_COMMONS = [f"CC-{kind}-{version}" for kind in ("BY", "BY-SA", "BY-NC", "BY-NC-SA",
                                                          "BY-ND", "BY-NC-ND")
                     for version in ("1.0", "2.0", "2.5", "3.0", "4.0")]
SPDX_IDS = frozenset(name.lower() for name in [
    *_CREATIVE_COMMONS, "CC0-1.0", "CC-PDDC", "PDDL-1.0", "ODbL-1.0", "ODC-By-1.0",
    "CDLA-Permissive-1.0", "CDLA-Permissive-2.0", "CDLA-Sharing-1.0", "MIT", "MIT-0",
    "Apache-2.0", "BSD-2-Clause", "BSD-3-Clause", "ISC", "Zlib", "Unlicense", "0BSD",
    "MPL-2.0", "EPL-2.0", "EUPL-1.2", "Artistic-2.0", "GPL-2.0-only", "GPL-2.0-or-later",
    "GPL-3.0-only", "GPL-3.0-or-later", "LGPL-2.1-only", "LGPL-2.1-or-later",
    "LGPL-3.0-only", "LGPL-3.0-or-later", "AGPL-3.0-only", "AGPL-3.0-or-later",
    "GFDL-1.3-only", "GFDL-1.3-or-later",
])
"""The SPDX identifiers :func:`check_license` knows, lower case (the hub's spelling)."""

_LICENSE_REF = re.compile(r"LicenseRef-[A-Za-z0-9.-]+")
_URL = re.compile(r"https?://\S+")


def check_license(value: str, label: str) -> str:
    """Return ``value`` if it is an SPDX identifier or a URL, else raise.

    Identifiers are compared without regard to case (``CC-BY-4.0`` and the
    hub's ``cc-by-4.0`` are both accepted and kept as written).

    Raises
    ------
    InputError
        ``<label>: 'xyz' is not an SPDX licence identifier (e.g. CC-BY-4.0, MIT)
        or a URL``.
    """
    text = value.strip()
    if text.lower() in SPDX_IDS or _LICENSE_REF.fullmatch(text) or _URL.fullmatch(text):
        return text
    raise InputError(f"{label}: {value!r} is not an SPDX licence identifier (e.g. CC-BY-4.0, "
                     "MIT, LicenseRef-...) or the URL of the licence")


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
        _add_row(table, row, f"{source.name}: line {line}")
    return table


def check_licenses(table: Mapping[str, Mapping[str, str]],
                   label: str = "licenses") -> dict[str, dict[str, str]]:
    """Check a parsed per-mesh licence table as :func:`read_licenses` checks a file's rows.

    Parameters
    ----------
    table : mapping
        Model name -> ``{"license", "author", "url"}`` (other keys are
        ignored, as a file's other columns are).
    label : str
        What the messages name (default: ``"licenses"``).

    Returns
    -------
    dict
        Model name -> ``{"license", "author", "url"}``, cells stripped and
        empty ones dropped, as :func:`read_licenses` returns them.

    Raises
    ------
    InputError
        ``<label>: <model>: ...`` for a row that is not a mapping, a cell
        that is not text, and whatever :func:`read_licenses` refuses in a row.
    """
    checked: dict[str, dict[str, str]] = {}
    for model, row in table.items():
        where = f"{label}: {model}"
        if not isinstance(row, Mapping):
            raise InputError(f"{where}: expected a mapping, got {type(row).__name__}")
        cells = {"name": model, **{key: row.get(key) for key in LICENSE_COLUMNS[1:]}}
        for key, value in cells.items():
            if value is not None and not isinstance(value, str):
                raise InputError(f"{where}: the {key} cell: expected text, got "
                                 f"{type(value).__name__}")
        _add_row(checked, cells, where)
    return checked


def _add_row(table: dict[str, dict[str, str]], row: Mapping[str, str | None], where: str) -> None:
    """Check one row of a licence table (cells named by :data:`LICENSE_COLUMNS`) and add it."""
    name = (row.get("name") or "").strip()
    licence = (row.get("license") or "").strip()
    if not name or not licence:
        raise InputError(f"{where} needs a name and a license")
    if name in table:
        raise InputError(f"{where} repeats the model {name!r}")
    for key in LICENSE_COLUMNS:
        control = next((c for c in row.get(key) or "" if unicodedata.category(c) == "Cc"), None)
        if control is not None:
            raise InputError(f"{where}: the {key} cell holds the control "
                             f"character U+{ord(control):04X}; remove it")
    check_license(licence, where)
    table[name] = {key: (row.get(key) or "").strip() for key in LICENSE_COLUMNS[1:]
                   if (row.get(key) or "").strip()}


def hub_license(license: str, license_name: str | None = None,  # noqa: A002 - the hub's field
                license_link: str | None = None, *, table: bool = False) -> dict[str, str]:
    """The dataset hub's ``license``, ``license_name`` and ``license_link`` of a release.

    The hub's ``license`` takes an identifier. A licence given by its URL is
    ``other`` there, named ``"custom"`` and linked to that URL; ``other``
    itself (the release states no licence, the source meshes' apply) is
    named ``"source-mesh-licenses"`` and linked to :data:`LICENSES_NAME`
    with a per-mesh ``table``, else to the card (``README.md``), whose
    licence note says so. A given ``license_name`` or ``license_link`` is
    kept; an identifier has neither unless given.

    Returns
    -------
    dict
        ``license``, and ``license_name`` and ``license_link`` where they have a value.

    Examples
    --------
    >>> hub_license("https://example.org/terms")
    {'license': 'other', 'license_name': 'custom', 'license_link': 'https://example.org/terms'}
    >>> hub_license("other", table=True)["license_link"]
    'LICENSES.csv'
    """
    if license == "other":
        license_name = license_name or "source-mesh-licenses"
        license_link = license_link or (LICENSES_NAME if table else CARD_NAME)
    elif _URL.fullmatch(license):
        license_name = license_name or "custom"
        license_link, license = license_link or license, "other"
    fields = {"license": license, "license_name": license_name, "license_link": license_link}
    return {key: value for key, value in fields.items() if value}


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
