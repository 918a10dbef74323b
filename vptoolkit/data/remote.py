"""Fetch a release that lives elsewhere into a local cache, verified, to read it locally.

A release is addressed by the URL of its folder (or of one archive in it):
``http://`` and ``https://`` with the standard library alone, every other
scheme fsspec knows (``hf://datasets/<user>/<repo>``, ``s3://bucket/release``
...) with the ``remote`` extra. Each file is transferred by
:mod:`vptoolkit.data.download` (bounded, retried, resumed with Range
requests, moved into place only when its SHA-256 matches); this module decides
which files, where they go and whether the cached ones still hold.

:func:`fetch_release` reads the release's ``SHA256SUMS`` first; the SHA-256
of that file names the cache folder, ``<cache_dir>/releases/<sha256>/``, so a
release whose content changed is a new folder and is fetched again, and an
unchanged one is read from the cache with one small request. The cache never
holds a half-written or unverified file under a file's own name. When
``SHA256SUMS`` cannot be fetched because no server answers (not an HTTP error
status) and the cache holds a complete copy of what the URL last served,
verified (every file read has its stamp), that copy is used and ``offline:
using the cached copy of <url>`` is logged as a warning, once per process; the
URL's last release folder is recorded in ``<cache_dir>/urls/<SHA-256 of the
URL>.json``.

Each cached file is stamped (size, modification and change time, in
``<cache_dir>/releases/<sha256>.stamps.json``); a file whose stamp no longer
matches is hashed again on the next open, and fetched again if its bytes
changed.

By default only what reading needs is fetched: ``croissant.json`` (which
records the size of every file), the terms of use (the card ``README.md`` and
``LICENSES.csv``) and one archive, the one this install reads
(:func:`~vptoolkit.dataset.store.containers.archive_preference`); other names the
manifest lists are not downloaded. ``everything=True`` fetches every file
(what ``vptool verify`` checks). :func:`locate_release` fetches the same but
leaves an HDF5 archive that is not cached on an http(s) server that serves
byte ranges, to be read by ranges (:mod:`vptoolkit.data.ranges`): its bytes
are then checked against the size ``croissant.json`` records, not against its
SHA-256, which covers the whole file only.

Every fetch is bounded. The manifest may hold :data:`MAX_MANIFEST_BYTES`; a
file may hold the ``contentSize`` that ``croissant.json`` records for it, else
:data:`MAX_DESCRIPTION_BYTES` (text and JSON) or :data:`MAX_FILE_BYTES`
(archives and shards); the rate and time bounds of one transfer are
:mod:`vptoolkit.data.download`'s. Each limit exceeded and every transport
error is one :class:`~vptoolkit.errors.InputError` line naming the URL.

Examples
--------
>>> from vptoolkit.data import open_dataset
>>> dataset = open_dataset("https://example.org/releases/viewpoints/")  # doctest: +SKIP
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import re
import sys
import urllib.parse
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import NamedTuple

from vptoolkit.data.download import (
    HttpSource,
    RangesRefused,
    Source,
    Unreachable,
    download_file,
    fetch_range,
    receive,
    retrying,
    source_of,
)
from vptoolkit.data.ranges import RemoteArchive
from vptoolkit.dataset.release.descriptions import CROISSANT_NAME
from vptoolkit.dataset.release.licenses import LICENSES_NAME
from vptoolkit.dataset.release.manifest import (
    CARD_NAME,
    MANIFEST_NAME,
    parse_content_size,
    parse_sha256sums,
)
from vptoolkit.dataset.store.containers import archive_preference, store_kind
from vptoolkit.errors import InputError, VerificationError
from vptoolkit.files import (
    parse_json,
    read_json_file,
    sha256_file,
    write_bytes_atomic,
    write_json_atomic,
    write_text_atomic,
)

__all__ = [
    "MAX_DESCRIPTION_BYTES",
    "MAX_FILE_BYTES",
    "MAX_MANIFEST_BYTES",
    "default_cache_dir",
    "fetch_release",
    "is_remote",
    "locate_release",
]

MAX_MANIFEST_BYTES = 16 << 20
"""Most bytes a release's ``SHA256SUMS`` may hold (16 MiB, about 200,000 lines)."""

