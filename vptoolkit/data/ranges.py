"""An archive read over http(s) byte ranges: only the blocks a reader touches are fetched.

:class:`RangeFile` is a read-only, seekable file over a URL whose size is
known (recorded in the release's ``croissant.json``). Each read asks for the
aligned blocks of :attr:`RemoteArchive.block_size` bytes it covers, with
Range requests (:func:`vptoolkit.data.download.fetch_range`: bounded, retried,
refused unless the answer is 206 with that exact Content-Range and total), and
keeps the last :attr:`RemoteArchive.cached_blocks` in memory. h5py reads an
HDF5 store from it (``h5py.File(stream, "r")``), so opening one split or one
model of a release reads the store's metadata and those rows, not the archive.

Verification
    The SHA-256 in ``SHA256SUMS`` covers the whole archive and cannot be
    checked from ranges: the bytes read this way are checked against the
    archive's recorded size only (every answer must name that total). The
    manifest, ``croissant.json`` and the card are downloaded whole and
    verified as always; ``open_dataset(url, partial=False)`` and ``vptool
    verify URL`` download the whole archive and check its SHA-256.

:class:`RemoteArchive` is what a data loader's worker processes receive: the
URL, the size and the block settings, a picklable value whose :meth:`~RemoteArchive.open`
gives a fresh :class:`RangeFile`.
"""

from __future__ import annotations

import io
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

from vptoolkit.data.download import HttpSource, fetch_range
from vptoolkit.errors import InputError

__all__ = ["CACHED_BLOCKS", "RANGE_BLOCK_BYTES", "RangeFile", "RemoteArchive"]

RANGE_BLOCK_BYTES = 64 << 10
"""Bytes of one Range request: reads are rounded out to aligned blocks of this size (64 KiB).

About the size of one compressed chunk of a model's points: HDF5 reads its
metadata and chunk index in small pieces scattered over the file, so larger
blocks fetch more bytes that nothing reads (``tools/bench_remote.py``).
"""

CACHED_BLOCKS = 256
"""Blocks one :class:`RangeFile` keeps in memory, the least recently read dropped first (16 MiB)."""


@dataclass(frozen=True)
class RemoteArchive:
    """An archive of a release to read by ranges: a picklable way to open it again.

    Attributes
    ----------
    base : str
        URL of the release folder (http or https).
    name : str
        The archive's path in it.
    size : int
        Its size in bytes, as ``croissant.json`` records it.
    path : Path
        Where the verified archive goes in the cache (what ``partial=False``
        fetches); the archive is not there, the path names it in messages.
    block_size : int
        Bytes of one Range request (default: :data:`RANGE_BLOCK_BYTES` when created).
    cached_blocks : int
        Blocks kept in memory (default: :data:`CACHED_BLOCKS` when created).
    """

    base: str
    name: str
    size: int
    path: Path
    block_size: int = field(default_factory=lambda: RANGE_BLOCK_BYTES)
    cached_blocks: int = field(default_factory=lambda: CACHED_BLOCKS)

    @property
    def url(self) -> str:
        """The archive's URL."""
        return HttpSource(self.base).url_of(self.name)

    def open(self) -> RangeFile:
        """A new :class:`RangeFile` over the archive (nothing is fetched yet)."""
        return RangeFile(self)


class RangeFile(io.RawIOBase):
    """A read-only, seekable file over an http(s) URL, read by aligned Range requests.

    Raises
    ------
    InputError
        From a read whose answer is not the bytes asked for (one line naming
        the URL: a wrong Content-Range or total, a server that stopped serving
        ranges, a transfer too slow or broken off after its tries).
    """

    def __init__(self, archive: RemoteArchive) -> None:
        super().__init__()
        self.archive = archive
        self.name = archive.name
        self._source = HttpSource(archive.base)
        self._position = 0
        self._blocks: OrderedDict[int, bytes] = OrderedDict()

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def tell(self) -> int:
        return self._position

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        base = {io.SEEK_SET: 0, io.SEEK_CUR: self._position, io.SEEK_END: self.archive.size}
        if whence not in base:
            raise InputError(f"{self.archive.url}: seek whence {whence!r} is not 0, 1 or 2")
        position = base[whence] + offset
        if position < 0:
            raise InputError(f"{self.archive.url}: seek to byte {position}, before the start")
        self._position = position
        return position

    def readinto(self, buffer: bytearray | memoryview) -> int:  # type: ignore[override]
        """Fill ``buffer`` from the current position; fewer bytes only at the end of the file."""
        view = memoryview(buffer).cast("B")
        stop = min(self._position + len(view), self.archive.size)
        written = 0
        while self._position + written < stop:
            where = self._position + written
            index, within = divmod(where, self.archive.block_size)
            block = self._block(index)
            count = min(len(block) - within, stop - where)
            view[written:written + count] = block[within:within + count]
            written += count
        self._position += written
        return written

    def close(self) -> None:
        """Drop the blocks kept in memory."""
        self._blocks.clear()
        super().close()

    def _block(self, index: int) -> bytes:
        """Block ``index``, from memory or fetched (then the least recently read may go)."""
        if index in self._blocks:
            self._blocks.move_to_end(index)
            return self._blocks[index]
        first = index * self.archive.block_size
        stop = min(first + self.archive.block_size, self.archive.size)
        block = fetch_range(self._source, self.archive.name, first, stop, self.archive.size)
        self._blocks[index] = block
        while len(self._blocks) > self.archive.cached_blocks:
            self._blocks.popitem(last=False)
        return block
