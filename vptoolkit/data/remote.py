"""Fetch a release that lives elsewhere into a local cache, verified, to read it locally.

A release is addressed by the URL of its folder (or of one archive in it):

- ``http://`` and ``https://``: the standard library alone (:mod:`urllib`);
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
the cache never holds a half-written or unverified file.

By default only what reading needs is fetched: the small description files
at the top of the release and one archive, the one this install reads
(:func:`~vptoolkit.dataset.containers.archive_preference`); ``everything=True``
fetches every file (what ``vptool verify`` checks).

Examples
--------
>>> from vptoolkit.data import open_dataset
>>> dataset = open_dataset("https://example.org/releases/viewpoints/")  # doctest: +SKIP
"""

from __future__ import annotations

import hashlib
import os
import re
import urllib.parse
from collections.abc import Iterable
from contextlib import AbstractContextManager
from pathlib import Path
from typing import IO

from vptoolkit.dataset.containers import archive_preference, store_kind
from vptoolkit.dataset.manifest import BLOCK_SIZE, MANIFEST_NAME, parse_sha256sums
from vptoolkit.errors import InputError, MissingDependencyError, VerificationError
from vptoolkit.files import atomic_write, write_bytes_atomic
from vptoolkit.optional import require

__all__ = ["REMOTE_EXTRA", "default_cache_dir", "fetch_release", "is_remote"]

REMOTE_EXTRA = "remote"
"""The vptoolkit extra that installs fsspec, for schemes other than http(s)."""

_SCHEME = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]*)://")
_TIMEOUT_S = 60.0
_USER_AGENT = "vptoolkit"


def is_remote(path: object) -> bool:
    """Whether ``path`` is a URL (``scheme://...``) rather than a local path.

    Only a ``str`` can be one; a :class:`~pathlib.Path` is always local.
    """
    return isinstance(path, str) and _SCHEME.match(path) is not None


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/vptoolkit``, else ``~/.cache/vptoolkit``."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "vptoolkit"


class _HttpSource:
    """A release folder served over http(s), read with urllib."""

    def __init__(self, url: str) -> None:
        self.base = url.rstrip("/")

    def url_of(self, relative: str) -> str:
        return f"{self.base}/{urllib.parse.quote(relative)}"

    def open(self, relative: str) -> AbstractContextManager[IO[bytes]]:
        import urllib.error  # with urllib.request: 10 ms that only a download needs
        import urllib.request

        url = self.url_of(relative)
        request = urllib.request.Request(url, headers={"User-Agent": _USER_AGENT})
        try:
            return urllib.request.urlopen(request, timeout=_TIMEOUT_S)  # noqa: S310 - http(s) only
        except urllib.error.HTTPError as err:
            err.close()
            raise InputError(f"{url}: HTTP {err.code} {err.reason}") from err
        except (urllib.error.URLError, OSError) as err:
            reason = getattr(err, "reason", err)
            raise InputError(f"{url}: cannot be fetched ({reason})") from err


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

    def open(self, relative: str) -> AbstractContextManager[IO[bytes]]:
        try:
            return self._fs.open(f"{self._root}/{relative}", "rb")
        except FileNotFoundError as err:
            raise InputError(f"{self.url_of(relative)}: not found") from err
        except OSError as err:
            raise InputError(f"{self.url_of(relative)}: cannot be fetched ({err})") from err


def _source(url: str) -> _HttpSource | _FsspecSource:
    scheme = url.split("://", 1)[0].lower()
    return _HttpSource(url) if scheme in ("http", "https") else _FsspecSource(url)


def _read(source: _HttpSource | _FsspecSource, relative: str) -> bytes:
    with source.open(relative) as stream:
        try:
            return stream.read()
        except OSError as err:
            raise InputError(f"{source.url_of(relative)}: download broke off ({err})") from err


def _needed(sums: Iterable[str], archive: str | None, url: str) -> list[str]:
    """The files reading needs: the top-level description files and one archive."""
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
    return [name for name in top if name not in archives] + [chosen]


def _download(source: _HttpSource | _FsspecSource, relative: str, expected: str,
              target: Path) -> None:
    """Fetch one file to ``target`` through a hidden temporary sibling, kept only if it matches."""
    target.parent.mkdir(parents=True, exist_ok=True)
    url = source.url_of(relative)
    digest = hashlib.sha256()
    with atomic_write(target) as out, source.open(relative) as stream:
        while True:
            try:
                block = stream.read(BLOCK_SIZE)
            except OSError as err:
                raise InputError(f"{url}: download broke off ({err})") from err
            if not block:
                break
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
        Fetch every file the manifest lists (default: the description files
        and one archive, what :func:`vptoolkit.data.open_dataset` reads).

    Returns
    -------
    Path
        The cached release folder, or the cached archive when ``url`` names
        one.

    Raises
    ------
    InputError
        If ``SHA256SUMS`` or a file cannot be fetched (the line names the URL
        and the HTTP status or the reason), or the release holds no archive
        to read.
    VerificationError
        If the manifest is malformed or a downloaded file differs from it;
        the file is not cached.
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
    listing = _read(source, MANIFEST_NAME)
    sums = parse_sha256sums(listing, source.url_of(MANIFEST_NAME))
    folder = Path(cache_dir if cache_dir is not None else default_cache_dir()) / "releases" / (
        hashlib.sha256(listing).hexdigest())
    wanted = sorted(sums) if everything else _needed(sums, archive, base)
    folder.mkdir(parents=True, exist_ok=True)
    for relative in wanted:
        target = folder / relative
        if not target.is_file():
            _download(source, relative, sums[relative], target)
    if not (folder / MANIFEST_NAME).is_file():
        write_bytes_atomic(folder / MANIFEST_NAME, listing)
    return folder / archive if archive is not None else folder

