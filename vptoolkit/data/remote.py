"""Fetch a release that lives elsewhere into a local cache, verified, to read it locally.

A release is addressed by the URL of its folder (or of one archive in it):

- ``http://`` and ``https://``: the standard library alone (:mod:`urllib`);
  redirects are followed to http(s) URLs only;
- every other scheme fsspec knows (``hf://datasets/<user>/<repo>``,
  ``s3://bucket/release``, ``gs://``, ``file://`` ...) through fsspec,
  the ``remote`` extra (``pip install 'vptoolkit[remote]'``; ``hf://`` also
  needs ``huggingface_hub``, ``s3://`` ``s3fs``).

:func:`fetch_release` reads the release's ``SHA256SUMS`` first; the SHA-256
of that file names the cache folder, ``<cache_dir>/releases/<sha256>/``, so a
release whose content changed is a new folder and is fetched again, and an
unchanged one is read from the cache with one small request. Each file is
downloaded to a hidden temporary name beside its place, hashed while it
arrives, and renamed into place only when its SHA-256 matches the manifest:
the cache never holds a half-written or unverified file. The temporary file
of a download that was killed is removed by the next download of that file.
Each cached file is stamped (size, modification and change time, in
``<cache_dir>/releases/<sha256>.stamps.json``); a file whose stamp no longer
matches is hashed again on the next open, and fetched again if its bytes
changed.

By default only what reading needs is fetched: ``croissant.json`` (which
records the size of every file), the terms of use (the card ``README.md`` and
``LICENSES.csv``) and one archive, the one this install reads
(:func:`~vptoolkit.dataset.containers.archive_preference`); other names the
manifest lists are not downloaded. ``everything=True`` fetches every file
(what ``vptool verify`` checks).

Every fetch is bounded. The manifest may hold :data:`MAX_MANIFEST_BYTES`; a
file may hold the ``contentSize`` that ``croissant.json`` records for it, else
:data:`MAX_DESCRIPTION_BYTES` (text and JSON) or :data:`MAX_FILE_BYTES`
(archives and shards); a download must keep up :data:`MIN_BYTES_PER_S` on
average once :data:`GRACE_S` have passed, and a server silent for
:data:`READ_TIMEOUT_S` ends it. So a file takes at most ``GRACE_S + size /
MIN_BYTES_PER_S`` seconds, and a fetch the sum of that over its few files.
Each limit exceeded, a download cut short (fewer bytes than the announced
``Content-Length``) and every transport error is one
:class:`~vptoolkit.errors.InputError` line naming the URL.

Examples
--------
>>> from vptoolkit.data import open_dataset
>>> dataset = open_dataset("https://example.org/releases/viewpoints/")  # doctest: +SKIP
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
import re
import time
import urllib.parse
from collections.abc import Iterable, Iterator, Mapping
from contextlib import AbstractContextManager
from pathlib import Path
from typing import IO, TYPE_CHECKING, BinaryIO

from vptoolkit.checks import one_line
from vptoolkit.dataset.containers import archive_preference, store_kind
from vptoolkit.dataset.descriptions import CROISSANT_NAME
from vptoolkit.dataset.licenses import LICENSES_NAME
from vptoolkit.dataset.manifest import (
    BLOCK_SIZE,
    CARD_NAME,
    MANIFEST_NAME,
    parse_sha256sums,
    sha256_file,
)
from vptoolkit.errors import InputError, MissingDependencyError, VerificationError
from vptoolkit.files import (
    atomic_write,
    parse_json,
    read_json_file,
    remove_stale_partials,
    write_bytes_atomic,
    write_text_atomic,
)
from vptoolkit.optional import require

if TYPE_CHECKING:
    import http.client
    import urllib.request

__all__ = [
    "GRACE_S",
    "MAX_DESCRIPTION_BYTES",
    "MAX_FILE_BYTES",
    "MAX_MANIFEST_BYTES",
    "MIN_BYTES_PER_S",
    "READ_TIMEOUT_S",
    "REMOTE_EXTRA",
    "default_cache_dir",
    "fetch_release",
    "is_remote",
]

REMOTE_EXTRA = "remote"
"""The vptoolkit extra that installs fsspec, for schemes other than http(s)."""

MAX_MANIFEST_BYTES = 16 << 20
"""Most bytes a release's ``SHA256SUMS`` may hold (16 MiB, about 200,000 lines)."""

