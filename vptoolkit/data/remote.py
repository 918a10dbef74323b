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
downloaded to a hidden sibling, ``.<name>.download``, hashed while it arrives,
and renamed into place only when its SHA-256 matches the manifest: the cache
never holds a half-written or unverified file under a file's own name.

A request that finds no server, breaks off or gets an HTTP 5xx is tried
again, :data:`TRIES` times in all, after waits of :data:`BACKOFF_S`, then twice
as long each time. A download that broke off (in this try, or in a run that
was killed) goes on from the end of its ``.download`` sibling with a Range
request: the answer is used only if it is 206 with a Content-Range starting
there, else the file is fetched from its start; the bytes already there are
hashed with the rest, and a resumed file whose SHA-256 differs is fetched once
more, whole. Downloads of at least :data:`PROGRESS_MIN_BYTES` show a tqdm bar
on stderr when it is a terminal. When ``SHA256SUMS`` cannot be fetched because
no server answers (not an HTTP error status) and the cache holds a complete
copy of what the URL last served, verified (every file read has its stamp),
that copy is used and ``offline: using the cached copy of <url>`` is logged
as a warning, once per process; the URL's last release folder is recorded in
``<cache_dir>/urls/<SHA-256 of the URL>.json``.

The archive is fetched whole, also to read one split or one model: the
reader (:func:`vptoolkit.dataset.reader.open_store`) opens a local path only,
and only a whole file can be checked against its SHA-256.
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

Size
    About 780 lines: the release cache (manifest, folders, stamps, offline
    use) and the bounded, retried, resumable transfer of one file. The
    transfer is a concept of its own and belongs in a module beside this one.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
import re
import sys
import time
import urllib.parse
from collections.abc import Callable, Generator, Iterable, Iterator, Mapping
from contextlib import ExitStack, closing
from pathlib import Path
from typing import IO, TYPE_CHECKING, BinaryIO, NamedTuple, TypeVar

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
    temporary_prefix,
    write_bytes_atomic,
    write_text_atomic,
)
from vptoolkit.optional import require
from vptoolkit.progress import Bar, progress_bar

if TYPE_CHECKING:
    import http.client
    import urllib.request

__all__ = [
    "BACKOFF_S",
    "GRACE_S",
    "MAX_DESCRIPTION_BYTES",
    "MAX_FILE_BYTES",
    "MAX_MANIFEST_BYTES",
    "MIN_BYTES_PER_S",
    "PROGRESS_MIN_BYTES",
    "READ_TIMEOUT_S",
    "REMOTE_EXTRA",
    "TRIES",
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

TRIES = 4
"""Tries of one request in all when the server cannot be reached, breaks off or answers 5xx."""

BACKOFF_S = 1.0
"""Seconds before the second try; each later wait is twice the one before (1, 2, 4 s)."""

PROGRESS_MIN_BYTES = 8 << 20
"""Downloads of at least this many bytes show a progress bar on stderr (8 MiB)."""

_SCHEME = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]*)://")
_CONTENT_SIZE = re.compile(r"(\d{1,19}) B")
_DATA_SUFFIXES = (".zarr.zip", ".h5", ".hdf5", ".parquet")
_TERMS = (CARD_NAME, LICENSES_NAME)
_CONTENT_RANGE = re.compile(r"bytes (\d+)-\d+/(?:\d+|\*)")
_USER_AGENT = "vptoolkit"
_log = logging.getLogger(__name__)
_noted_offline: set[str] = set()  # URLs whose offline notice this process has shown
_T = TypeVar("_T")


class _Transient(InputError):
    """A failure that may pass when tried again: a transfer broken off, an HTTP 5xx answer."""


class _Unreachable(_Transient):
    """No answer at all: the host is unknown, refuses the connection or stays silent."""