MAX_DESCRIPTION_BYTES = 64 << 20
"""Most bytes of a text or JSON file whose size ``croissant.json`` does not record (64 MiB)."""

MAX_FILE_BYTES = 1 << 40
"""Most bytes of any one file: an archive or shard whose size is not recorded (1 TiB)."""

_SCHEME = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]*)://")
_DATA_SUFFIXES = (".zarr.zip", ".h5", ".hdf5", ".parquet")
_TERMS = (CARD_NAME, LICENSES_NAME)
_log = logging.getLogger(__name__)
_noted_offline: set[str] = set()  # URLs whose offline notice this process has shown


def is_remote(path: object) -> bool:
    """Whether ``path`` is a URL (``scheme://...``) rather than a local path.

    Only a ``str`` can be one; a :class:`~pathlib.Path` is always local.
    """
    return isinstance(path, str) and _SCHEME.match(path) is not None


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/vptoolkit``, else ``~/.cache/vptoolkit``."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "vptoolkit"


def _check_paths(sums: Iterable[str], label: str) -> None:
    """Refuse manifest paths that cannot each be one file of the cache folder.

    A ``.`` or empty part (``.``, ``a//b``, ``a/``) names no file, and a path
    below a listed file (``README.md`` and ``README.md/x``) would need it to
    be a folder as well.
    """
    listed = set(sums)
    for relative in listed:
        parts = relative.split("/")
        if any(part in ("", ".") for part in parts):
            raise VerificationError(f"{label}: lists {relative!r}, which is not the path of a file")
        for end in range(1, len(parts)):
            if "/".join(parts[:end]) in listed:
                raise VerificationError(f"{label}: lists {'/'.join(parts[:end])} both as a file "
                                        f"and as the folder of {relative}")


def _needed(sums: Iterable[str], archive: str | None, url: str) -> list[str]:
    """What reading needs: croissant.json, the terms of use and one archive, in that order."""
    listed = sorted(sums)
    top = [name for name in listed if "/" not in name]
    archives = [name for name in top if name.lower().endswith((".zarr.zip", ".h5", ".hdf5"))]
    chosen = archive
    if chosen is None:
        for suffixes in archive_preference():
            found = [name for name in archives if name.lower().endswith(suffixes)]
            if len(found) > 1:
                raise InputError(f"{url}: holds {len(found)} stores ({', '.join(found)}); "
                                 "name one of them in the URL")
            if found:
                chosen = found[0]
                break
    if chosen is None:
        if any(name.endswith(".parquet") for name in listed):
            raise InputError(
                f"{url}: a Parquet-only release, which vptool reads only as a *.zarr.zip or "
                "*.h5 archive; load it with datasets (datasets.load_dataset) or pyarrow"
            )
        raise InputError(f"{url}: SHA256SUMS lists no *.zarr.zip or *.h5 store")
    if chosen not in sums:
        raise InputError(f"{url}: {chosen} is not listed in the release's SHA256SUMS")
    return [name for name in (CROISSANT_NAME, *_TERMS) if name in top] + [chosen]


def _limit(relative: str, sizes: Mapping[str, int]) -> tuple[int, str]:
    """The most bytes ``relative`` may hold, and where that bound comes from."""
    if relative in sizes:
        return min(sizes[relative], MAX_FILE_BYTES), f"its contentSize in {CROISSANT_NAME}"
    if relative.lower().endswith(_DATA_SUFFIXES):
        return MAX_FILE_BYTES, "the most one file may hold (MAX_FILE_BYTES)"
    return MAX_DESCRIPTION_BYTES, "the most a description file may hold (MAX_DESCRIPTION_BYTES)"


def _recorded_sizes(croissant: Path) -> dict[str, int]:
    """File name -> ``contentSize`` in bytes, as a cached ``croissant.json`` records them.

    Empty when the file is absent or unreadable: then the fixed limits apply.
    """
    if not croissant.is_file():
        return {}
    try:
        document = parse_json(croissant.read_bytes(), CROISSANT_NAME)
    except (InputError, OSError):
        return {}
    distribution = document.get("distribution") if isinstance(document, dict) else None
    sizes: dict[str, int] = {}
    for entry in distribution if isinstance(distribution, list) else ():
        if not isinstance(entry, dict):
            continue
        name, size = entry.get("contentUrl"), parse_content_size(entry.get("contentSize"))
        if isinstance(name, str) and size is not None:
            sizes[name] = size
    return sizes


