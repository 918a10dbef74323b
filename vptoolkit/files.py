"""Writing files so that a reader never sees half of one.

Every output of vptoolkit (meshes, quality arrays, checkpoints, pictures,
reports) is written through :func:`atomic_write`: the bytes go to a
temporary sibling (``.<name>.<random>.partial``, in the same folder so the
rename cannot cross file systems), are flushed to disk, and the sibling is
renamed over the target with :func:`os.replace`. An interrupted or failing
write leaves the previous file (or no file) and no partial one.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

__all__ = ["atomic_write", "write_bytes_atomic", "write_text_atomic"]


@contextmanager
def atomic_write(path: str | os.PathLike[str]) -> Iterator[BinaryIO]:
    """Open a binary stream whose content replaces ``path`` only on success.

    Parameters
    ----------
    path : path-like
        The target file; its folder must exist.

    Yields
    ------
    stream : binary file object
        Write the whole content to it. When the ``with`` block ends without
        an exception the content is fsynced and renamed over ``path``;
        otherwise the temporary file is removed and ``path`` is untouched.
    """
    target = Path(path)
    temporary = target.with_name(f".{target.name}.{secrets.token_hex(4)}.partial")
    # O_EXCL never clobbers; mode 0o666 lets the umask decide the permissions.
    handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(handle, "wb") as stream:
            yield stream
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, target)
    finally:
        temporary.unlink(missing_ok=True)


def write_bytes_atomic(path: str | os.PathLike[str], payload: bytes) -> Path:
    """Write ``payload`` to ``path`` through :func:`atomic_write`; return the path."""
    with atomic_write(path) as stream:
        stream.write(payload)
    return Path(path)


def write_text_atomic(path: str | os.PathLike[str], text: str) -> Path:
    """Write UTF-8 ``text`` to ``path`` through :func:`atomic_write`; return the path."""
    return write_bytes_atomic(path, text.encode("utf-8"))