MAX_DESCRIPTION_BYTES = 64 << 20
"""Most bytes of a text or JSON file whose size ``croissant.json`` does not record (64 MiB)."""

MAX_FILE_BYTES = 1 << 40
"""Most bytes of any one file: an archive or shard whose size is not recorded (1 TiB)."""

MIN_BYTES_PER_S = 16 << 10
"""Average rate, in bytes per second, a download must keep up after :data:`GRACE_S` (16 KiB/s)."""

GRACE_S = 60.0
"""Seconds a download may take before :data:`MIN_BYTES_PER_S` applies."""

READ_TIMEOUT_S = 60.0
"""Seconds a server may stay silent (connecting or while sending) before a download ends."""

_SCHEME = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]*)://")
_CONTENT_SIZE = re.compile(r"(\d{1,19}) B")
_DATA_SUFFIXES = (".zarr.zip", ".h5", ".hdf5", ".parquet")
_TERMS = (CARD_NAME, LICENSES_NAME)
_USER_AGENT = "vptoolkit"
_log = logging.getLogger(__name__)


def is_remote(path: object) -> bool:
    """Whether ``path`` is a URL (``scheme://...``) rather than a local path.

    Only a ``str`` can be one; a :class:`~pathlib.Path` is always local.
    """
    return isinstance(path, str) and _SCHEME.match(path) is not None


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/vptoolkit``, else ``~/.cache/vptoolkit``."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "vptoolkit"


@functools.cache
def _http_opener() -> urllib.request.OpenerDirector:
    """urllib's opener, with redirects followed to http(s) URLs only (never ``ftp://``)."""
    import urllib.error  # with urllib.request: 10 ms that only a download needs
    import urllib.request

    class HttpOnlyRedirects(urllib.request.HTTPRedirectHandler):
        def redirect_request(self, req: urllib.request.Request, fp: IO[bytes], code: int,
                             msg: str, headers: http.client.HTTPMessage,
                             newurl: str) -> urllib.request.Request | None:
            if urllib.parse.urlsplit(newurl).scheme.lower() not in ("http", "https"):
                raise urllib.error.HTTPError(
                    newurl, code, f"{msg} - Redirection to url '{newurl}' is not allowed "
                    "(only http and https are followed)", headers, fp)
            return super().redirect_request(req, fp, code, msg, headers, newurl)

    return urllib.request.build_opener(HttpOnlyRedirects)


class _HttpSource:
    """A release folder served over http(s), read with urllib."""

    def __init__(self, url: str) -> None:
        self.base = url.rstrip("/")

    def url_of(self, relative: str) -> str:
        return f"{self.base}/{urllib.parse.quote(relative)}"

    def blocks(self, relative: str, limit: int, why: str) -> Iterator[bytes]:
        """The body of ``relative`` as it arrives, one socket read at a time.

        Refused at once when the server announces more than ``limit`` bytes;
        a body shorter than its ``Content-Length`` or a broken chunked body
        ends in an :class:`~vptoolkit.errors.InputError`.
        """
        import http.client
        import urllib.error
        import urllib.request

        url = self.url_of(relative)
        request = urllib.request.Request(url, headers={"User-Agent": _USER_AGENT})
        try:
            response = _http_opener().open(request, timeout=READ_TIMEOUT_S)
        except urllib.error.HTTPError as err:
            err.close()
            raise InputError(f"{url}: HTTP {err.code} {one_line(err.reason)}") from err
        except (urllib.error.URLError, OSError, http.client.HTTPException) as err:
            reason = getattr(err, "reason", err)
            raise InputError(f"{url}: cannot be fetched ({one_line(reason)})") from err
        with response:
            announced = response.length  # None without a Content-Length
            if announced is not None and announced > limit:
                raise _too_large(url, limit, why)
            received = 0
            while True:
                try:
                    block = response.read1(BLOCK_SIZE)
                except (OSError, http.client.HTTPException) as err:
                    raise InputError(f"{url}: download broke off ({one_line(err)})") from err
                if not block:
                    break
                received += len(block)
                yield block
            if announced is not None and received < announced:
                raise InputError(f"{url}: download broke off ({received} of the {announced} "
                                 "bytes announced)")


