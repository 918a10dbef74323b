"""Writing files so that a reader never sees half of one, and reading JSON back in one line.

Every output of vptoolkit (meshes, quality arrays, checkpoints, pictures,
reports) is written through :func:`atomic_write`: the bytes go to a
temporary sibling (``.<name>.<random>.partial``, in the same folder so the
rename cannot cross file systems), are flushed to disk, and the sibling is
renamed over the target with :func:`os.replace`. An interrupted or failing
write leaves the previous file (or no file) and no partial one.

Every JSON the toolkit reads back (checkpoint configurations and training
states, ``categories.json``, ``croissant.json``, the staging folder's records,
JSON members and attributes of stores) goes through :func:`parse_json` or
:func:`read_json_file`: bad UTF-8, bad syntax, a number Python refuses (more
than 4300 digits) and nesting deeper than the interpreter's recursion limit
(``'[' * 200000``) all raise an :class:`~vptoolkit.errors.InputError` that
names the file, never a ``RecursionError`` traceback.

Every path built from a model name or category (a store's content, so maybe
hostile) takes that part through :func:`check_path_part`, which the store
writer and reader apply too.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import secrets
import shutil
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path, PurePosixPath, PureWindowsPath
from typing import Any, BinaryIO

import numpy as np

from vptoolkit.checks import one_line, short_repr

try:
    import fcntl
except ImportError:  # Windows: no advisory locks, nothing is held
    fcntl = None  # type: ignore[assignment]
from vptoolkit.errors import InputError

__all__ = [
    "BLOCK_SIZE",
    "atomic_write",
    "check_output_folder",
    "check_path_part",
    "held",
    "json_text",
    "named_os_error",
    "output_json",
    "errors_named",
    "exclusive_lock",
    "parse_json",
    "read_json_file",
    "remove_stale_partials",
    "sha256_file",
    "stale_partials",
    "temporary_name",
    "temporary_prefix",
    "write_bytes_atomic",
    "write_json_atomic",
    "write_text_atomic",
    "without_nan",
]


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

    Raises
    ------
    InputError
        If the folder of ``path`` does not exist.
    OSError
        If writing fails (e.g. a full disk); its ``filename`` is ``path``,
        never the temporary file.
    """
    target = Path(path)
    check_output_folder(target)
    temporary = target.with_name(temporary_name(target.name))
    try:
        # O_EXCL never clobbers; mode 0o666 lets the umask decide the permissions.
        handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    except OSError as err:  # name the user's file, not the hidden temporary one
        raise OSError(err.errno, err.strerror, str(target)) from err
    try:
        # Closing flushes what is buffered, so a full disk can fail there too.
        with os.fdopen(handle, "wb") as stream:
            yield stream
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, target)
    except OSError as err:
        if err.filename is None or str(err.filename) == str(temporary):
            # e.g. a full disk: say which output could not be written
            raise named_os_error(err, target) from err
        raise
    finally:
        temporary.unlink(missing_ok=True)


def named_os_error(error: OSError, path: str | os.PathLike[str]) -> OSError:
    """``error`` (a full disk, a file too large) as an OSError whose ``filename`` is ``path``."""
    if error.strerror is None:  # numpy's tofile says only "N requested and M written"
        return OSError(error.errno, f"not fully written ({one_line(error)}); is the disk full?",
                       str(path))
    return OSError(error.errno, error.strerror, str(path))


@contextmanager
def errors_named(temporary: str | os.PathLike[str],
                 target: str | os.PathLike[str]) -> Iterator[None]:
    """Inside the block, an OSError about ``temporary`` or about no file names ``target``.

    A writer that builds its output in a hidden temporary file or folder
    (``temporary``) and moves it into place reports a full disk or a file
    too large as a problem of the output the user named (``target``), never
    of the hidden path (:func:`named_os_error`); an OSError about another
    path (an input) passes unchanged.
    """
    try:
        yield
    except OSError as err:
        if err.filename is None or str(err.filename).startswith(str(temporary)):
            raise named_os_error(err, target) from err
        raise


