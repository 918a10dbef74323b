"""Pack a built dataset into a release folder.

A release folder holds, for ``name = "vptoolkit-viewpoints"``::

    vptoolkit-viewpoints.zarr.zip   Zarr v3 zip store
    vptoolkit-viewpoints.h5         HDF5 file, same arrays and attributes
    README.md                       dataset card (YAML header + datasheet)
    croissant.json                  Croissant 1.0 JSON-LD, FileObjects with SHA-256
    dataset_info.json               :func:`~vptoolkit.dataset.card.dataset_info` as JSON
    SHA256SUMS                      ``sha256sum`` manifest of every other file

:func:`pack_release` writes all of it into a hidden temporary sibling folder
and renames that into place at the end, so the release folder either does not
exist, stays empty, or is complete. :func:`~vptoolkit.dataset.manifest.verify`
checks a release; :func:`~vptoolkit.dataset.card.dataset_info` and
:func:`~vptoolkit.dataset.card.format_info` describe one. They are re-exported
here so the command line needs one import.
"""

from __future__ import annotations

import errno
import json
import os
import re
import shutil
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, overload

from vptoolkit.dataset.card import (
    croissant_jsonld,
    dataset_info,
    format_info,
    info_from_reader,
    render_card,
)
from vptoolkit.dataset.manifest import MANIFEST_NAME, VerifyReport, sha256_file, verify, write_sha256sums
from vptoolkit.errors import InputError, VerificationError
from vptoolkit.files import remove_stale_partials, temporary_prefix, write_text_atomic

if TYPE_CHECKING:
    from vptoolkit.dataset.store import ModelEntry, StoreReader

__all__ = [
    "DEFAULT_NAME",
    "CARD_NAME",
    "CROISSANT_NAME",
    "INFO_NAME",
    "ReleaseResult",
    "pack_release",
    "verify",
    "VerifyReport",
    "dataset_info",
    "format_info",
]

DEFAULT_NAME = "vptoolkit-viewpoints"
"""Base name of the archives when :func:`pack_release` is given no ``name``."""

CARD_NAME = "README.md"
CROISSANT_NAME = "croissant.json"
INFO_NAME = "dataset_info.json"

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")


@dataclass(frozen=True)
class ReleaseResult:
    """What :func:`pack_release` wrote.

    Attributes
    ----------
    path : Path
        The release folder.
    name : str
        Base name of the archives.
    zarr_zip : Path
        The Zarr v3 zip store, ``<path>/<name>.zarr.zip``.
    hdf5 : Path
        The HDF5 file, ``<path>/<name>.h5``.
    card : Path
        The dataset card, ``README.md``.
    croissant : Path
        The Croissant metadata, ``croissant.json``.
    manifest : Path
        ``SHA256SUMS``.
    files : dict
        Relative path -> SHA-256 hex digest of every file listed in the manifest.
    n_models : int
        Models in the release.
    n_failures : int
        Inputs the build could not process (listed in the archives and the card).
    """

    path: Path
    name: str
    zarr_zip: Path
    hdf5: Path
    card: Path
    croissant: Path
    manifest: Path
    files: dict[str, str]
    n_models: int
    n_failures: int

    @property
    def total_bytes(self) -> int:
        """Size of every file of the release, manifest included."""
        return sum((self.path / name).stat().st_size for name in [*self.files, MANIFEST_NAME])


class _ReaderEntries(Sequence["ModelEntry"]):
    """The models of an open store as a lazy sequence: entry ``i`` is read on access."""

    def __init__(self, reader: StoreReader) -> None:
        self._reader = reader
        self._length = len(reader.models())

    def __len__(self) -> int:
        return self._length

    @overload
    def __getitem__(self, index: int) -> ModelEntry: ...

    @overload
    def __getitem__(self, index: slice) -> Sequence[ModelEntry]: ...

    def __getitem__(self, index: int | slice) -> ModelEntry | Sequence[ModelEntry]:
        if isinstance(index, slice):
            return [self._reader.entry(i) for i in range(*index.indices(self._length))]
        return self._reader.entry(index)


def _check_name(name: str) -> None:
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise InputError(
            f"name: {name!r} must start with a letter or digit and hold only letters, "
            "digits, '.', '_' and '-'"
        )


def _check_source_intact(source: Path) -> None:
    """Re-hash every array of the store to pack against its ``sha256``, before writing anything.

    Packing re-computes each array's digest from what it reads, so a damaged
    chunk (a flipped byte, or a deleted one that zarr reads as zeros) would
    otherwise ship with a fresh, matching checksum.

    Raises
    ------
    VerificationError
        Naming the mismatching arrays; nothing is written.
    """
    report = verify(source)
    if not report.ok:
        raise VerificationError(f"{report.summary()}; nothing packed")


