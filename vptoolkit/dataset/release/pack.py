"""Pack a built dataset into a release folder.

A release folder holds, for ``name = "vptoolkit-viewpoints"``::

    data/<split>-00000-of-00012.parquet    one row per model, shards of a split (format parquet)
    views/views-00000-of-00001.parquet     the shared view directions    (format parquet)
    vptoolkit-viewpoints.h5                HDF5 file, the same models    (format hdf5)
    vptoolkit-viewpoints.zarr.zip          Zarr v3 zip store, the same   (format zarr)
    README.md                       dataset card (hub YAML header + datasheet)
    croissant.json                  Croissant 1.1 JSON-LD, record sets over the Parquet shards
    dataset_info.json               :func:`~vptoolkit.dataset.store.info.dataset_info` as JSON
    SCHEMA.md                       the layout of the archives
    LICENSES.csv                    per-mesh licence and attribution (with ``licenses``)
    SHA256SUMS                      ``sha256sum`` manifest of every other file

The file names hold no version (it is in the card, ``croissant.json``,
``dataset_info.json`` and the archives' attributes), so a loader's paths
stay valid from one release to the next. The default formats are
:data:`~vptoolkit.dataset.release.options.DEFAULT_FORMATS`, Parquet and
HDF5: Parquet for the hub, ``datasets`` and ``mlcroissant``, one archive
for :mod:`vptoolkit.data` and ``h5py`` on the light install; a Zarr zip
would be a third full copy of the data.

Packing is reproducible: the same build, options and ``created`` time give
the same bytes in every file, so a third party can rebuild a release and
compare its ``SHA256SUMS``.

:func:`pack_release` writes all of it into a hidden temporary sibling folder
and renames that into place at the end, so the release folder either does not
exist, stays empty, or is complete. :func:`~vptoolkit.dataset.release.manifest.verify`
checks a release; :func:`~vptoolkit.dataset.store.info.dataset_info` and
:func:`~vptoolkit.dataset.store.info.format_info` describe one. Packing writes
``LICENSES.csv`` through :mod:`vptoolkit.dataset.release.licenses` and the card and
``croissant.json`` through :mod:`vptoolkit.dataset.release.descriptions`, which also
holds :func:`~vptoolkit.dataset.release.descriptions.update_card`.

Size
    About 460 lines for one concept, the packing transaction: checking the
    source and the folder before anything is written, the staging folder and
    its lock, each format's writer call and the final rename (the options are
    checked when made, in :mod:`vptoolkit.dataset.release.options`). The writers themselves live
    in their own modules; what is left here shares the staging folder and
    its cleanup, which a split would have to pass around.
"""

from __future__ import annotations

import dataclasses
import errno
import importlib.resources
import os
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vptoolkit.checks import short_repr
from vptoolkit.conventions import DATASET_VERSION, SPLITS
from vptoolkit.dataset.release.card import render_card
from vptoolkit.dataset.release.contents import ReleaseFiles
from vptoolkit.dataset.release.descriptions import (
    CROISSANT_NAME,
    INFO_NAME,
    write_descriptions,
    write_json,
)
from vptoolkit.dataset.release.licenses import LICENSES_NAME, check_release_license, write_licenses
from vptoolkit.dataset.release.manifest import (
    CARD_NAME,
    MANIFEST_NAME,
    verify,
    write_sha256sums,
)
from vptoolkit.dataset.release.options import ReleaseOptions, release_created
from vptoolkit.dataset.store.entries import LazyEntries
from vptoolkit.dataset.store.info import info_from_reader
from vptoolkit.dataset.store.schema import (
    ModelEntry,
    published_split,
    registered_measures,
)
from vptoolkit.errors import InputError, VerificationError
from vptoolkit.files import (
    errors_named,
    held,
    named_os_error,
    remove_stale_partials,
    sha256_file,
    temporary_prefix,
)