def is_inside_folder(relative: str) -> bool:
    """Whether ``relative`` is a non-empty relative path that stays inside its folder.

    Refuses an absolute path (POSIX or Windows, with a drive), a ``..``
    component and a backslash, judged on the text alone.
    """
    if not relative or "\\" in relative:
        return False
    posix = PurePosixPath(relative)
    return (not posix.is_absolute() and not PureWindowsPath(relative).anchor
            and ".." not in posix.parts)


_CONTROL_CHARACTER = re.compile("[\x00-\x1f\x7f-\x9f]")  # Unicode category Cc


def check_path_part(value: object, what: str) -> str:
    """Return ``value`` if it can be one component of a path inside a folder, else raise.

    Model names and categories become file and folder names (``OUT/<category>/``,
    ``objfiles/<category>/<folder>/<name>.obj``), so a store's writer and
    reader and every path built from them check them here. Refused: a value
    that is not a non-empty string, holds ``/`` or ``\\``, starts with ``.``
    (so ``.``, ``..`` and hidden names), starts with a Windows drive
    (``C:``) or holds a control character (Unicode category Cc, NUL and line
    breaks included). Without separators, ``..`` can only be a whole component
    at the start, so ``a..b`` passes.

    Parameters
    ----------
    value : object
        The name.
    what : str
        What the value is, first in the message, e.g. ``dataset.zarr: category``.

    Returns
    -------
    part : str
        ``value``, unchanged.

    Raises
    ------
    InputError
        ``<what> '<value>' cannot name a file or folder (<why>)``, the value
        shortened to 80 characters.
    """
    if not isinstance(value, str) or not value:
        raise InputError(f"{what}: expected a non-empty string, got {short_repr(value, 80)}")
    if "/" in value or "\\" in value:
        problem = "it holds a path separator"
    elif value.startswith("."):
        problem = "it starts with '.'"
    elif PureWindowsPath(value).drive:
        problem = "it starts with a drive"
    elif _CONTROL_CHARACTER.search(value):
        problem = "it holds a control character"
    else:
        return value
    raise InputError(f"{what} {short_repr(value, 80)} cannot name a file or folder ({problem})")


_MAX_NAME_BYTES = 255  # a file name on ext4, XFS, APFS, NTFS
_SUFFIX_BYTES = len(".12345678.partial") + 8  # room for mkstemp's longer random part


def temporary_prefix(name: str) -> str:
    """Start of the name of every hidden temporary sibling of ``name``.

    ``.<name>.``, or ``.<start of name>~<16 hex of its SHA-256>.`` where a
    temporary name would otherwise pass the 255-byte limit of a file name, so
    that every valid output name can be written.
    """
    encoded = name.encode("utf-8", "surrogateescape")
    if len(encoded) + len(".") + _SUFFIX_BYTES <= _MAX_NAME_BYTES:
        return f".{name}."
    digest = hashlib.sha256(encoded).hexdigest()[:16]
    start = encoded[:160].decode("utf-8", "ignore")
    return f".{start}~{digest}."


def temporary_name(name: str) -> str:
    """``temporary_prefix(name)`` + 8 random hex digits + ``.partial``."""
    return f"{temporary_prefix(name)}{secrets.token_hex(4)}.partial"


def check_output_folder(path: str | os.PathLike[str], argument: str | None = None) -> Path:
    """Fail early, naming ``path``, when the folder an output goes into is missing.

    Call it before long work, so that a typo in an output path does not cost
    the whole computation.

    Raises
    ------
    InputError
        If the parent folder of ``path`` does not exist or is not a folder.
    """
    target = Path(path)
    folder = target.parent
    label = f"{argument}: " if argument else ""
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "does not exist"
        raise InputError(f"{label}{target}: output folder {folder} {what}")
    return target


def remove_stale_partials(folder: str | os.PathLike[str], name: str) -> None:
    """Delete the temporary siblings of ``name`` that an interrupted write left in ``folder``.

    Call it only after a write of ``name`` succeeded; a ``kill -9`` in the
    middle of a write leaves its ``.<name>.<random>.partial`` file or folder
    behind. Only that exact pattern is matched (so ``.rel.v2.<random>.partial``,
    the sibling of ``rel.v2``, is not one of ``rel``'s), and an entry that a
    live process holds (:func:`held`) is left alone.
    """
    for entry in stale_partials(folder, name):
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            entry.unlink(missing_ok=True)