def _check_release_dir(release_dir: Path) -> None:
    if release_dir.exists() or release_dir.is_symlink():
        if not release_dir.is_dir():
            raise InputError(f"{release_dir}: exists and is not a folder")
        if any(release_dir.iterdir()):
            raise InputError(
                f"{release_dir}: folder is not empty; pack into a new or empty folder"
            )


def _write_json(path: Path, value: Any) -> None:
    text = json.dumps(value, indent=2, ensure_ascii=False, allow_nan=False)
    write_text_atomic(path, text + "\n")


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _publish(staging: Path, release_dir: Path) -> None:
    """Rename ``staging`` to ``release_dir``, which must be absent or an empty folder."""
    os.chmod(staging, 0o777 & ~_umask())  # mkdtemp made it private
    try:
        # rename(2) replaces an empty directory atomically and refuses a non-empty one.
        os.rename(staging, release_dir)
    except OSError as err:
        if err.errno in (errno.ENOTEMPTY, errno.EEXIST):
            raise InputError(
                f"{release_dir}: folder was filled while packing; release left untouched"
            ) from err
        if release_dir.is_dir() and not any(release_dir.iterdir()):
            # Platforms whose rename refuses any existing target (Windows).
            release_dir.rmdir()
            os.rename(staging, release_dir)
            return
        raise


def pack_release(
    dataset: Path | str,
    release_dir: Path | str,
    *,
    name: str | None = None,
    license: str = "other",  # noqa: A002 - the dataset-hub field is called license
    progress: bool = False,
) -> ReleaseResult:
    """Pack a built dataset into a release folder.

    The models are copied entry by entry (never all in memory) into a Zarr v3
    zip store and an HDF5 file with the same attributes and failure log, then
    the dataset card, Croissant metadata, a JSON summary and the
    ``SHA256SUMS`` manifest are written. Everything goes into a hidden
    temporary sibling of ``release_dir`` that is renamed into place at the
    end; on any error it is removed and ``release_dir`` is left as it was.

    Parameters
    ----------
    dataset : Path or str
        A built dataset: a store or any folder
        :func:`vptoolkit.dataset.store.find_store` accepts.
    release_dir : Path or str
        Output folder; must not exist or be empty. Its parent folders are
        created.
    name : str, optional
        Base name of the archives (default: ``"vptoolkit-viewpoints"``).
    license : str
        Licence identifier of the annotations for the card and Croissant
        metadata (default: ``"other"``; the source meshes' licences apply).
    progress : bool
        Show progress bars while the archives are written (default: False).

    Returns
    -------
    ReleaseResult

    Raises
    ------
    InputError
        If ``release_dir`` exists and is not an empty folder, ``name`` is not a
        plain file name, or ``dataset`` holds no readable store.
    VerificationError
        If an array of ``dataset`` differs from its stored SHA-256 (checked
        before anything is written).
    """
    from vptoolkit.dataset.store import find_store, open_store, write_dataset

    base = DEFAULT_NAME if name is None else name
    _check_name(base)
    target = Path(release_dir)
    _check_release_dir(target)
    source = find_store(dataset)
    _check_source_intact(source)
    target.parent.mkdir(parents=True, exist_ok=True)

    zip_name, h5_name = f"{base}.zarr.zip", f"{base}.h5"
    staging = Path(tempfile.mkdtemp(prefix=temporary_prefix(target.name), suffix=".partial",
                                    dir=target.parent))
    try:
        with open_store(source) as reader:
            entries = _ReaderEntries(reader)
            views = reader.array("views")[:]
            failures = reader.failures()
            for archive in (zip_name, h5_name):
                write_dataset(staging / archive, entries, attrs=dict(reader.attrs), views=views,
                              failures=failures, progress=progress)
        archives = {archive: sha256_file(staging / archive) for archive in (zip_name, h5_name)}
        sizes = {archive: (staging / archive).stat().st_size for archive in archives}
        with open_store(staging / zip_name) as packed:
            info = info_from_reader(packed)
            card = render_card(packed, archives, license=license, file_sizes=sizes)
            (staging / CARD_NAME).write_text(card, encoding="utf-8", newline="\n")
            described = dict(archives)
            described[CARD_NAME] = sha256_file(staging / CARD_NAME)
            sizes[CARD_NAME] = (staging / CARD_NAME).stat().st_size
            croissant = croissant_jsonld(packed, described, license=license,
                                         file_sizes=sizes)
        _write_json(staging / CROISSANT_NAME, croissant)
        _write_json(staging / INFO_NAME, info)
        files = write_sha256sums(staging)
        _check_release_dir(target)
        _publish(staging, target)
        remove_stale_partials(target.parent, target.name)  # left by a killed earlier pack
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return ReleaseResult(
        path=target,
        name=base,
        zarr_zip=target / zip_name,
        hdf5=target / h5_name,
        card=target / CARD_NAME,
        croissant=target / CROISSANT_NAME,
        manifest=target / MANIFEST_NAME,
        files=files,
        n_models=int(info["n_models"]),
        n_failures=int(info["n_failures"]),
    )