def _stamp(path: Path) -> list[int]:
    """Size, modification and change time of a file (ns): any write changes one of them."""
    status = path.stat()
    return [status.st_size, status.st_mtime_ns, status.st_ctime_ns]


def _read_stamps(path: Path) -> dict[str, object]:
    """The stamps of a release's cached files; empty when absent or unreadable (all are hashed)."""
    if not path.is_file():
        return {}
    try:
        stamps = read_json_file(path)
    except InputError:
        return {}
    return stamps if isinstance(stamps, dict) else {}


def _is_cached(target: Path, expected: str, stamps: dict[str, object], relative: str) -> bool:
    """Whether ``target`` holds the verified file: its stamp matches, or its SHA-256 does.

    A file hashed again gets a new stamp; one whose bytes differ from the
    manifest is reported and left to be fetched again.
    """
    if not target.is_file():
        return False
    if stamps.get(relative) == _stamp(target):
        return True
    if sha256_file(target) == expected:
        stamps[relative] = _stamp(target)
        return True
    _log.warning("%s: cached copy differs from SHA256SUMS; fetching it again", target)
    return False


def _wanted(sums: Mapping[str, str], archive: str | None, base: str,
            everything: bool) -> list[str]:
    """The files a fetch reads: every listed one, croissant.json first, or :func:`_needed`."""
    if everything:  # croissant.json first: it records the sizes of the others
        return sorted(sorted(sums), key=lambda name: name != CROISSANT_NAME)
    return _needed(sums, archive, base)


def _pointer(cache: Path, base: str) -> Path:
    """Where the cache records which release folder ``base`` last served."""
    return cache / "urls" / f"{hashlib.sha256(base.encode('utf-8')).hexdigest()}.json"


class _CachedRelease(NamedTuple):
    """The release folder last fetched from a URL, and the files a fetch would read of it."""

    folder: Path
    sums: dict[str, str]
    wanted: list[str]

    @property
    def stamps_path(self) -> Path:
        return self.folder.parent / f"{self.folder.name}.stamps.json"

    def is_stamped(self) -> bool:
        """Whether every wanted file is there with the stamp it got when verified (no hashing)."""
        stamps = _read_stamps(self.stamps_path)
        return all((self.folder / relative).is_file()
                   and stamps.get(relative) == _stamp(self.folder / relative)
                   for relative in self.wanted)

    def problem(self) -> str | None:
        """None when the copy is complete and verified, else what is wrong with it.

        A file whose stamp changed (a copied cache has new change times) is
        hashed again and, if it matches ``SHA256SUMS``, stamped anew.
        """
        stamps = _read_stamps(self.stamps_path)
        before = dict(stamps)
        missing = [relative for relative in self.wanted if not (self.folder / relative).is_file()]
        if missing:
            return (f"is incomplete (no {', '.join(missing[:3])}; an archive read by byte "
                    "ranges is not cached)")
        changed = [relative for relative in self.wanted
                   if not _is_cached(self.folder / relative, self.sums[relative], stamps,
                                     relative)]
        if changed:
            return f"has changed ({', '.join(changed[:3])} differ from its SHA256SUMS)"
        if stamps != before:
            write_json_atomic(self.stamps_path, stamps, indent=None, newline=False)
        return None


def _cached_release(cache: Path, base: str, archive: str | None,
                    everything: bool) -> _CachedRelease | None:
    """The release folder last fetched from ``base``, if the cache records one.

    Its ``SHA256SUMS`` must hash to the folder's name; whether its files are
    complete and verified is :meth:`_CachedRelease.is_stamped` (cheap) or
    :meth:`_CachedRelease.problem` (hashes what changed).
    """
    pointer = _pointer(cache, base)
    if not pointer.is_file():
        return None
    try:
        record = read_json_file(pointer)
        name = record.get("release") if isinstance(record, dict) else None
        if not isinstance(name, str) or not re.fullmatch(r"[0-9a-f]{64}", name):
            return None
        folder = cache / "releases" / name
        listing = (folder / MANIFEST_NAME).read_bytes()
        if hashlib.sha256(listing).hexdigest() != name:
            return None
        sums = parse_sha256sums(listing, str(folder / MANIFEST_NAME))
        wanted = _wanted(sums, archive, base, everything)
    except (InputError, VerificationError, OSError):
        return None
    return _CachedRelease(folder, sums, wanted)