class _Body(NamedTuple):
    """The answer to a request for one file, from byte ``offset`` on."""

    offset: int
    """Where ``blocks`` starts in the file: the byte asked for, or 0 when all of it comes."""
    size: int | None
    """Bytes of the whole file, when the answer says."""
    blocks: Generator[bytes, None, None]
    """The bytes, as they arrive; close it to end the transfer early."""


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

    def open(self, relative: str, limit: int, why: str, start: int = 0) -> _Body:
        """Request ``relative`` from byte ``start`` on (a Range request when ``start`` > 0).

        The answer starts at ``start`` when the server sends 206 with that
        Content-Range, else at 0 (a server without ranges sends it all; a
        416, a range past the end, asks again for all of it). Refused at once
        when the file holds more than ``limit`` bytes; a body shorter than its
        ``Content-Length`` or a broken chunked body ends in a
        :class:`_Transient` error, as do an unreachable server (:class:`_Unreachable`)
        and an HTTP 5xx.
        """
        import http.client
        import urllib.error
        import urllib.request

        url = self.url_of(relative)
        headers = {"User-Agent": _USER_AGENT}
        if start:
            headers["Range"] = f"bytes={start}-"
        request = urllib.request.Request(url, headers=headers)
        try:
            response = _http_opener().open(request, timeout=READ_TIMEOUT_S)
        except urllib.error.HTTPError as err:
            err.close()
            if err.code == 416 and start:
                return self.open(relative, limit, why)
            kind = _Transient if err.code >= 500 else InputError
            raise kind(f"{url}: HTTP {err.code} {one_line(err.reason)}") from err
        except (urllib.error.URLError, OSError, http.client.HTTPException) as err:
            reason = getattr(err, "reason", err)
            raise _Unreachable(f"{url}: cannot be fetched ({one_line(reason)})") from err
        offset = 0
        if start and response.status == 206:
            content_range = response.headers.get("Content-Range", "")
            match = _CONTENT_RANGE.fullmatch(content_range)
            if match is None or int(match[1]) != start:
                response.close()
                raise InputError(f"{url}: answered a request from byte {start} with "
                                 f"Content-Range {one_line(content_range)!r}")
            offset = start
        announced = response.length  # None without a Content-Length
        size = None if announced is None else offset + announced
        if size is not None and size > limit:
            response.close()
            raise _too_large(url, limit, why)
        return _Body(offset, size, self._read(response, url))

    @staticmethod
    def _read(response: http.client.HTTPResponse, url: str) -> Generator[bytes, None, None]:
        import http.client

        with response:
            announced = response.length
            received = 0
            while True:
                try:
                    block = response.read1(BLOCK_SIZE)
                except (OSError, http.client.HTTPException) as err:
                    raise _Transient(f"{url}: download broke off ({one_line(err)})") from err
                if not block:
                    break
                received += len(block)
                yield block
            if announced is not None and received < announced:
                raise _Transient(f"{url}: download broke off ({received} of the {announced} "
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

    def open(self, relative: str, limit: int, why: str, start: int = 0) -> _Body:
        """The content of ``relative`` from byte ``start`` on, in blocks of :data:`BLOCK_SIZE` bytes.

        Refused at once when the file system reports more than ``limit`` bytes.
        """
        stream = self._open(relative)
        size = getattr(stream, "size", None)  # fsspec's buffered files know it
        if isinstance(size, int) and size > limit:
            stream.close()
            raise _too_large(self.url_of(relative), limit, why)
        if start:
            stream.seek(start)
        return _Body(start, size if isinstance(size, int) else None,
                     self._read(stream, self.url_of(relative)))

    @staticmethod
    def _read(stream: IO[bytes], url: str) -> Generator[bytes, None, None]:
        with stream:
            while True:
                try:
                    block = stream.read(BLOCK_SIZE)
                except OSError as err:
                    raise _Transient(f"{url}: download broke off ({one_line(err)})") from err
                if not block:
                    return
                yield block

    def _open(self, relative: str) -> IO[bytes]:
        try:
            stream: IO[bytes] = self._fs.open(f"{self._root}/{relative}", "rb")
        except FileNotFoundError as err:
            raise InputError(f"{self.url_of(relative)}: not found") from err
        except OSError as err:
            raise InputError(f"{self.url_of(relative)}: cannot be fetched ({err})") from err
        return stream


def _source(url: str) -> _HttpSource | _FsspecSource:
    scheme = url.split("://", 1)[0].lower()
    return _HttpSource(url) if scheme in ("http", "https") else _FsspecSource(url)


def _too_large(url: str, limit: int, why: str) -> InputError:
    return InputError(f"{url}: more than {limit} bytes, {why}; download refused, nothing cached")


def _receive(source: _HttpSource | _FsspecSource, relative: str, limit: int, why: str,
             start: int = 0) -> _Body:
    """One file from byte ``start`` on, refused past ``limit`` bytes or below the minimum rate.

    ``why`` says where ``limit`` comes from, in the message.
    """
    body = source.open(relative, limit, why, start)
    return body._replace(blocks=_bounded(body, source.url_of(relative), limit, why))


def _bounded(body: _Body, url: str, limit: int,
             why: str) -> Generator[bytes, None, None]:
    """The blocks of ``body``, ended by an error past ``limit`` bytes or below the minimum rate.

    Closing it, or an error, ends the transfer.
    """
    start = time.monotonic()
    received = 0
    with closing(body.blocks):
        for block in body.blocks:
            received += len(block)
            if body.offset + received > limit:
                raise _too_large(url, limit, why)
            elapsed = time.monotonic() - start
            if elapsed > GRACE_S and received < (elapsed - GRACE_S) * MIN_BYTES_PER_S:
                raise InputError(
                    f"{url}: too slow ({received} bytes in {elapsed:.0f} s, below "
                    f"{MIN_BYTES_PER_S} bytes/s after the first {GRACE_S:g} s); download refused"
                )
            yield block


def _retrying(attempt: Callable[[], _T], tries: int | None = None) -> _T:
    """``attempt()``, tried again after a :class:`_Transient` error, :data:`TRIES` times in all.

    The waits between tries start at :data:`BACKOFF_S` and double. The last
    error is raised, of the same class, saying how many tries were made.
    """
    tries = TRIES if tries is None else tries
    for number in range(1, tries):
        try:
            return attempt()
        except _Transient as err:
            wait = BACKOFF_S * 2 ** (number - 1)
            _log.info("%s; trying again in %.1f s", err, wait)
            time.sleep(wait)
    try:
        return attempt()
    except _Transient as err:
        if tries == 1:
            raise
        raise type(err)(f"{err}; gave up after {tries} tries") from err


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


def _hold(stream: BinaryIO) -> bool:
    """Lock a download's temporary file while it is written; False if another process holds it.

    :func:`~vptoolkit.files.remove_stale_partials` skips a locked file, so a
    concurrent download of the same file, in another process, keeps its own.
    """
    try:
        import fcntl
    except ImportError:  # Windows: an open file cannot be removed anyway
        return True
    try:
        fcntl.flock(stream.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    except OSError:  # a file system without locks: nothing is held, as in files.held
        return True
    return True


def _fill(out: BinaryIO, source: _HttpSource | _FsspecSource, relative: str,
          sizes: Mapping[str, int], show: bool) -> str:
    """Complete ``out`` with the bytes of ``relative`` and return the SHA-256 of all of it.

    ``out`` may already hold the start of the file (a download broken off
    before, in ``"a+b"`` mode): those bytes are hashed and the rest is asked
    for with a Range request; a server that sends the whole file instead
    starts ``out`` over. Transient failures are tried again (:func:`_retrying`),
    each try going on from the bytes already written.
    """
    limit, why = _limit(relative, sizes)
    digest = hashlib.sha256()
    if out.seek(0, os.SEEK_END) > limit:
        out.truncate(0)
    elif out.tell():
        out.seek(0)
        for block in iter(functools.partial(out.read, BLOCK_SIZE), b""):
            digest.update(block)
    with ExitStack() as bars:
        bar: Bar | None = None

        def attempt() -> None:
            nonlocal digest, bar
            have = out.seek(0, os.SEEK_END)
            body = _receive(source, relative, limit, why, start=have)
            if body.offset != have:  # the whole file comes: start over
                out.truncate(0)
                digest = hashlib.sha256()
            if bar is None:
                total = body.size if body.size is not None else sizes.get(relative, 0)
                bar = bars.enter_context(progress_bar(
                    total=total, description=relative, unit="B", initial=body.offset,
                    enabled=show and total >= PROGRESS_MIN_BYTES))
            with closing(body.blocks):
                for block in body.blocks:
                    out.write(block)
                    digest.update(block)
                    bar.update(len(block))

        _retrying(attempt)
    return digest.hexdigest()


def _download(source: _HttpSource | _FsspecSource, relative: str, expected: str,
              target: Path, sizes: Mapping[str, int], show: bool) -> None:
    """Fetch one file to ``target`` through a hidden sibling, moved into place only if it matches.

    The sibling, ``.<name>.download``, is kept when the download fails on the
    way (after :data:`TRIES` tries), and the next download goes on from its
    end; a resumed file whose SHA-256 differs is fetched once more from the
    start. While another process holds that sibling, this one downloads to a
    temporary file of its own. The temporary files that killed downloads of
    ``target`` left are removed first.
    """
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_partials(target.parent, target.name)
    url = source.url_of(relative)
    partial = target.with_name(f"{temporary_prefix(target.name)}download")
    with open(partial, "a+b") as out:
        if _hold(out):
            resumed = out.seek(0, os.SEEK_END) > 0
            try:
                digest = _fill(out, source, relative, sizes, show)
                if digest != expected and resumed:
                    out.truncate(0)
                    digest = _fill(out, source, relative, sizes, show)
            except _Transient:
                raise  # the bytes received so far stay, for the next download to go on from
            except (InputError, OSError):
                partial.unlink(missing_ok=True)
                raise
            if digest == expected:
                out.flush()
                os.fsync(out.fileno())
        else:
            with atomic_write(target) as fresh:
                _hold(fresh)
                digest = _fill(fresh, source, relative, sizes, show)
                if digest != expected:
                    raise _differs(url, digest, expected)
            return
    if digest != expected:
        partial.unlink(missing_ok=True)
        raise _differs(url, digest, expected)
    os.replace(partial, target)


def _differs(url: str, digest: str, expected: str) -> VerificationError:
    return VerificationError(f"{url}: SHA-256 {digest[:12]}... differs from SHA256SUMS "
                             f"({expected[:12]}...); download refused, nothing cached")


def _wanted(sums: Mapping[str, str], archive: str | None, base: str,
            everything: bool) -> list[str]:
    """The files a fetch reads: every listed one, croissant.json first, or :func:`_needed`."""
    if everything:  # croissant.json first: it records the sizes of the others
        return sorted(sorted(sums), key=lambda name: name != CROISSANT_NAME)
    return _needed(sums, archive, base)


def _pointer(cache: Path, base: str) -> Path:
    """Where the cache records which release folder ``base`` last served."""
    return cache / "urls" / f"{hashlib.sha256(base.encode('utf-8')).hexdigest()}.json"


def _cached_copy(cache: Path, base: str, archive: str | None, everything: bool) -> Path | None:
    """The release folder (or archive) last fetched from ``base``, if complete and verified.

    Complete and verified: the folder's ``SHA256SUMS`` hashes to its name and
    every file a fetch would read is there with the stamp it got when it was
    verified. Nothing is hashed here; None when any of that is not so.
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
        wanted = _wanted(parse_sha256sums(listing, str(folder / MANIFEST_NAME)), archive, base,
                         everything)
    except (InputError, VerificationError, OSError):
        return None
    stamps = _read_stamps(cache / "releases" / f"{name}.stamps.json")
    for relative in wanted:
        target = folder / relative
        if not target.is_file() or stamps.get(relative) != _stamp(target):
            return None
    return folder / archive if archive is not None else folder


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
        :data:`PROGRESS_MIN_BYTES` (default: when stderr is a terminal).

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
        its limit or slower than :data:`MIN_BYTES_PER_S`, a redirect to
        another scheme than http(s)), after :data:`TRIES` tries where trying
        again may help (no answer, a transfer broken off, HTTP 5xx), or the
        release holds no archive to read.
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
    cache = Path(cache_dir if cache_dir is not None else default_cache_dir())
    cached = _cached_copy(cache, base, archive, everything)
    try:  # one try only when a cached copy can stand in
        listing = _retrying(lambda: b"".join(_receive(
            source, MANIFEST_NAME, MAX_MANIFEST_BYTES,
            "the most a SHA256SUMS manifest may hold").blocks), tries=1 if cached else None)
    except _Unreachable:
        if cached is None:
            raise
        if base not in _noted_offline:
            _noted_offline.add(base)
            _log.warning("offline: using the cached copy of %s", base)
        return cached
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
    for relative in wanted:
        target = folder / relative
        if not _is_cached(target, sums[relative], stamps, relative):
            _download(source, relative, sums[relative], target, sizes, show)
            stamps[relative] = _stamp(target)
        if relative == CROISSANT_NAME:
            sizes = _recorded_sizes(target)
    if stamps != before:
        write_text_atomic(stamps_path, json.dumps(stamps, sort_keys=True))
    manifest = folder / MANIFEST_NAME
    if not manifest.is_file() or manifest.read_bytes() != listing:
        write_bytes_atomic(manifest, listing)
    pointer = _pointer(cache, base)
    record = json.dumps({"release": folder.name, "url": base}, sort_keys=True)
    if not pointer.is_file() or pointer.read_text(encoding="utf-8") != record:
        pointer.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(pointer, record)
    return folder / archive if archive is not None else folder
