"""What a publisher says about a release, as one value: :class:`ReleaseOptions`.

:func:`~vptoolkit.dataset.release.pack.pack_release` takes a
:class:`ReleaseOptions`: the archives' base name, the formats, the version,
the release time, the licence (one for the release and a per-mesh table),
the card's and Croissant's names and links, the Parquet shard size, and
whether a licence that contradicts the sources' own terms is forced. It
is checked once, when it is made, so a bad option is refused before a store
is opened; the defaults are the named constants below.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Final

from vptoolkit.checks import check_bool, short_repr
from vptoolkit.conventions import DATASET_VERSION
from vptoolkit.dataset.release.licenses import check_license, check_licenses, read_licenses
from vptoolkit.dataset.release.parquet import DEFAULT_SHARD_BYTES, parse_size
from vptoolkit.errors import InputError

__all__ = [
    "DEFAULT_FORMATS",
    "DEFAULT_LICENSE",
    "DEFAULT_NAME",
    "FORMATS",
    "ReleaseOptions",
    "release_created",
]

DEFAULT_NAME: Final = "vptoolkit-viewpoints"
"""Base name of the archives when a release is given no ``name``."""

FORMATS: Final = ("parquet", "zarr", "hdf5")
"""Containers a release can hold."""

DEFAULT_FORMATS: Final = ("parquet", "hdf5")
"""What a release holds by default: the Parquet shards and one archive, HDF5,
which the light install (numpy, h5py) reads; each format is a full copy of the data."""

DEFAULT_LICENSE: Final = "other"
"""The licence of a release given none: it states none, the source meshes' licences apply."""

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
_VERSION = re.compile(r"(0|[1-9][0-9]*)\.(0|[1-9][0-9]*)\.(0|[1-9][0-9]*)")
# ASCII digits: str.isdigit also passes "²", which int() refuses
_EPOCH_SECONDS = re.compile(r"[0-9]+")


@dataclass(frozen=True)
class ReleaseOptions:
    """What a publisher says about a release; checked when made.

    Attributes
    ----------
    name : str
        Base name of the archives, ``<name>.h5`` and ``<name>.zarr.zip``
        (default: :data:`DEFAULT_NAME`): a letter or digit, then letters,
        digits, ``.``, ``_`` and ``-``.
    license : str
        Licence of the release: an SPDX identifier or expression
        (``CC-BY-4.0`` in any case, ``MIT OR Apache-2.0``) or the URL of the
        licence, for the card and Croissant; it is also the licence of every
        source mesh the ``licenses`` table does not name. The default
        :data:`DEFAULT_LICENSE` (``"other"``) says nothing: the source
        meshes' licences apply. A licence that contradicts the terms the
        sources state (ModelNet, ShapeNet, the paper authors' data, a model's
        own licence) is refused when the release is packed
        (:func:`~vptoolkit.dataset.release.licenses.check_release_license`) unless
        ``force_license``.
    formats : tuple of str
        Containers to write, from :data:`FORMATS` (default:
        :data:`DEFAULT_FORMATS`, Parquet and HDF5); any sequence is kept as
        a tuple without repeats.
    version : str
        Dataset version ``MAJOR.MINOR.PATCH`` (default:
        :data:`~vptoolkit.conventions.DATASET_VERSION`), written into the
        attributes (``dataset_version``), card and Croissant; never into
        file names.
    created : str, optional
        Release time, ISO 8601, kept as UTC text (``2026-01-02T03:04:05Z``;
        a time without a zone is UTC). None: ``$SOURCE_DATE_EPOCH`` when the
        release is packed, else the build's ``created``
        (:func:`release_created`). The same build, options and ``created``
        give byte-identical files.
    pretty_name : str, optional
        Title of the card and Croissant name (default: from the source name).
    source_url : str, optional
        Where the source meshes come from.
    url : str, optional
        Where the release is published (Croissant ``url``).
    creator : str, optional
        Who made the release (Croissant ``creator``; default ``"vptoolkit"``).
    licenses : Path or mapping, optional
        A per-mesh licence table, a CSV file read when the release is packed
        (:func:`~vptoolkit.dataset.release.licenses.read_licenses`), or its parsed
        mapping (model name to ``license``, ``author``, ``url``), checked
        here as a file's rows are
        (:func:`~vptoolkit.dataset.release.licenses.check_licenses`); each
        model's record then carries ``provenance``, the card tables it and the
        release ships it as ``LICENSES.csv``.
    license_name, license_link : str, optional
        The hub's ``license_name`` / ``license_link``; with ``license="other"``
        the release says ``"source-mesh-licenses"`` and ``LICENSES.csv`` (with
        a table) or ``README.md`` unless they are given.
    shard_size : int or str
        Largest Arrow size of the rows of one Parquet shard, in bytes or as
        text (``"500MB"``, ``"200KB"``; see
        :func:`~vptoolkit.dataset.release.parquet.parse_size`); kept in bytes
        (default: :data:`~vptoolkit.dataset.release.parquet.DEFAULT_SHARD_BYTES`).
    force_license : bool
        Release under ``license`` even where it contradicts the sources'
        terms (default False); the card records that decision and what it
        contradicts.

    Raises
    ------
    InputError
        Naming the first invalid field.

    Examples
    --------
    >>> options = ReleaseOptions(formats=["hdf5", "parquet", "hdf5"], shard_size="200KB")
    >>> options.formats, options.shard_bytes, options.default_license
    (('hdf5', 'parquet'), 200000, None)
    """

    name: str = DEFAULT_NAME
    license: str = DEFAULT_LICENSE
    formats: Sequence[str] = DEFAULT_FORMATS
    version: str = DATASET_VERSION
    created: str | None = None
    pretty_name: str | None = None
    source_url: str | None = None
    url: str | None = None
    creator: str | None = None
    licenses: Path | str | Mapping[str, Mapping[str, str]] | None = None
    license_name: str | None = None
    license_link: str | None = None
    shard_size: int | str = DEFAULT_SHARD_BYTES
    force_license: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME.fullmatch(self.name):
            raise InputError(
                f"name: {short_repr(self.name)} must start with a letter or digit and hold only "
                "letters, digits, '.', '_' and '-'"
            )
        if not isinstance(self.version, str) or not _VERSION.fullmatch(self.version):
            raise InputError(f"version: {self.version!r} is not MAJOR.MINOR.PATCH (e.g. 1.0.0)")
        if not isinstance(self.license, str):
            raise InputError(f"license: expected text, got {short_repr(self.license)}")
        given = self.license.strip()
        other = given == DEFAULT_LICENSE
        for field_name in ("pretty_name", "source_url", "url", "creator", "license_name",
                           "license_link"):
            value = getattr(self, field_name)
            if value is not None and not isinstance(value, str):
                raise InputError(f"{field_name}: expected text, got {short_repr(value)}")
        values: dict[str, Any] = {
            "license": given if other else check_license(given, "license"),
            "formats": _formats(self.formats),
            "created": None if self.created is None else release_created(self.created, None),
            "licenses": _licenses(self.licenses),
            "shard_size": parse_size(self.shard_size, "shard_size"),
            "force_license": check_bool(self.force_license, "force_license"),
        }
        for field_name, value in values.items():  # frozen: checked values replace the given ones
            object.__setattr__(self, field_name, value)

    @property
    def shard_bytes(self) -> int:
        """``shard_size`` in bytes."""
        return int(self.shard_size)

    def license_table(self) -> dict[str, dict[str, str]] | None:
        """The per-mesh licence table: ``licenses`` read if it names a file, or as given.

        Raises
        ------
        InputError
            If the file cannot be read or holds a bad row
            (:func:`~vptoolkit.dataset.release.licenses.read_licenses`).
        """
        if self.licenses is None:
            return None
        if isinstance(self.licenses, (str, os.PathLike)):
            return read_licenses(self.licenses)
        return {model: dict(row) for model, row in self.licenses.items()}

    @property
    def default_license(self) -> str | None:
        """The licence of a source mesh the table does not name (None for ``"other"``)."""
        return None if self.license == DEFAULT_LICENSE else self.license