def fetch_release(url: str, *, cache_dir: str | os.PathLike[str] | None = None,
                  everything: bool = False, progress: bool | None = None) -> Path:
    """Download a release into the local cache, verified, and return the local path.

    Parameters
    ----------
    url : str
        URL of a release folder (``https://host/releases/viewpoints/``,
        ``hf://datasets/user/repo``), or of one ``*.zarr.zip`` / ``*.h5``
        archive in it (then that archive is fetched).
    cache_dir : path-like, optional
        Cache folder (default: :func:`default_cache_dir`). The release goes
        into ``<cache_dir>/releases/<SHA-256 of its SHA256SUMS>/``.
    everything : bool
        Fetch every file the manifest lists (default: ``croissant.json``,
        the card, ``LICENSES.csv`` and one archive, what
        :func:`vptoolkit.data.open_dataset` reads).
    progress : bool, optional
        Show a progress bar on stderr for each download of at least
        :data:`~vptoolkit.data.download.PROGRESS_MIN_BYTES` (default: when stderr is a
        terminal).

    Returns
    -------
    Path
        The cached release folder, or the cached archive when ``url`` names
        one. Files already cached are checked first (stamp, else SHA-256) and
        fetched again if they changed. When the server cannot be reached and
        the cache holds a complete, verified copy of what ``url`` last served,
        that copy, with the warning ``offline: using the cached copy of <url>``
        logged once per process.

    Raises
    ------
    InputError
        If ``SHA256SUMS`` or a file cannot be fetched (the line names the URL
        and the HTTP status or the reason: a download cut short, larger than
        its limit or slower than :data:`~vptoolkit.data.download.MIN_BYTES_PER_S`,
        a redirect to another scheme than http(s)), after
        :data:`~vptoolkit.data.download.TRIES` tries where trying again may
        help (no answer, a transfer broken off, HTTP 5xx), or the release
        holds no archive to read.
    VerificationError
        If the manifest is malformed (a line that is not ``<sha256>  <path>``,
        a path outside the folder, ``.``, or below another listed file) or a
        downloaded file differs from it; the file is not cached.
    MissingDependencyError
        For a scheme other than http(s) without fsspec (``pip install
        'vptoolkit[remote]'``) or fsspec's filesystem for that scheme.
    """
    return _fetch(url, cache_dir, everything=everything, progress=progress, by_ranges=False)[0]


def locate_release(url: str, *, cache_dir: str | os.PathLike[str] | None = None,
                   progress: bool | None = None) -> Path | RemoteArchive:
    """What reading a release needs, fetched as :func:`fetch_release` does, but its archive.

    An HDF5 archive that is not cached yet is left on the server to be read
    by byte ranges when the server is http(s), serves ranges (one request for
    the archive's first byte tells) and ``croissant.json`` records the
    archive's size; else it is downloaded and verified whole.

    Parameters
    ----------
    url, cache_dir, progress
        As for :func:`fetch_release`.

    Returns
    -------
    Path or RemoteArchive
        The cached release folder or archive, as :func:`fetch_release`
        returns it; or the archive to read by ranges, whose bytes are checked
        against its recorded size only (its SHA-256 covers the whole file).

    Raises
    ------
    InputError, VerificationError, MissingDependencyError
        As :func:`fetch_release`; an InputError too when the server answers
        the first Range request with another Content-Range or total size than
        ``croissant.json`` records.
    """
    path, ranged = _fetch(url, cache_dir, everything=False, progress=progress, by_ranges=True)
    return path if ranged is None else ranged