if TYPE_CHECKING:
    from vptoolkit.dataset.release.parquet import ParquetShard
    from vptoolkit.dataset.store.reader import StoreReader

__all__ = [
    "ReleaseResult",
    "pack_release",
]

SCHEMA_NAME = "SCHEMA.md"


@dataclass(frozen=True)
class ReleaseResult:
    """What :func:`pack_release` wrote.

    Attributes
    ----------
    path : Path
        The release folder.
    name : str
        Base name of the archives.
    zarr_zip : Path or None
        The Zarr v3 zip store, ``<path>/<name>.zarr.zip`` (None without the
        ``zarr`` format).
    hdf5 : Path or None
        The HDF5 file, ``<path>/<name>.h5`` (None without ``hdf5``).
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
    version : str
        The dataset version.
    created : str
        The release time written everywhere, ISO 8601 UTC.
    parquet : tuple of Path
        The Parquet shards (empty without the ``parquet`` format).
    warnings : tuple of str
        One line per thing a publisher should know (an empty split, models
        without a licence).
    """

    path: Path
    name: str
    zarr_zip: Path | None
    hdf5: Path | None
    card: Path
    croissant: Path
    manifest: Path
    files: dict[str, str]
    n_models: int
    n_failures: int
    version: str = DATASET_VERSION
    created: str = ""
    parquet: tuple[Path, ...] = ()
    warnings: tuple[str, ...] = ()

    @property
    def total_bytes(self) -> int:
        """Size of every file of the release, manifest included."""
        return sum((self.path / name).stat().st_size for name in [*self.files, MANIFEST_NAME])


@dataclass(frozen=True, eq=False)
class _ReleaseEntry(ModelEntry):
    """A model as it goes into a release: its record also carries its provenance."""

    provenance: dict[str, str] | None = None

    def record(self) -> dict[str, Any]:
        """The model's record, with ``provenance`` (licence, author, url) when known."""
        record = super().record()
        if self.provenance is not None:
            record["provenance"] = dict(self.provenance)
        return record


def _release_entries(reader: StoreReader,
                     provenance: Mapping[str, dict[str, str]] | None = None,
                     default_license: str | None = None) -> LazyEntries:
    """The models of an open store as they go into a release, read on access.

    Splits come out under their published names, and a model named in
    ``provenance`` gets its licence, author and url; any other model without
    stored provenance gets ``{"license": default_license}`` when that is given.
    """
    records = reader.models()
    known = provenance or {}
    default = {"license": default_license} if default_license else None

    def release_entry(row: int) -> ModelEntry:
        entry = reader.entry(row)
        fields = {f.name: getattr(entry, f.name) for f in dataclasses.fields(entry)}
        fields["split"] = published_split(entry.split)
        fields["provenance"] = (known.get(entry.name) or records[row].get("provenance")
                                or default)
        return _ReleaseEntry(**fields)

    return LazyEntries(len(records), release_entry)




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


def _check_still_empty(release_dir: Path) -> None:
    """The check of :func:`_check_release_dir` again, once everything is written."""
    if release_dir.is_dir() and not release_dir.is_symlink() and any(release_dir.iterdir()):
        raise InputError(f"{release_dir}: folder was filled while packing; release left untouched")
    _check_release_dir(release_dir)


_MAX_NAME_BYTES = 255  # a file name on ext4, XFS, APFS, NTFS


def _name_bytes(name: str) -> int:
    return len(name.encode("utf-8", "surrogateescape"))


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


def _require_formats(formats: Sequence[str]) -> None:
    """Fail before any work when a chosen format's library is missing."""
    from vptoolkit.dataset.store.containers import require_zarr
    from vptoolkit.optional import require

    if "zarr" in formats:
        require_zarr()
    if "parquet" in formats:
        require("pyarrow", extra="dataset")


def _copy_schema(target: Path) -> None:
    resource = importlib.resources.files("vptoolkit.dataset_card").joinpath(SCHEMA_NAME)
    target.write_text(resource.read_text(encoding="utf-8"), encoding="utf-8", newline="\n")


