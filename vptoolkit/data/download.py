"""The transfer of one file: bounded, retried, resumable, from http(s) or any fsspec URL.

A file is read from a :data:`Source`, the folder of a release:

- :class:`HttpSource` for ``http://`` and ``https://``, with the standard
  library alone (:mod:`urllib`); redirects are followed to http(s) URLs only;
- :class:`FsspecSource` for every other scheme fsspec knows
  (``hf://datasets/<user>/<repo>``, ``s3://bucket/release``, ``file://`` ...),
  the ``remote`` extra (``pip install 'vptoolkit[remote]'``; ``hf://`` also
  needs ``huggingface_hub``, ``s3://`` ``s3fs``).

:func:`download_file` writes one file to its place through a hidden sibling,
``.<name>.download``, hashed while it arrives and renamed into place only when
its SHA-256 is the expected one. A request that finds no server, breaks off or
gets an HTTP 5xx is tried again (:func:`retrying`), :data:`TRIES` times in all,
after waits of :data:`BACKOFF_S`, then twice as long each time. A download
that broke off (in this try, or in a run that was killed) goes on from the end
of its ``.download`` sibling with a Range request: the answer is used only if
it is 206 with a Content-Range starting there, else the file is fetched from
its start; the bytes already there are hashed with the rest, and a resumed file
whose SHA-256 differs is fetched once more, whole. Downloads of at least
:data:`PROGRESS_MIN_BYTES` show a tqdm bar on stderr when asked to.

:func:`fetch_range` reads bytes ``first:stop`` of an http(s) file of a known
size: the answer must be 206 with exactly that Content-Range and total, or it
is refused (:class:`RangesRefused` when the server sends the whole file
instead). :mod:`vptoolkit.data.ranges` reads an archive lazily with it.

Every transfer is bounded: the caller gives the most bytes the file may hold
(refused at once when the server announces more, and as soon as more arrive);
a transfer must keep up :data:`MIN_BYTES_PER_S` on average once
:data:`GRACE_S` have passed, and a server silent for :data:`READ_TIMEOUT_S`
ends it. So a file takes at most ``GRACE_S + size / MIN_BYTES_PER_S`` seconds.
Each limit exceeded, a transfer cut short (fewer bytes than the announced
``Content-Length``) and every transport error is one
:class:`~vptoolkit.errors.InputError` line naming the URL.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import os
import re
import socket
import time
import urllib.parse
from collections.abc import Callable, Generator
from contextlib import ExitStack, closing
from pathlib import Path
from typing import IO, TYPE_CHECKING, BinaryIO, NamedTuple, TypeVar

from vptoolkit.checks import one_line
from vptoolkit.errors import InputError, MissingDependencyError, VerificationError
from vptoolkit.files import BLOCK_SIZE, atomic_write, remove_stale_partials, temporary_prefix
from vptoolkit.optional import require
from vptoolkit.progress import Bar, progress_bar

if TYPE_CHECKING:
    import http.client
    import urllib.request

__all__ = [
    "BACKOFF_S",
    "GRACE_S",
    "MIN_BYTES_PER_S",
    "PROGRESS_MIN_BYTES",
    "READ_TIMEOUT_S",
    "REMOTE_EXTRA",
    "TRIES",
    "Body",
    "FsspecSource",
    "HttpSource",
    "RangesRefused",
    "Source",
    "Transient",
    "Unreachable",
    "download_file",
    "fetch_range",
    "receive",
    "retrying",
    "source_of",
]

REMOTE_EXTRA = "remote"
"""The vptoolkit extra that installs fsspec, for schemes other than http(s)."""

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

_CONTENT_RANGE = re.compile(r"bytes (\d+)-(\d+)/(\d+|\*)")
_USER_AGENT = "vptoolkit"
_log = logging.getLogger(__name__)
_T = TypeVar("_T")


class Transient(InputError):
    """A failure that may pass when tried again: a transfer broken off, an HTTP 5xx answer."""


class Unreachable(Transient):
    """No answer at all: the host is unknown, refuses the connection or stays silent."""


class RangesRefused(InputError):
    """The server answered a Range request with the whole file: it does not serve ranges."""


class Body(NamedTuple):
    """The answer to a request for one file, from byte ``offset`` on."""

    offset: int
    """Where ``blocks`` starts in the file: the byte asked for, or 0 when all of it comes."""
    size: int | None
    """Bytes of the whole file, when the answer says."""
    blocks: Generator[bytes, None, None]
    """The bytes, as they arrive; close it to end the transfer early."""


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


class HttpSource:
    """A release folder served over http(s), read with urllib."""

    def __init__(self, url: str) -> None:
        self.base = url.rstrip("/")

    def url_of(self, relative: str) -> str:
        return f"{self.base}/{urllib.parse.quote(relative)}"

    def open(self, relative: str, limit: int, why: str, start: int = 0) -> Body:
        """Request ``relative`` from byte ``start`` on (a Range request when ``start`` > 0).

        The answer starts at ``start`` when the server sends 206 with that
        Content-Range, else at 0 (a server without ranges sends it all; a
        416, a range past the end, asks again for all of it). Refused at once
        when the file holds more than ``limit`` bytes; a body shorter than its
        ``Content-Length`` or a broken chunked body ends in a
        :class:`Transient` error, as do an unreachable server (:class:`Unreachable`)
        and an HTTP 5xx.
        """
        url = self.url_of(relative)
        response = self._request(url, f"bytes={start}-" if start else None)
        if response is None:  # 416: the range starts past the end
            return self.open(relative, limit, why)
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
        return Body(offset, size, self._read(response, url))

    def open_range(self, relative: str, first: int, stop: int, total: int) -> Body:
        """Request bytes ``first:stop`` of ``relative``, a file of ``total`` bytes.

        Raises
        ------
        RangesRefused
            When the server answers with the whole file (200).
        InputError
            When the answer is not 206 with Content-Range
            ``bytes <first>-<stop - 1>/<total>``, or is longer.
        """
        url = self.url_of(relative)
        wanted = f"bytes {first}-{stop - 1}/{total}"
        response = self._request(url, f"bytes={first}-{stop - 1}")
        if response is None:
            raise InputError(f"{url}: answered a request for {wanted} with HTTP 416 (range "
                             "not satisfiable); the file is smaller than croissant.json records")
        if response.status != 206:
            response.close()
            raise RangesRefused(f"{url}: answered a Range request with the whole file "
                                f"(HTTP {response.status})")
        content_range = response.headers.get("Content-Range", "")
        if content_range != wanted:
            response.close()
            raise InputError(f"{url}: answered a request for {wanted} (the size croissant.json "
                             f"records) with Content-Range {one_line(content_range)!r}")
        if (response.length or 0) > stop - first:
            response.close()
            raise InputError(f"{url}: answered a request for {wanted} with a body of "
                             f"{response.length} bytes, more than the {stop - first} asked for")
        return Body(first, total, self._read(response, url))

    @staticmethod
    def _request(url: str, byte_range: str | None) -> http.client.HTTPResponse | None:
        """The open response to a GET of ``url``; None for a 416 answer to a Range request."""
        import http.client
        import urllib.error
        import urllib.request

        headers = {"User-Agent": _USER_AGENT}
        if byte_range is not None:
            headers["Range"] = byte_range
        request = urllib.request.Request(url, headers=headers)
        try:
            response: http.client.HTTPResponse = _http_opener().open(
                request, timeout=READ_TIMEOUT_S)
        except urllib.error.HTTPError as err:
            err.close()
            if err.code == 416 and byte_range is not None:
                return None
            kind = Transient if err.code >= 500 else InputError
            raise kind(f"{url}: HTTP {err.code} {one_line(err.reason)}") from err
        except (urllib.error.URLError, OSError, http.client.HTTPException) as err:
            reason = getattr(err, "reason", err)
            raise Unreachable(f"{url}: cannot be fetched ({one_line(reason)})") from err
        return response

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
                    raise Transient(f"{url}: download broke off ({one_line(err)})") from err
                if not block:
                    break
                received += len(block)
                yield block
            if announced is not None and received < announced:
                raise Transient(f"{url}: download broke off ({received} of the {announced} "
                                "bytes announced)")


class FsspecSource:
    """A release folder anywhere fsspec reaches (``hf://``, ``s3://``, ``file://`` ...)."""

    def __init__(self, url: str) -> None:
        fsspec = require("fsspec", extra=REMOTE_EXTRA)
        self.base = url.rstrip("/")
        try:  # some file systems connect here (ftp://)
            self._fs, self._root = fsspec.core.url_to_fs(self.base)
        except ImportError as err:
            raise MissingDependencyError(f"{url}: {err}") from err
        except Exception as err:  # noqa: BLE001 - a backend's own error becomes one line
            raise _backend_failure(url, err, one_line(err)) from err
        self._root = self._root.rstrip("/")

    def url_of(self, relative: str) -> str:
        return f"{self.base}/{relative}"

    def open(self, relative: str, limit: int, why: str, start: int = 0) -> Body:
        """The content of ``relative`` from byte ``start`` on, in :data:`BLOCK_SIZE`-byte blocks.

        Refused at once when the file system reports more than ``limit`` bytes.
        """
        stream = self._open(relative)
        size = getattr(stream, "size", None)  # fsspec's buffered files know it
        if isinstance(size, int) and size > limit:
            stream.close()
            raise _too_large(self.url_of(relative), limit, why)
        if start:
            stream.seek(start)
        return Body(start, size if isinstance(size, int) else None,
                    self._read(stream, self.url_of(relative)))

    @staticmethod
    def _read(stream: IO[bytes], url: str) -> Generator[bytes, None, None]:
        with stream:
            while True:
                try:
                    block = stream.read(BLOCK_SIZE)
                except Exception as err:  # noqa: BLE001 - a backend's own error becomes one line
                    raise Transient(f"{url}: download broke off ({one_line(err)})") from err
                if not block:
                    return
                yield block

    def _open(self, relative: str) -> IO[bytes]:
        """Open ``relative``; a failure to connect is :class:`Unreachable`, any other one line.

        Each fsspec file system raises its own client's errors (``httpx``,
        ``requests``, ``aiohttp``, ``botocore`` ...), so they are told apart by
        :func:`_backend_failure`, not by type.
        """
        url = self.url_of(relative)
        try:
            stream: IO[bytes] = self._fs.open(f"{self._root}/{relative}", "rb")
        except FileNotFoundError as err:
            raise InputError(f"{url}: not found") from err
        except Exception as err:  # noqa: BLE001 - a backend's own error becomes one line
            raise _backend_failure(url, err, f"cannot be fetched ({one_line(err)})") from err
        return stream


def _backend_failure(url: str, error: Exception, message: str) -> InputError:
    """A file system backend's ``error`` at ``url`` as one line: :class:`Unreachable` when it is
    a failure to reach a host, else an InputError ``"{url}: {message}"``.

    A failure to reach a host is the standard library's ``ConnectionError``,
    ``TimeoutError`` or ``socket.gaierror`` (an unknown host), or an HTTP
    client's error whose class name says ``Connect`` or ``Timeout``
    (``httpx.ConnectError``, ``requests.ConnectionError``,
    ``aiohttp.ClientConnectorError`` ...), raised or raised from.
    """
    seen: set[int] = set()
    current: BaseException | None = error
    while current is not None and id(current) not in seen:
        seen.add(id(current))
        if isinstance(current, (ConnectionError, TimeoutError, socket.gaierror)) or any(
                word in klass.__name__ for klass in type(current).__mro__
                for word in ("Connect", "Timeout")):
            return Unreachable(f"{url}: cannot be fetched ({one_line(error)})")
        current = current.__cause__ or current.__context__
    return InputError(f"{url}: {message}")


Source = HttpSource | FsspecSource
"""A release folder files are read from."""


def source_of(url: str) -> Source:
    """The :data:`Source` of a release folder's URL: urllib for http(s), else fsspec."""
    scheme = url.split("://", 1)[0].lower()
    return HttpSource(url) if scheme in ("http", "https") else FsspecSource(url)


def _too_large(url: str, limit: int, why: str) -> InputError:
    return InputError(f"{url}: more than {limit} bytes, {why}; download refused, nothing cached")


def receive(source: Source, relative: str, limit: int, why: str, start: int = 0) -> Body:
    """One file from byte ``start`` on, refused past ``limit`` bytes or below the minimum rate.

    ``why`` says where ``limit`` comes from, in the message.
    """
    body = source.open(relative, limit, why, start)
    return body._replace(blocks=_bounded(body, source.url_of(relative), limit, why))


def fetch_range(source: HttpSource, relative: str, first: int, stop: int, total: int) -> bytes:
    """Bytes ``first:stop`` of ``relative``, a file of ``total`` bytes, bounded and retried.

    Raises
    ------
    RangesRefused
        When the server does not serve ranges (it sends the whole file).
    InputError
        When the answer's Content-Range or total differs from the request, it
        is too slow, or it cannot be fetched (after :data:`TRIES` tries where
        that may help).
    """
    url = source.url_of(relative)

    def attempt() -> bytes:
        body = source.open_range(relative, first, stop, total)
        why = f"the {stop - first} bytes asked for"
        payload = b"".join(_bounded(body, url, stop, why))
        if len(payload) != stop - first:
            raise Transient(f"{url}: download broke off ({len(payload)} of the "
                            f"{stop - first} bytes asked for)")
        return payload

    return retrying(attempt)


def _bounded(body: Body, url: str, limit: int,
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


def retrying(attempt: Callable[[], _T], tries: int | None = None) -> _T:
    """``attempt()``, tried again after a :class:`Transient` error, :data:`TRIES` times in all.

    The waits between tries start at :data:`BACKOFF_S` and double. The last
    error is raised, of the same class, saying how many tries were made.
    """
    tries = TRIES if tries is None else tries
    for number in range(1, tries):
        try:
            return attempt()
        except Transient as err:
            wait = BACKOFF_S * 2 ** (number - 1)
            _log.info("%s; trying again in %.1f s", err, wait)
            time.sleep(wait)
    try:
        return attempt()
    except Transient as err:
        if tries == 1:
            raise
        raise type(err)(f"{err}; gave up after {tries} tries") from err


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


class _Wanted(NamedTuple):
    """One file to download and its bounds."""

    relative: str
    """Its path in the release folder."""
    limit: int
    """The most bytes it may hold."""
    why: str
    """Where ``limit`` comes from, for the message."""
    recorded_size: int
    """Its size as the release records it (0 when unknown): the progress bar's total."""


def _fill(out: BinaryIO, source: Source, wanted: _Wanted, show: bool) -> str:
    """Complete ``out`` with the bytes of the file and return the SHA-256 of all of it.

    ``out`` may already hold the start of the file (a download broken off
    before, in ``"a+b"`` mode): those bytes are hashed and the rest is asked
    for with a Range request; a server that sends the whole file instead
    starts ``out`` over. Transient failures are tried again (:func:`retrying`),
    each try going on from the bytes already written.
    """
    digest = hashlib.sha256()
    if out.seek(0, os.SEEK_END) > wanted.limit:
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
            body = receive(source, wanted.relative, wanted.limit, wanted.why, start=have)
            if body.offset != have:  # the whole file comes: start over
                out.truncate(0)
                digest = hashlib.sha256()
            if bar is None:
                total = body.size if body.size is not None else wanted.recorded_size
                bar = bars.enter_context(progress_bar(
                    total=total, description=wanted.relative, unit="B", initial=body.offset,
                    enabled=show and total >= PROGRESS_MIN_BYTES))
            with closing(body.blocks):
                for block in body.blocks:
                    out.write(block)
                    digest.update(block)
                    bar.update(len(block))

        retrying(attempt)
    return digest.hexdigest()


def download_file(source: Source, relative: str, target: Path, *, sha256: str, limit: int,
                  why: str, recorded_size: int | None, show: bool) -> None:
    """Fetch one file to ``target`` through a hidden sibling, moved into place only if it matches.

    Parameters
    ----------
    source : Source
        The release folder.
    relative : str
        The file's path in it.
    target : Path
        Where the verified file goes.
    sha256 : str
        Its expected SHA-256, hexadecimal.
    limit : int
        The most bytes it may hold; ``why`` says where that bound comes from.
    recorded_size : int, optional
        Its size as the release records it, for the progress bar.
    show : bool
        Show a progress bar for :data:`PROGRESS_MIN_BYTES` or more.

    Notes
    -----
    The sibling, ``.<name>.download``, is kept when the download fails on the
    way (after :data:`TRIES` tries), and the next download goes on from its
    end; a resumed file whose SHA-256 differs is fetched once more from the
    start. While another process holds that sibling, this one downloads to a
    temporary file of its own. The temporary files that killed downloads of
    ``target`` left are removed first.

    Raises
    ------
    InputError
        If it cannot be fetched or passes its bounds (one line naming the URL).
    VerificationError
        If its SHA-256 differs; nothing is cached.
    """
    wanted = _Wanted(relative, limit, why, recorded_size or 0)
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_partials(target.parent, target.name)
    url = source.url_of(relative)
    partial = target.with_name(f"{temporary_prefix(target.name)}download")
    with open(partial, "a+b") as out:
        if _hold(out):
            resumed = out.seek(0, os.SEEK_END) > 0
            try:
                digest = _fill(out, source, wanted, show)
                if digest != sha256 and resumed:
                    out.truncate(0)
                    digest = _fill(out, source, wanted, show)
            except Transient:
                raise  # the bytes received so far stay, for the next download to go on from
            except (InputError, OSError):
                partial.unlink(missing_ok=True)
                raise
            if digest == sha256:
                out.flush()
                os.fsync(out.fileno())
        else:
            with atomic_write(target) as fresh:
                _hold(fresh)
                digest = _fill(fresh, source, wanted, show)
                if digest != sha256:
                    raise _differs(url, digest, sha256)
            return
    if digest != sha256:
        partial.unlink(missing_ok=True)
        raise _differs(url, digest, sha256)
    os.replace(partial, target)


def _differs(url: str, digest: str, expected: str) -> VerificationError:
    return VerificationError(f"{url}: SHA-256 {digest[:12]}... differs from SHA256SUMS "
                             f"({expected[:12]}...); download refused, nothing cached")