class _FsspecSource:
    """A release folder anywhere fsspec reaches (``hf://``, ``s3://``, ``file://`` ...)."""

    def __init__(self, url: str) -> None:
        fsspec = require("fsspec", extra=REMOTE_EXTRA)
        self.base = url.rstrip("/")
        try:
            self._fs, self._root = fsspec.core.url_to_fs(self.base)
        except ImportError as err:
            raise MissingDependencyError(f"{url}: {err}") from err
        except ValueError as err:
            raise InputError(f"{url}: {err}") from err
        self._root = self._root.rstrip("/")

    def url_of(self, relative: str) -> str:
        return f"{self.base}/{relative}"

    def blocks(self, relative: str, limit: int, why: str) -> Iterator[bytes]:
        """The content of ``relative`` in blocks of :data:`BLOCK_SIZE` bytes.

        Refused at once when the file system reports more than ``limit`` bytes.
        """
        with self._open(relative) as stream:
            size = getattr(stream, "size", None)  # fsspec's buffered files know it
            if isinstance(size, int) and size > limit:
                raise _too_large(self.url_of(relative), limit, why)
            while True:
                try:
                    block = stream.read(BLOCK_SIZE)
                except OSError as err:
                    raise InputError(
                        f"{self.url_of(relative)}: download broke off ({one_line(err)})") from err
                if not block:
                    return
                yield block

    def _open(self, relative: str) -> AbstractContextManager[IO[bytes]]:
        try:
            return self._fs.open(f"{self._root}/{relative}", "rb")
        except FileNotFoundError as err:
            raise InputError(f"{self.url_of(relative)}: not found") from err
        except OSError as err:
            raise InputError(f"{self.url_of(relative)}: cannot be fetched ({err})") from err


def _source(url: str) -> _HttpSource | _FsspecSource:
    scheme = url.split("://", 1)[0].lower()
    return _HttpSource(url) if scheme in ("http", "https") else _FsspecSource(url)


def _too_large(url: str, limit: int, why: str) -> InputError:
    return InputError(f"{url}: more than {limit} bytes, {why}; download refused, nothing cached")


def _receive(source: _HttpSource | _FsspecSource, relative: str, limit: int,
             why: str) -> Iterator[bytes]:
    """The bytes of one file as they arrive, refused past ``limit`` bytes or below the minimum rate.

    ``why`` says where ``limit`` comes from, in the message.
    """
    url = source.url_of(relative)
    start = time.monotonic()
    received = 0
    for block in source.blocks(relative, limit, why):
        received += len(block)
        if received > limit:
            raise _too_large(url, limit, why)
        elapsed = time.monotonic() - start
        if elapsed > GRACE_S and received < (elapsed - GRACE_S) * MIN_BYTES_PER_S:
            raise InputError(
                f"{url}: too slow ({received} bytes in {elapsed:.0f} s, below "
                f"{MIN_BYTES_PER_S} bytes/s after the first {GRACE_S:g} s); download refused"
            )
        yield block


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
        name, size = entry.get("contentUrl"), entry.get("contentSize")
        match = _CONTENT_SIZE.fullmatch(size) if isinstance(size, str) else None
        if isinstance(name, str) and match is not None:
            sizes[name] = int(match[1])
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