_NO_LICENCE = ("no licence given for the source meshes (--license ID for all of them, or "
               "--licenses FILE.csv per model): the card tells users to check them before "
               "redistributing")


def _release_warnings(records: Sequence[Mapping[str, Any]], has_licenses: bool) -> list[str]:
    found = []
    counts = {split: 0 for split in SPLITS}
    for record in records:
        counts[published_split(str(record["split"]))] = counts.get(
            published_split(str(record["split"])), 0) + 1
    for split, count in counts.items():
        if count == 0:
            found.append(f"split {split!r} is empty: no model will be "
                         f"{'tested' if split == 'test' else 'used'} from it")
    if has_licenses:
        unlicensed = [r["name"] for r in records if not r.get("provenance")]
        if unlicensed:
            shown = ", ".join(unlicensed[:5]) + (" ..." if len(unlicensed) > 5 else "")
            found.append(f"{len(unlicensed)} model(s) have no row in the licence table: {shown}")
    return found


def pack_release(
    dataset: Path | str,
    release_dir: Path | str,
    options: ReleaseOptions | None = None,
    *,
    progress: bool = False,
) -> ReleaseResult:
    """Pack a built dataset into a release folder.

    The models are copied entry by entry (never all in memory) into the
    chosen containers (Parquet shards of bounded size per split, an HDF5
    file, a Zarr v3 zip store), then the dataset card, Croissant metadata, a JSON summary,
    ``SCHEMA.md`` and the ``SHA256SUMS`` manifest are written. Everything
    goes into a hidden temporary sibling of ``release_dir`` that is renamed
    into place at the end; on any error it is removed and ``release_dir`` is
    left as it was.

    Parameters
    ----------
    dataset : Path or str
        A built dataset: a store or any folder
        :func:`vptoolkit.dataset.store.containers.find_store` accepts.
    release_dir : Path or str
        Output folder; must not exist or be empty. Its parent folders are
        created.
    options : ReleaseOptions, optional
        Name, formats, version, release time, licences, card and Croissant
        fields and shard size (default: ``ReleaseOptions()``: Parquet and
        HDF5, version :data:`~vptoolkit.conventions.DATASET_VERSION`, no
        licence stated). Without ``created``, the release time is
        ``$SOURCE_DATE_EPOCH``, else the build's ``created``.
    progress : bool
        Show progress bars while the archives are written (default: False).

    Returns
    -------
    ReleaseResult
        ``warnings`` names an empty split, models without a licence, and a
        release given no licence at all (which only the card's licence note
        states, not its warning block).

    Raises
    ------
    InputError
        If ``release_dir`` exists and is not an empty folder,
        ``SOURCE_DATE_EPOCH`` is malformed, the licence table file is bad,
        ``dataset`` holds no readable store, or its store records a measure
        the registry does not know (the card needs its title and direction;
        the options themselves are checked when made).
    MissingDependencyError
        If a chosen format's library is missing (zarr >= 3, pyarrow: ``pip
        install 'vptoolkit[dataset]'``).
    VerificationError
        If an array of ``dataset`` differs from its stored SHA-256 (checked
        before anything is written).
    """
    from vptoolkit.dataset.store.containers import find_store
    from vptoolkit.dataset.store.reader import open_store
    from vptoolkit.dataset.store.writer import write_dataset

    if options is None:
        options = ReleaseOptions()
    elif not isinstance(options, ReleaseOptions):
        raise InputError(f"options: expected ReleaseOptions, got {type(options).__name__}")
    base, chosen = options.name, options.formats
    target = Path(release_dir)
    _check_release_dir(target)
    provenance = options.license_table()
    source = find_store(dataset)
    _require_formats(chosen)
    _check_source_intact(source)
    target.parent.mkdir(parents=True, exist_ok=True)

    archive_names = {"zarr": f"{base}.zarr.zip", "hdf5": f"{base}.h5"}
    written = [archive_names[f] for f in ("zarr", "hdf5") if f in chosen]
    # Without an archive, a hidden HDF5 copy serves the descriptions and is removed.
    described_name = written[0] if written else f".{base}.describe.h5"
    longest = max([*archive_names.values(), described_name], key=_name_bytes)
    if _name_bytes(longest) > _MAX_NAME_BYTES:
        raise InputError(
            f"{target}: file name {short_repr(longest)} is longer than {_MAX_NAME_BYTES} bytes; "
            "choose a shorter name"
        )
    try:
        staging = Path(tempfile.mkdtemp(prefix=temporary_prefix(target.name), suffix=".partial",
                                        dir=target.parent))
    except OSError as err:  # a read-only or full parent folder: name the release
        raise named_os_error(err, target) from err
    try:
        # a full disk or a file too large names the release, not the hidden folder;
        # a concurrent pack's cleanup leaves the held staging folder alone
        with errors_named(staging, target), held(staging):
            with open_store(source) as reader:
                # the card names each measure and which way it is better: the registry's
                registered_measures(reader.measures, reader.path.name)
                attrs = dict(reader.attrs)
                check_release_license(options.license, attrs, reader.models(), provenance,
                                      force=options.force_license, where=str(source))
                when = release_created(options.created, attrs.get("created"))
                attrs["created"] = when
                attrs["dataset_version"] = options.version
                options = dataclasses.replace(options, created=when)
                entries = _release_entries(reader, provenance, options.default_license)
                views = reader.array("views")[:]
                failures = reader.failures()
                for archive in dict.fromkeys([*written, described_name]):
                    write_dataset(staging / archive, entries, attrs=attrs, views=views,
                                  failures=failures, progress=progress)
            digests = {archive: sha256_file(staging / archive) for archive in written}
            shards: list[ParquetShard] = []
            with open_store(staging / described_name) as packed:
                records = packed.models()
                if "parquet" in chosen:
                    from vptoolkit.dataset.release.parquet import write_parquet_shards

                    shards = write_parquet_shards(packed, staging,
                                                  shard_bytes=options.shard_bytes)
                    digests.update({s.path: sha256_file(staging / s.path) for s in shards})
                found = _release_warnings(records, provenance is not None)
                unlicensed = not any(record.get("provenance") for record in records)
                if provenance is not None:
                    write_licenses(staging / LICENSES_NAME, records)
                _copy_schema(staging / SCHEMA_NAME)
                for extra in (LICENSES_NAME, SCHEMA_NAME):
                    if (staging / extra).exists():
                        digests[extra] = sha256_file(staging / extra)
                release_files = ReleaseFiles(
                    digests, {file: (staging / file).stat().st_size for file in digests}, shards)
                card = render_card(packed, release_files, options, warnings=found)
                (staging / CARD_NAME).write_text(card, encoding="utf-8", newline="\n")
                digests[CARD_NAME] = write_descriptions(staging, packed, release_files, options)
                info = info_from_reader(packed)
            if described_name not in written:
                (staging / described_name).unlink()
            write_json(staging / INFO_NAME, info)
            files = write_sha256sums(staging, known=digests)  # each file hashed once
            _check_still_empty(target)
            _publish(staging, target)
            remove_stale_partials(target.parent, target.name)  # left by a killed earlier pack
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return ReleaseResult(
        path=target,
        name=base,
        zarr_zip=target / archive_names["zarr"] if "zarr" in chosen else None,
        hdf5=target / archive_names["hdf5"] if "hdf5" in chosen else None,
        card=target / CARD_NAME,
        croissant=target / CROISSANT_NAME,
        manifest=target / MANIFEST_NAME,
        files=files,
        n_models=int(info["n_models"]),
        n_failures=int(info["n_failures"]),
        version=options.version,
        created=when,
        parquet=tuple(target / s.path for s in shards),
        warnings=tuple(found) + ((_NO_LICENCE,) if unlicensed else ()),
    )