def stale_partials(folder: str | os.PathLike[str], name: str) -> list[Path]:
    """The temporary siblings of ``name`` in ``folder`` that no live process holds.

    What :func:`remove_stale_partials` deletes: the ``.<name>.<random>.partial``
    files and folders a killed write left, sorted; none if ``folder`` is not a
    folder. A command that wants a new or empty output folder ignores them.
    """
    root = Path(folder)
    if not root.is_dir():
        return []
    pattern = re.compile(re.escape(temporary_prefix(name)) + r"[A-Za-z0-9_]+\.partial")
    return [entry for entry in sorted(root.iterdir())
            if pattern.fullmatch(entry.name) and not _is_held(entry)]


@contextmanager
def held(path: str | os.PathLike[str]) -> Iterator[None]:
    """Hold an advisory lock on a temporary file or folder while the block runs.

    :func:`remove_stale_partials`, in this process or another, skips what is
    held, so a write in progress never loses its temporary sibling. Where
    locks are not available (no ``fcntl``), nothing is held.
    """
    handle = _lock(path)
    try:
        yield
    finally:
        if handle is not None:
            os.close(handle)


@contextmanager
def exclusive_lock(path: str | os.PathLike[str], busy: str) -> Iterator[None]:
    """Hold an exclusive lock on the file ``path`` (created if needed) while the block runs.

    The operating system releases it when the process ends, even after
    ``kill -9``, so a lock never outlives its holder. Where locks are not
    available (no ``fcntl``), nothing is held.

    Raises
    ------
    InputError
        ``busy`` (one line), when another process holds the lock.
    """
    if fcntl is None:  # pragma: no cover - not POSIX: no protection against two runs
        yield
        return
    with open(path, "a+b") as handle:
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as err:
            raise InputError(busy) from err
        try:
            yield
        finally:
            fcntl.flock(handle.fileno(), fcntl.LOCK_UN)


def _lock(path: str | os.PathLike[str]) -> int | None:
    if fcntl is None:
        return None
    try:
        handle = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))  # a FIFO never waits
    except OSError:
        return None
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(handle)
        return None
    return handle


def _is_held(path: Path) -> bool:
    """Whether a live process holds ``path`` (see :func:`held`)."""
    if path.is_symlink():
        return False
    handle = _lock(path)
    if handle is not None:
        os.close(handle)  # it could be locked: nobody holds it
        return False
    return fcntl is not None and path.exists()


def write_bytes_atomic(path: str | os.PathLike[str], payload: bytes) -> Path:
    """Write ``payload`` to ``path`` through :func:`atomic_write`; return the path."""
    with atomic_write(path) as stream:
        stream.write(payload)
    return Path(path)


def write_text_atomic(path: str | os.PathLike[str], text: str) -> Path:
    """Write UTF-8 ``text`` to ``path`` through :func:`atomic_write`; return the path."""
    return write_bytes_atomic(path, text.encode("utf-8"))


def json_text(value: Any, *, indent: int | None = 2, sort_keys: bool = True,
              ensure_ascii: bool = True, allow_nan: bool = True, newline: bool = True) -> str:
    """``value`` as JSON text: :func:`json.dumps` with these options, then a line break.

    The defaults give indented JSON with sorted keys and a final newline;
    ``newline=False`` leaves the text as :func:`json.dumps` wrote it.
    """
    text = json.dumps(value, indent=indent, sort_keys=sort_keys, ensure_ascii=ensure_ascii,
                      allow_nan=allow_nan)
    return text + "\n" if newline else text