def _hold(stream: BinaryIO) -> None:
    """Lock a download's temporary file while it is written.

    :func:`~vptoolkit.files.remove_stale_partials` skips a locked file, so a
    concurrent download of the same file, in another process, keeps its own.
    """
    try:
        import fcntl
    except ImportError:  # Windows: an open file cannot be removed anyway
        return
    try:
        fcntl.flock(stream.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:  # a file system without locks: nothing is held, as in files.held
        return


def _download(source: _HttpSource | _FsspecSource, relative: str, expected: str,
              target: Path, sizes: Mapping[str, int]) -> None:
    """Fetch one file to ``target`` through a hidden temporary sibling, kept only if it matches.

    The temporary files that killed downloads of ``target`` left are removed first.
    """
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_partials(target.parent, target.name)
    url = source.url_of(relative)
    limit, why = _limit(relative, sizes)
    digest = hashlib.sha256()
    with atomic_write(target) as out:
        _hold(out)
        for block in _receive(source, relative, limit, why):
            digest.update(block)
            out.write(block)
        if digest.hexdigest() != expected:
            raise VerificationError(
                f"{url}: SHA-256 {digest.hexdigest()[:12]}... differs from SHA256SUMS "
                f"({expected[:12]}...); download refused, nothing cached"
            )


def fetch_release(url: str, *, cache_dir: str | os.PathLike[str] | None = None,
                  everything: bool = False) -> Path:
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

    Returns
    -------
    Path
        The cached release folder, or the cached archive when ``url`` names
        one. Files already cached are checked first (stamp, else SHA-256) and
        fetched again if they changed.

    Raises
    ------
    InputError
        If ``SHA256SUMS`` or a file cannot be fetched (the line names the URL
        and the HTTP status or the reason: a download cut short, larger than
        its limit or slower than :data:`MIN_BYTES_PER_S`, a redirect to
        another scheme than http(s)), or the release holds no archive to read.
    VerificationError
        If the manifest is malformed (a line that is not ``<sha256>  <path>``,
        a path outside the folder, ``.``, or below another listed file) or a
        downloaded file differs from it; the file is not cached.
    MissingDependencyError
        For a scheme other than http(s) without fsspec (``pip install
        'vptoolkit[remote]'``) or fsspec's filesystem for that scheme.
    """
    base, archive = url.rstrip("/"), None
    last = base.rsplit("/", 1)[-1]
    try:
        store_kind(last)
        base, archive = base.rsplit("/", 1)[0], urllib.parse.unquote(last)
    except InputError:
        if last == MANIFEST_NAME:
            base = base.rsplit("/", 1)[0]
    source = _source(base)
    listing = b"".join(_receive(source, MANIFEST_NAME, MAX_MANIFEST_BYTES,
                                "the most a SHA256SUMS manifest may hold"))
    sums = parse_sha256sums(listing, source.url_of(MANIFEST_NAME))
    _check_paths(sums, source.url_of(MANIFEST_NAME))
    releases = Path(cache_dir if cache_dir is not None else default_cache_dir()) / "releases"
    folder = releases / hashlib.sha256(listing).hexdigest()
    if everything:  # croissant.json first: it records the sizes of the others
        wanted = sorted(sorted(sums), key=lambda name: name != CROISSANT_NAME)
    else:
        wanted = _needed(sums, archive, base)
    folder.mkdir(parents=True, exist_ok=True)
    stamps_path = releases / f"{folder.name}.stamps.json"
    stamps = _read_stamps(stamps_path)
    before = dict(stamps)
    sizes: dict[str, int] = {}
    for relative in wanted:
        target = folder / relative
        if not _is_cached(target, sums[relative], stamps, relative):
            _download(source, relative, sums[relative], target, sizes)
            stamps[relative] = _stamp(target)
        if relative == CROISSANT_NAME:
            sizes = _recorded_sizes(target)
    if stamps != before:
        write_text_atomic(stamps_path, json.dumps(stamps, sort_keys=True))
    manifest = folder / MANIFEST_NAME
    if not manifest.is_file() or manifest.read_bytes() != listing:
        write_bytes_atomic(manifest, listing)
    return folder / archive if archive is not None else folder