def _formats(formats: Any) -> tuple[str, ...]:
    if isinstance(formats, str) or not isinstance(formats, Sequence):
        raise InputError(f"formats: expected a sequence of format names, got {short_repr(formats)}")
    chosen = tuple(dict.fromkeys(formats))
    unknown = [f for f in chosen if f not in FORMATS]
    if unknown or not chosen:
        raise InputError(f"formats: expected one or more of {', '.join(FORMATS)}, got "
                         f"{', '.join(map(str, formats)) or 'none'}")
    return chosen


def _licenses(licenses: Any) -> Path | dict[str, dict[str, str]] | None:
    if licenses is None:
        return None
    if isinstance(licenses, (str, os.PathLike)):
        return Path(licenses)
    if not isinstance(licenses, Mapping):
        raise InputError(f"licenses: expected a CSV path or a mapping, got {short_repr(licenses)}")
    return check_licenses(licenses)


def release_created(created: str | None, default: str | None) -> str:
    """The release time to write, ISO 8601 UTC (``2026-01-02T03:04:05Z``).

    Parameters
    ----------
    created : str, optional
        An ISO 8601 time; one without a zone is taken as UTC.
    default : str, optional
        Used when ``created`` is None and ``SOURCE_DATE_EPOCH`` is unset
        (the build's own ``created`` attribute).

    Returns
    -------
    str
        ``created``, else ``$SOURCE_DATE_EPOCH`` (seconds since 1970, the
        reproducible-builds convention), else ``default``, else now.

    Raises
    ------
    InputError
        If ``created`` or ``SOURCE_DATE_EPOCH`` cannot be read.
    """
    if created is not None:
        if not isinstance(created, str):
            raise InputError(f"created: expected ISO 8601 text, got {short_repr(created)}")
        try:
            moment = datetime.fromisoformat(created.replace("Z", "+00:00"))
        except ValueError as err:
            raise InputError(f"created: {short_repr(created)} is not an ISO 8601 time") from err
        if moment.tzinfo is None:
            moment = moment.replace(tzinfo=timezone.utc)
        try:
            return _utc_text(moment.astimezone(timezone.utc))
        except OverflowError as err:
            raise InputError(
                f"created: {short_repr(created)} is outside the years 1 to 9999 in UTC"
            ) from err
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    if epoch:
        if not _EPOCH_SECONDS.fullmatch(epoch):
            raise InputError(
                f"SOURCE_DATE_EPOCH: {short_repr(epoch)} is not a whole number of seconds"
            )
        try:
            return _utc_text(datetime.fromtimestamp(int(epoch), timezone.utc))
        except (OverflowError, OSError, ValueError) as err:
            raise InputError(
                f"SOURCE_DATE_EPOCH: {short_repr(epoch)[1:-1]} seconds is beyond the year 9999"
            ) from err
    if default:
        return default
    return _utc_text(datetime.now(timezone.utc))


def _utc_text(moment: datetime) -> str:
    """``2026-01-02T03:04:05Z``, the year always four digits (``0999``, which strftime drops)."""
    return (f"{moment.year:04d}-{moment.month:02d}-{moment.day:02d}"
            f"T{moment.hour:02d}:{moment.minute:02d}:{moment.second:02d}Z")