def without_nan(value: Any) -> Any:
    """``value`` with every NaN or infinite float (Python or numpy) replaced by None.

    Goes into dicts, lists and tuples (a tuple becomes a list); other values are
    returned as they are. JSON has no NaN: ``json.dumps`` would write the bare
    token ``NaN``, which strict parsers (JavaScript's ``JSON.parse``) refuse.
    """
    if isinstance(value, dict):
        return {key: without_nan(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [without_nan(item) for item in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def output_json(value: Any, *, indent: int | None = 2) -> str:
    """The JSON text a command prints: NaN and infinities as ``null`` (:func:`without_nan`),
    keys in their order, no final newline; strict JSON (``allow_nan=False``)."""
    return json.dumps(without_nan(value), indent=indent, allow_nan=False)


def write_json_atomic(path: str | os.PathLike[str], value: Any, *, indent: int | None = 2,
                      sort_keys: bool = True, ensure_ascii: bool = True, allow_nan: bool = True,
                      newline: bool = True) -> Path:
    """Write ``value`` as :func:`json_text` through :func:`write_text_atomic`; return the path.

    The keywords are :func:`json_text`'s; the defaults write indented JSON with
    sorted keys and a final newline.
    """
    return write_text_atomic(path, json_text(value, indent=indent, sort_keys=sort_keys,
                                             ensure_ascii=ensure_ascii, allow_nan=allow_nan,
                                             newline=newline))


def parse_json(data: str | bytes, label: str) -> Any:
    """Decode JSON text.

    Parameters
    ----------
    data : str or bytes
        The text, or its UTF-8 bytes.
    label : str
        The file (or ``file:member``) named first in the message.

    Returns
    -------
    value : Any
        The decoded value; callers check its type.

    Raises
    ------
    InputError
        ``label: not UTF-8 JSON (...)`` for any decoding failure.
    """
    try:
        text = data.decode("utf-8") if isinstance(data, (bytes, bytearray)) else data
        return json.loads(text)
    except RecursionError as err:
        raise InputError(f"{label}: not UTF-8 JSON (nested too deeply)") from err
    except (UnicodeDecodeError, ValueError, TypeError) as err:
        raise InputError(f"{label}: not UTF-8 JSON ({one_line(err)})") from err


def read_json_file(path: str | os.PathLike[str], label: str | None = None) -> Any:
    """Read a JSON file and decode it with :func:`parse_json`.

    Parameters
    ----------
    path : path-like
        The file.
    label : str, optional
        Named in messages (default: the file's name).

    Returns
    -------
    value : Any
        As :func:`parse_json` gives it.

    Raises
    ------
    InputError
        If the file cannot be read or is not UTF-8 JSON.
    """
    path = Path(path)
    label = path.name if label is None else label
    if path.exists() and not path.is_file():
        raise InputError(f"{label}: not a regular file")
    try:
        data = path.read_bytes()
    except OSError as err:
        raise InputError(f"{label}: cannot read ({one_line(err.strerror or err)})") from err
    return parse_json(data, label)


BLOCK_SIZE = 1 << 20
"""Bytes read per step while hashing or copying a file (1 MiB)."""


def sha256_file(path: Path | str, *, block_size: int = BLOCK_SIZE) -> str:
    """Return the SHA-256 hex digest of a file, read in blocks.

    Parameters
    ----------
    path : Path or str
        The file.
    block_size : int
        Bytes read per step (default: 1 MiB).

    Returns
    -------
    str
        64 lower-case hex digits.

    Raises
    ------
    InputError
        If ``path`` is not a regular file (a named pipe is never waited on).
    OSError
        If it cannot be opened or read.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> file = pathlib.Path(tempfile.mkdtemp()) / "abc.txt"
    >>> _ = file.write_bytes(b"abc")
    >>> sha256_file(file)[:16]
    'ba7816bf8f01cfea'
    """
    digest = hashlib.sha256()
    # Opened without blocking, so a named pipe (or a device) is refused instead of
    # waiting forever for a writer.
    handle = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    with os.fdopen(handle, "rb") as stream:
        if not stat.S_ISREG(os.fstat(handle).st_mode):
            raise InputError(f"{Path(path).name}: not a regular file")
        while block := stream.read(block_size):
            digest.update(block)
    return digest.hexdigest()
