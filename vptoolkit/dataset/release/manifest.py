"""SHA-256 manifests of release folders and the ``verify`` check.

A release folder holds a ``SHA256SUMS`` file in the format of GNU
``sha256sum``: one line ``<64 hex digits>  <path relative to the folder>`` per
file, sorted by path, covering every other file of the folder. ``sha256sum -c
SHA256SUMS`` checks it without vptoolkit.

:func:`verify` goes one level deeper: inside every archive (Zarr zip, Zarr
directory or HDF5) it re-hashes each array and compares the digest with the
array's stored ``sha256`` attribute (see ``vptoolkit/dataset_card/SCHEMA.md``), so a
damaged archive is caught even where no manifest exists. Files are hashed as a
stream of 1 MiB blocks, so memory stays flat for archives of any size.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from vptoolkit.errors import InputError, MissingDependencyError, VerificationError
from vptoolkit.files import is_inside_folder, read_json_file, sha256_file, write_text_atomic

__all__ = [
    "MANIFEST_NAME",
    "CARD_NAME",
    "Problem",
    "VerifyReport",
    "hash_folder",
    "format_sha256sums",
    "write_sha256sums",
    "parse_content_size",
    "parse_sha256sums",
    "read_sha256sums",
    "verify",
]

MANIFEST_NAME = "SHA256SUMS"
"""File name of the manifest inside a release folder."""

CARD_NAME = "README.md"
"""File name of the dataset card inside a release folder (the hub reads it there)."""

_HEX = re.compile(r"[0-9a-f]{64}")
_CONTENT_SIZE = re.compile(r"(\d{1,19}) B")
_LINE = re.compile(r"^(?P<digest>[0-9a-fA-F]{64}) (?P<mode>[ *])(?P<path>.+)$")
_ARCHIVE_SUFFIXES = (".zarr.zip", ".h5", ".hdf5")
_SUMMARY_ITEMS = 3

ProblemKind = Literal["missing", "checksum", "size", "array", "unreadable", "manifest", "attrs",
                      "extra", "skipped"]


@dataclass(frozen=True)
class Problem:
    """One finding of :func:`verify`.

    Attributes
    ----------
    kind : str
        ``"missing"`` (a listed file or a schema array is absent),
        ``"checksum"`` (a file's SHA-256 differs from the manifest),
        ``"size"`` (a file's size differs from its ``contentSize`` in
        ``croissant.json``, or that is not ``"<bytes> B"``),
        ``"array"`` (an array's content differs from its ``sha256`` attribute,
        cannot be decoded, or differs between the archives of one release),
        ``"unreadable"`` (an archive cannot be opened or lacks a schema array),
        ``"manifest"`` (a malformed ``SHA256SUMS`` line), ``"attrs"`` (the
        archive's ``measures`` and ``higher_is_better`` disagree with each
        other, the measure registry or its arrays' columns) or
        ``"extra"`` (a file the manifest does not list; only ever a warning).
    target : str
        What is wrong: a path relative to the verified folder, or
        ``<archive>:<array>`` for an array inside an archive.
    detail : str
        One line saying what differs, e.g. ``expected 3f2a…, got 91c0…``.
    """

    kind: ProblemKind
    target: str
    detail: str

    def __str__(self) -> str:
        return f"{self.target}: {self.detail}"

    def to_dict(self) -> dict[str, str]:
        """Return the finding as JSON types."""
        return {"kind": self.kind, "target": self.target, "detail": self.detail}


@dataclass
class VerifyReport:
    """What :func:`verify` checked and found.

    Attributes
    ----------
    path : Path
        The verified release folder or store.
    kind : {"release", "store"}
        ``"release"`` when a manifest was checked, ``"store"`` for a single store.
    files_checked : int
        Files re-hashed against the manifest (0 for a single store).
    arrays_checked : int
        Arrays re-hashed against their ``sha256`` attribute, over all archives.
    problems : list of Problem
        Failures; the data cannot be trusted if there is any.
    warnings : list of Problem
        Findings that do not fail verification (files the manifest does not list).
    skipped : list of Problem
        Parts that could not be checked because a package is missing (kind
        ``"skipped"``, detail: what to install): an archive's arrays, or the
        comparison of the Parquet shards with an archive. Nothing is known
        to be wrong with them; the summary names them.
    """

    path: Path
    kind: Literal["release", "store"]
    files_checked: int = 0
    arrays_checked: int = 0
    problems: list[Problem] = field(default_factory=list)
    warnings: list[Problem] = field(default_factory=list)
    skipped: list[Problem] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Whether nothing failed and something was verified (warnings, skipped parts allowed)."""
        return not self.problems and not (self.skipped and self.nothing_verified)

    @property
    def nothing_verified(self) -> bool:
        """Whether no file and no array was checked."""
        return self.files_checked == 0 and self.arrays_checked == 0

    @property
    def mismatches(self) -> list[str]:
        """Targets of all problems, in the order found (files, then arrays)."""
        return [problem.target for problem in self.problems]

    def summary(self) -> str:
        """Return one line: what was checked, or the first mismatches and their count."""
        arrays = f"{self.arrays_checked} arrays"
        checked = f"{self.files_checked} files and {arrays}" if self.kind == "release" else arrays
        if self.ok:
            extra = ""
            if self.warnings:
                count = len(self.warnings)
                extra = (f", {count} warning{'s' if count != 1 else ''}: "
                         + "; ".join(str(warning) for warning in self.warnings))
            if self.skipped:
                extra += "; skipped " + "; ".join(str(problem) for problem in self.skipped)
            return f"{self.path}: OK ({checked} verified{extra})"
        if not self.problems:
            shown = "; ".join(str(problem) for problem in self.skipped)
            return f"{self.path}: NOT VERIFIED ({checked} verified; skipped {shown})"
        shown = "; ".join(str(problem) for problem in self.problems[:_SUMMARY_ITEMS])
        more = len(self.problems) - _SUMMARY_ITEMS
        tail = f"; and {more} more" if more > 0 else ""
        count = len(self.problems)
        return f"{self.path}: {count} mismatch{'es' if count != 1 else ''}: {shown}{tail}"

    def raise_if_failed(self) -> None:
        """Raise if any check failed.

        Raises
        ------
        VerificationError
            With :meth:`summary` as its one-line message, if anything mismatches.
        MissingDependencyError
            If nothing mismatches but nothing could be verified either, every
            part skipped for lack of a package (the message says which to
            install).
        """
        if self.problems:
            raise VerificationError(self.summary())
        if not self.ok:
            raise MissingDependencyError(self.summary())

    def to_dict(self) -> dict[str, Any]:
        """Return the report as JSON types."""
        return {
            "path": str(self.path),
            "kind": self.kind,
            "ok": self.ok,
            "files_checked": self.files_checked,
            "arrays_checked": self.arrays_checked,
            "problems": [problem.to_dict() for problem in self.problems],
            "warnings": [problem.to_dict() for problem in self.warnings],
            "skipped": [problem.to_dict() for problem in self.skipped],
        }


def _list_files(folder: Path) -> list[str]:
    """Every file below ``folder`` as sorted POSIX paths relative to it."""
    found = []
    for root, dirs, files in os.walk(folder):
        dirs.sort()
        for name in files:
            found.append((Path(root) / name).relative_to(folder).as_posix())
    return sorted(found)


def _check_listable(relative: str) -> None:
    if "\n" in relative or "\r" in relative or "\\" in relative:
        raise InputError(f"{relative!r}: file names with newlines or backslashes cannot be listed")


def hash_folder(folder: Path | str, *, exclude: Iterable[str] = (MANIFEST_NAME,),
                known: Mapping[str, str] | None = None) -> dict[str, str]:
    """Return the SHA-256 of every file below ``folder``.

    Parameters
    ----------
    folder : Path or str
        The folder; files in subfolders are included.
    exclude : iterable of str
        Relative POSIX paths to leave out (default: the manifest itself).
    known : mapping of str to str, optional
        Relative POSIX path -> SHA-256 of files already hashed (as they were
        written): those digests are taken as they are, the files not read
        again. A path that is not a file below ``folder`` is ignored.

    Returns
    -------
    dict
        Relative POSIX path -> 64 hex digits, sorted by path.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: not a folder")
    skipped = set(exclude)
    given = known or {}
    sums = {}
    for relative in _list_files(folder):
        if relative in skipped:
            continue
        _check_listable(relative)
        sums[relative] = given.get(relative) or sha256_file(folder / relative)
    return sums


def format_sha256sums(sums: Mapping[str, str]) -> str:
    """Return the text of a ``SHA256SUMS`` file: ``<hex>  <path>`` lines sorted by path.

    Raises
    ------
    InputError
        If a digest is not 64 lower-case hex digits or a path cannot be listed.
    """
    lines = []
    for relative in sorted(sums):
        digest = sums[relative]
        if not _HEX.fullmatch(digest):
            raise InputError(f"{relative}: {digest!r} is not a SHA-256 hex digest")
        _check_listable(relative)
        lines.append(f"{digest}  {relative}\n")
    return "".join(lines)


def write_sha256sums(folder: Path | str, known: Mapping[str, str] | None = None) -> dict[str, str]:
    """Hash every file below ``folder`` and write ``folder/SHA256SUMS``.

    Parameters
    ----------
    folder : Path or str
        The folder to list.
    known : mapping of str to str, optional
        Digests of files already hashed, listed without reading them again
        (see :func:`hash_folder`).

    Returns
    -------
    dict
        Relative POSIX path -> SHA-256 of every file listed.
    """
    folder = Path(folder)
    sums = hash_folder(folder, known=known)
    write_text_atomic(folder / MANIFEST_NAME, format_sha256sums(sums))
    return sums


def read_sha256sums(path: Path | str) -> dict[str, str]:
    """Read a ``SHA256SUMS`` file.

    Accepts both ``sha256sum`` modes (``<hex>  path`` and ``<hex> *path``);
    blank lines are skipped.

    Returns
    -------
    dict
        Relative POSIX path -> lower-case hex digest, in file order.

    Raises
    ------
    VerificationError
        On text that is not UTF-8 or does not end with a line break (cut
        short), a malformed line, a repeated path, or a path that is absolute
        or leaves the folder (``..``); the message names the line number.
    """
    path = Path(path)
    return parse_sha256sums(path.read_bytes(), path.name)


def parse_sha256sums(data: bytes, label: str = MANIFEST_NAME) -> dict[str, str]:
    """Parse the bytes of a ``SHA256SUMS`` file, as :func:`read_sha256sums` does.

    ``label`` names the file in error messages (a path or a URL).
    """
    sums: dict[str, str] = {}
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise VerificationError(f"{label}: not UTF-8 text (byte {err.start})") from err
    if text and not text.endswith("\n"):  # a transfer cut short can leave a path that parses
        raise VerificationError(f"{label}: ends in the middle of line "
                                f"{len(text.splitlines())} (cut short?); every line of a "
                                "manifest ends with a line break")
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        match = _LINE.match(line)
        if match is None:
            raise VerificationError(f"{label}: line {number} is not '<sha256>  <path>'")
        relative = match["path"]
        if not is_inside_folder(relative):
            raise VerificationError(f"{label}: line {number} names a path outside the folder")
        if relative in sums:
            raise VerificationError(f"{label}: line {number} repeats {relative}")
        sums[relative] = match["digest"].lower()
    return sums


def _short(digest: str | None) -> str:
    return "none" if digest is None else f"{digest[:12]}..."


def _is_archive(path: Path) -> bool:
    name = path.name
    if name.endswith(".zarr") and path.is_dir():
        return True
    return path.is_file() and name.endswith(_ARCHIVE_SUFFIXES)


def _check_arrays(
    store_path: Path, label: str, report: VerifyReport
) -> dict[str, str | None]:
    """Re-hash every array of one store; return name -> digest of its content."""
    from vptoolkit.dataset.store.reader import open_store
    from vptoolkit.dataset.store.schema import array_sha256

    digests: dict[str, str | None] = {}
    try:
        reader = open_store(store_path, check_chunks=False)  # a lost chunk is a hash mismatch here
    except MissingDependencyError as err:
        report.skipped.append(Problem("skipped", label, f"arrays not checked: {err}"))
        return digests
    except VerificationError as err:
        # Raised from a library's error, it is damaged metadata; raised alone, wrong attributes.
        report.problems.append(
            Problem("unreadable", label, f"cannot open archive ({err.__cause__})")
            if err.__cause__ is not None else Problem("attrs", label, str(err)))
        return digests
    except InputError as err:
        report.problems.append(Problem("unreadable", label, f"cannot open archive ({err})"))
        return digests
    except Exception as err:  # noqa: BLE001 - any failure to open is the finding itself
        report.problems.append(
            Problem("unreadable", label, f"cannot open archive ({type(err).__name__}: {err})")
        )
        return digests
    with reader:
        for name in reader.array_names():
            target = f"{label}:{name}"
            report.arrays_checked += 1
            try:
                stored: str | None = reader.stored_sha256(name)
            except Exception as err:  # noqa: BLE001 - reported, not swallowed
                stored = None
                report.problems.append(Problem("array", target, f"no sha256 attribute ({err})"))
            try:
                actual = array_sha256(reader.array(name))
            except Exception as err:  # noqa: BLE001 - a damaged chunk is the finding
                digests[name] = None
                report.problems.append(Problem(
                    "array", target, f"content unreadable ({type(err).__name__}: {err})"
                ))
                continue
            digests[name] = actual
            if stored is not None and actual != stored:
                report.problems.append(Problem(
                    "array", target,
                    f"array checksum mismatch (stored {_short(stored)}, content {_short(actual)})",
                ))
    return digests


def _compare_archives(found: dict[str, dict[str, str | None]], report: VerifyReport) -> None:
    """Flag arrays whose content differs between the archives of one release."""
    labels = sorted(found)
    if len(labels) < 2:
        return
    first = labels[0]
    for other in labels[1:]:
        for name in sorted(set(found[first]) & set(found[other])):
            a, b = found[first][name], found[other][name]
            if a is not None and b is not None and a != b:
                report.problems.append(Problem(
                    "array", f"{other}:{name}", f"content differs from {first}:{name}"
                ))


def _croissant_sums(folder: Path) -> dict[str, str]:
    """File -> SHA-256 as ``croissant.json`` lists them: a second witness beside the manifest."""
    try:
        document = read_json_file(folder / "croissant.json")
        return {str(item["contentUrl"]): str(item["sha256"]).lower()
                for item in document.get("distribution", [])
                if isinstance(item, dict) and "contentUrl" in item and "sha256" in item}
    except (InputError, AttributeError, TypeError):
        return {}


def parse_content_size(value: object) -> int | None:
    """The bytes a Croissant ``contentSize`` of the form ``"<bytes> B"`` records, else None."""
    match = _CONTENT_SIZE.fullmatch(value) if isinstance(value, str) else None
    return int(match[1]) if match is not None else None


def _check_sizes(folder: Path, report: VerifyReport) -> None:
    """Flag files whose size differs from the ``contentSize`` ``croissant.json`` records.

    A reader of the release by URL bounds each download by that size and refuses
    a server whose ranges give another, so a size that lies is a problem here.
    A file already found damaged is not named again.
    """
    damaged = {problem.target for problem in report.problems}
    try:
        document = read_json_file(folder / "croissant.json")
    except InputError:  # absent or not JSON: the manifest's digests already say so
        return
    distribution = document.get("distribution") if isinstance(document, dict) else None
    for item in distribution if isinstance(distribution, list) else ():
        if not isinstance(item, dict) or "contentSize" not in item:
            continue
        relative = item.get("contentUrl")
        if not isinstance(relative, str) or not is_inside_folder(relative):
            continue
        file = folder / relative
        if relative in damaged or not file.is_file():  # missing: the manifest's finding
            continue
        recorded, actual = parse_content_size(item["contentSize"]), file.stat().st_size
        if recorded is None:
            report.problems.append(Problem(
                "size", relative, f"croissant.json records contentSize "
                f"{str(item['contentSize'])[:40]!r}, not '<bytes> B'"))
        elif recorded != actual:
            report.problems.append(Problem(
                "size", relative,
                f"croissant.json records {recorded} bytes, the file has {actual}"))


def _is_release_folder(path: Path) -> bool:
    """A folder that is a release rather than a build: a manifest, Croissant or archives."""
    if (path / "dataset.zarr").exists() or (path / "dataset.h5").exists():
        return False
    if (path / MANIFEST_NAME).exists() or (path / "croissant.json").exists():
        return True
    return any(_is_archive(entry) for entry in path.iterdir() if not entry.name.startswith("."))


def _verify_release(folder: Path) -> VerifyReport:
    report = VerifyReport(path=folder, kind="release")
    manifest = folder / MANIFEST_NAME
    listed: dict[str, str] = {}
    if not manifest.is_file():
        report.problems.append(Problem("missing", MANIFEST_NAME, "manifest missing"))
    else:
        try:
            listed = read_sha256sums(manifest)
        except (VerificationError, UnicodeDecodeError) as err:
            report.problems.append(Problem("manifest", MANIFEST_NAME, str(err)))
    present = set(_list_files(folder)) - {MANIFEST_NAME}
    witness = _croissant_sums(folder)
    for number, (relative, expected) in enumerate(listed.items(), start=1):
        file = folder / relative
        if not file.is_file():
            report.problems.append(Problem("missing", relative, "listed in SHA256SUMS, not found"))
            continue
        report.files_checked += 1
        actual = sha256_file(file)
        if actual == expected:
            continue
        if witness.get(relative) == actual:
            # The file is what croissant.json says it is: the manifest line is wrong.
            report.problems.append(Problem(
                "manifest", MANIFEST_NAME,
                f"the line for {relative} has digest {_short(expected)}, but the file matches "
                f"croissant.json ({_short(actual)}); the manifest is damaged",
            ))
            continue
        report.problems.append(Problem(
            "checksum", relative,
            f"checksum mismatch (expected {_short(expected)}, got {_short(actual)})",
        ))
    _check_sizes(folder, report)
    if listed:
        for relative in sorted(present - set(listed)):
            report.warnings.append(Problem("extra", relative, "not listed in SHA256SUMS"))
    archives = sorted(
        entry for entry in folder.iterdir() if _is_archive(entry) and not entry.name.startswith(".")
    )
    if not archives and not any(relative.endswith(".parquet") for relative in listed):
        # A Parquet-only release is checked by the manifest's digests alone.
        report.problems.append(Problem("missing", folder.name or str(folder),
                                       "no archive (*.zarr.zip, *.h5) in the release"))
    found = {}
    for archive in archives:
        found[archive.name] = _check_arrays(archive, archive.name, report)
    _compare_archives(found, report)
    from vptoolkit.dataset.release.parquet import parse_shard_name

    shards = sorted(relative for relative in present if parse_shard_name(relative) is not None)
    intact = [archive for archive in archives
              if found[archive.name] and None not in found[archive.name].values()]
    if shards and intact:
        _compare_shards(folder, intact[0], shards, report)
    return report


def _compare_shards(folder: Path, archive: Path, shards: list[str], report: VerifyReport) -> None:
    """Flag Parquet shards whose rows differ from the archive's models."""
    from vptoolkit.dataset.release.parquet import shard_differences
    from vptoolkit.dataset.store.reader import open_store

    try:
        with open_store(archive, check_chunks=False) as reader:
            differences = shard_differences(reader, folder, shards)
    except MissingDependencyError as err:
        report.skipped.append(Problem(
            "skipped", ", ".join(shards), f"contents not compared with {archive.name}: {err}"))
        return
    for target, detail in differences:
        report.problems.append(Problem("array", target, f"{detail} ({archive.name})"))


def verify(path: Path | str) -> VerifyReport:
    """Verify a release folder, a single store or a build output folder.

    Parameters
    ----------
    path : Path or str
        A release folder (it holds ``SHA256SUMS``, ``croissant.json`` or
        archives, and no ``dataset.zarr``/``dataset.h5`` of a build): every
        listed file is re-hashed against the manifest (a missing manifest is
        a problem), files it does not list become warnings, then every array
        of every archive in the folder is re-hashed against its ``sha256``
        attribute and compared across archives, and every row of the Parquet
        shards is compared with the first intact archive (a release of
        Parquet shards only is checked by the manifest alone). An archive, or
        shards, that cannot be read for lack of a package is ``skipped``, not
        damaged. Otherwise any path
        :func:`vptoolkit.dataset.store.containers.find_store` accepts (a ``*.zarr``,
        ``*.zarr.zip`` or ``*.h5`` store, or a build folder): array checks only.

    Returns
    -------
    VerifyReport
        ``report.ok`` is False if anything mismatches; call
        ``report.raise_if_failed()`` to turn that into a
        :class:`~vptoolkit.errors.VerificationError`.

    Raises
    ------
    InputError
        If ``path`` does not exist or holds no store.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file or folder")
    if path.is_dir() and not path.name.endswith(".zarr") and _is_release_folder(path):
        return _verify_release(path)
    from vptoolkit.dataset.store.containers import find_store

    store_path = find_store(path)
    report = VerifyReport(path=path, kind="store")
    try:
        label = store_path.relative_to(path).as_posix() if store_path != path else path.name
    except ValueError:
        label = store_path.name
    _check_arrays(store_path, label, report)
    return report