def _fetch(url: str, cache_dir: str | os.PathLike[str] | None, *, everything: bool,
           progress: bool | None, by_ranges: bool) -> tuple[Path, RemoteArchive | None]:
    """:func:`fetch_release`'s path; with ``by_ranges``, also the archive left to read by ranges.

    With ``by_ranges`` (never with ``everything``), the archive (the last file
    wanted) is not downloaded when :func:`_by_ranges` offers it to be read by
    ranges; the path returned then names its place in the cache, where it is not.
    """
    base, archive = url.rstrip("/"), None
    last = base.rsplit("/", 1)[-1]
    try:
        store_kind(last)
        base, archive = base.rsplit("/", 1)[0], urllib.parse.unquote(last)
    except InputError:
        if last == MANIFEST_NAME:
            base = base.rsplit("/", 1)[0]
    source = source_of(base)
    cache = Path(cache_dir if cache_dir is not None else default_cache_dir())
    cached = _cached_release(cache, base, archive, everything)
    try:  # one try only when a verified cached copy can stand in
        listing = retrying(lambda: b"".join(receive(
            source, MANIFEST_NAME, MAX_MANIFEST_BYTES,
            "the most a SHA256SUMS manifest may hold").blocks),
            tries=1 if cached is not None and cached.is_stamped() else None)
    except Unreachable as err:
        if cached is None:
            raise
        problem = cached.problem()
        if problem is not None:
            raise Unreachable(f"{err}; the cached copy in {cached.folder} {problem}") from err
        if base not in _noted_offline:
            _noted_offline.add(base)
            _log.warning("offline: using the cached copy of %s", base)
        return (cached.folder / archive if archive is not None else cached.folder), None
    sums = parse_sha256sums(listing, source.url_of(MANIFEST_NAME))
    _check_paths(sums, source.url_of(MANIFEST_NAME))
    releases = cache / "releases"
    folder = releases / hashlib.sha256(listing).hexdigest()
    wanted = _wanted(sums, archive, base, everything)
    folder.mkdir(parents=True, exist_ok=True)
    stamps_path = releases / f"{folder.name}.stamps.json"
    stamps = _read_stamps(stamps_path)
    before = dict(stamps)
    sizes: dict[str, int] = {}
    show = sys.stderr.isatty() if progress is None else progress
    ranged: RemoteArchive | None = None
    for relative in wanted:
        target = folder / relative
        if not _is_cached(target, sums[relative], stamps, relative):
            if by_ranges and relative == wanted[-1]:
                ranged = _by_ranges(source, relative, sizes, target)
            if ranged is None:
                limit, why = _limit(relative, sizes)
                download_file(source, relative, target, sha256=sums[relative], limit=limit,
                              why=why, recorded_size=sizes.get(relative), show=show)
                stamps[relative] = _stamp(target)
        if relative == CROISSANT_NAME:
            sizes = _recorded_sizes(target)
    if stamps != before:
        write_json_atomic(stamps_path, stamps, indent=None, newline=False)
    manifest = folder / MANIFEST_NAME
    if not manifest.is_file() or manifest.read_bytes() != listing:
        write_bytes_atomic(manifest, listing)
    pointer = _pointer(cache, base)
    record = json.dumps({"release": folder.name, "url": base}, sort_keys=True)
    if not pointer.is_file() or pointer.read_text(encoding="utf-8") != record:
        pointer.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(pointer, record)
    return (folder / archive if archive is not None else folder), ranged


def _by_ranges(source: Source, relative: str, sizes: Mapping[str, int],
               target: Path) -> RemoteArchive | None:
    """The archive ``relative`` to read by ranges, or None to download it whole.

    Whole when it is not HDF5, not served over http(s), ``croissant.json``
    records no size for it (or more than :data:`MAX_FILE_BYTES`), or the
    server sends the whole file for a request of its first byte.
    """
    size = sizes.get(relative, 0)
    if (not isinstance(source, HttpSource) or store_kind(relative) != "hdf5"
            or not 0 < size <= MAX_FILE_BYTES):
        return None
    try:
        fetch_range(source, relative, 0, 1, size)
    except RangesRefused as err:
        _log.info("%s; downloading it whole", err)
        return None
    return RemoteArchive(source.base, relative, size, target)
