"""The per-mesh licence table of a release: ``LICENSES.csv``.

:func:`read_licenses` reads a publisher's table (``--licenses FILE.csv``: one
row per model name with its licence, author and URL);
:func:`write_licenses` writes the table of a release from the model records'
``provenance``, in model order, so the same records give the same bytes.
:func:`check_license` accepts a licence only as an SPDX licence expression
(an identifier of the SPDX licence list such as ``BSL-1.0``, a ``LicenseRef-``
of one's own, or ``MIT OR Apache-2.0``; validated by ``packaging.licenses``,
which carries the SPDX list) or as the URL of its text, so that a release's
licences can be read by machines; :func:`check_licenses` checks a table given
as a mapping as a file's rows are checked, and :func:`hub_license` gives the
hub's licence fields of a release.

:func:`license_conflicts` says which terms the sources state themselves
(:func:`source_terms`: ModelNet's, ShapeNet's, the paper authors' release, and
each model's own licence, from ``LICENSES.csv`` or its stored ``provenance``)
a release licence contradicts, and :func:`check_release_license` refuses such
a licence unless the publisher forces it.
"""

from __future__ import annotations

import csv
import io
import re
import unicodedata
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from packaging.licenses import InvalidLicenseExpression, canonicalize_license_expression

from vptoolkit.dataset.release.manifest import CARD_NAME
from vptoolkit.errors import ArgumentError, InputError

__all__ = ["AUTHORS_SOURCE", "LICENSES_NAME", "LICENSE_COLUMNS", "MODELNET_SOURCE",
           "SHAPENET_SOURCE", "SourceTerms", "check_license", "check_licenses",
           "check_release_license", "hub_license", "license_conflicts", "read_licenses",
           "same_license", "source_terms", "write_licenses"]

LICENSES_NAME = "LICENSES.csv"
"""File name of the table in a release folder."""

LICENSE_COLUMNS = ("name", "license", "author", "url")
"""Header of a per-mesh licence table (``--licenses FILE.csv``)."""

_URL = re.compile(r"https?://\S+")
_OPERATOR = re.compile(r"\s(AND|OR|WITH)\s", re.IGNORECASE)


def check_license(value: str, label: str) -> str:
    """Return ``value`` as written if it is an SPDX licence expression or a URL, else raise.

    An expression is an identifier of the SPDX licence list (``BSL-1.0``,
    ``OFL-1.1``; any case, so the hub's ``cc-by-4.0`` passes), a
    ``LicenseRef-`` of one's own, or a combination with ``AND``, ``OR``,
    ``WITH`` and parentheses (``MIT OR Apache-2.0``), as
    ``packaging.licenses.canonicalize_license_expression`` accepts it.

    Raises
    ------
    InputError
        ``<label>: 'xyz' is not an SPDX licence identifier or expression
        (...) or the URL of the licence``.
    """
    text = value.strip()
    if _URL.fullmatch(text):
        return text
    try:
        canonicalize_license_expression(text)
    except InvalidLicenseExpression as err:
        raise ArgumentError(f"{{argument}}: {value!r} is not an SPDX licence identifier or "
                            "expression (e.g. CC-BY-4.0, MIT OR Apache-2.0, LicenseRef-...) or "
                            "the URL of the licence", label) from err
    return text


def same_license(first: str, second: str) -> bool:
    """Whether two checked licences are the same: equal SPDX expressions, or equal URLs.

    Expressions are compared in their canonical SPDX spelling, so ``mit``
    and ``MIT`` are the same licence; a URL equals only the same URL.
    """
    if _URL.fullmatch(first) or _URL.fullmatch(second):
        return first == second
    return canonicalize_license_expression(first) == canonicalize_license_expression(second)


@dataclass(frozen=True)
class SourceTerms:
    """Terms of use that a source states for its meshes.

    Attributes
    ----------
    name : str
        Who states them (``"ModelNet"``).
    terms : str
        What they say, in one clause.
    url : str
        Where they are written; a release licence equal to it states them.
    """

    name: str
    terms: str
    url: str


MODELNET_SOURCE = SourceTerms(
    "ModelNet", "academic research only; the CAD models' authors hold the copyright",
    "https://modelnet.cs.princeton.edu/")
"""ModelNet's terms (ModelNet10/40): a source whose name starts with ``ModelNet``."""

SHAPENET_SOURCE = SourceTerms(
    "ShapeNet", "non-commercial research and education only; the models' authors hold "
    "the copyright", "https://shapenet.org/terms")
"""ShapeNet's terms of use: a source whose name starts with ``ShapeNet``."""

AUTHORS_SOURCE = SourceTerms(
    "the paper authors' release", "ModelNet40 meshes, points and measures, under ModelNet's "
    "terms: academic research only", "https://github.com/schellmi42/viewpoint_learning")
"""The paper authors' data: a store written by ``vptool import-authors`` (backend ``imported``)."""

_NAMED_SOURCES = ((re.compile(r"modelnet", re.IGNORECASE), MODELNET_SOURCE),
                  (re.compile(r"shapenet", re.IGNORECASE), SHAPENET_SOURCE))


def source_terms(attrs: Mapping[str, Any]) -> list[SourceTerms]:
    """The terms a store's sources state, from its root attributes.

    Parameters
    ----------
    attrs : mapping
        A store's root attributes (or :func:`~vptoolkit.dataset.store.info.info_from_reader`'s
        summary): ``source`` (the source folder's name) and ``backend``.

    Returns
    -------
    list of SourceTerms
        :data:`MODELNET_SOURCE` or :data:`SHAPENET_SOURCE` for a source named
        so, and :data:`AUTHORS_SOURCE` for a store imported from the paper
        authors' release; empty when none is known.
    """
    source = str(attrs.get("source") or "")
    found = [terms for pattern, terms in _NAMED_SOURCES if pattern.match(source)]
    if attrs.get("backend") == "imported":
        found.append(AUTHORS_SOURCE)
    return found


def license_conflicts(license: str, attrs: Mapping[str, Any],  # noqa: A002 - the option's name
                      records: Sequence[Mapping[str, Any]],
                      table: Mapping[str, Mapping[str, str]] | None = None) -> list[str]:
    """What a blanket release licence contradicts among the terms the sources state.

    Parameters
    ----------
    license : str
        The release licence (checked by :func:`check_license`), or
        ``"other"``, which states none and contradicts nothing.
    attrs : mapping
        The store's root attributes, read by :func:`source_terms`.
    records : sequence of mapping
        The store's model records (``name``, optional ``provenance``).
    table : mapping, optional
        A per-mesh licence table (:func:`read_licenses`); a model's row
        replaces its stored ``provenance``.

    Returns
    -------
    list of str
        One phrase per contradicted source (``"the terms of ModelNet (academic
        research only; ...; https://modelnet.cs.princeton.edu/)"``), then one
        per other licence that models carry (``"the licence mit of 2 models
        in LICENSES.csv (chair_0001, ...)"``); empty when there is no
        contradiction. A licence equal to a source's terms URL states them.
    """
    if license == "other":
        return []
    found = [f"the terms of {terms.name} ({terms.terms}; {terms.url})"
             for terms in source_terms(attrs) if license != terms.url]
    by_licence: dict[str, list[str]] = {}
    for record in records:
        row = (table or {}).get(str(record.get("name"))) or record.get("provenance") or {}
        own = row.get("license") if isinstance(row, Mapping) else None
        if own and own != "other" and not same_license(str(own), license):
            by_licence.setdefault(str(own), []).append(str(record.get("name")))
    for own, names in by_licence.items():
        shown = ", ".join(names[:3]) + (", ..." if len(names) > 3 else "")
        count = f"{len(names)} model{'s' if len(names) != 1 else ''}"
        found.append(f"the licence {own} of {count} in {LICENSES_NAME} ({shown})")
    return found


def check_release_license(license: str, attrs: Mapping[str, Any],  # noqa: A002
                          records: Sequence[Mapping[str, Any]],
                          table: Mapping[str, Mapping[str, str]] | None = None, *,
                          force: bool, where: str) -> None:
    """Refuse a blanket release licence that contradicts the sources' own terms.

    Parameters
    ----------
    license, attrs, records, table
        As :func:`license_conflicts` takes them.
    force : bool
        The publisher's decision to release under ``license`` anyway
        (``vptool pack --force-license``); the card then records it.
    where : str
        What the message names first: the store.

    Raises
    ------
    InputError
        ``<where>: --license X contradicts the terms of ModelNet (...); pack with
        --license other (the sources' terms apply) or add --force-license
        to record your decision in the card``, unless ``force``.
    """
    conflicts = license_conflicts(license, attrs, records, table)
    if conflicts and not force:
        raise InputError(f"{where}: --license {license} contradicts {'; and '.join(conflicts)}; "
                         "pack with --license other (the sources' terms apply) or add "
                         "--force-license to record your decision in the card")


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
    ``other`` there, named ``"custom"`` and linked to that URL; an expression
    of several licences (``MIT OR Apache-2.0``) is ``other``, named after it
    (``"mit-or-apache-2.0"``) and linked to the card; ``other``
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
    >>> hub_license("MIT OR Apache-2.0")["license_name"]
    'mit-or-apache-2.0'
    """
    if license == "other":
        license_name = license_name or "source-mesh-licenses"
        license_link = license_link or (LICENSES_NAME if table else CARD_NAME)
    elif _URL.fullmatch(license):
        license_name = license_name or "custom"
        license_link, license = license_link or license, "other"
    elif _OPERATOR.search(license):
        license_name = license_name or re.sub(r"[^a-z0-9.]+", "-", license.lower()).strip("-")
        license_link, license = license_link or CARD_NAME, "other"
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
