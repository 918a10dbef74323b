"""The entries of a collection: a folder, a glob or a list file, streamed and keyed.

:func:`discover` yields one :class:`Entry` per model file of a source, never
listing the source whole in memory:

- a **folder** is walked recursively with :func:`os.scandir`, each folder's
  names sorted (so the walk is deterministic), hidden files and folders
  (a name starting with ``.``) and symbolic links to folders skipped;
- a **glob** (a path with ``*``, ``?`` or ``[``) is the folder walk of its
  part before the first pattern component, keeping the files whose path
  relative to it matches the rest (``**`` matches any number of folders);
- a **model file** is the one entry of its own name;
- a **list file**, given as ``@list.txt``, holds one path or URL per line
  (blank lines and lines starting with ``#`` skipped), read line by line;
  a relative path is relative to the list file's folder.

A model file is one whose suffix, in any letter case, is in
:data:`vptoolkit.io.MODEL_SUFFIXES` (meshes and point clouds).
An entry's key is its path relative to the root given (the folder, the
glob's fixed part, or the list file's folder), with POSIX separators, so ``coll/a/teapot.stl`` and
``coll/b/teapot.stl`` are the entries ``a/teapot.stl`` and ``b/teapot.stl``;
a list line that is a URL or leaves the root (an absolute path, ``..``) is
its own key, as written. Entries come in the walk's order (a list's in its
line order); a list names whatever it names, so a line whose file is not a
model file is still an entry (its run records why it failed).
"""

from __future__ import annotations

import fnmatch
import os
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from vptoolkit.errors import InputError
from vptoolkit.io import MODEL_SUFFIXES

__all__ = ["Entry", "discover", "is_model_file", "is_remote_entry"]

LIST_PREFIX = "@"
"""A source starting with this is a list file: ``@models.txt``."""

_PATTERN = re.compile(r"[*?\[]")
_URL = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*://")


@dataclass(frozen=True)
class Entry:
    """One model file of a collection.

    Attributes
    ----------
    path : str
        Where to read it: a local path, or a URL as the list wrote it.
    key : str
        Its path relative to the root given, POSIX separators (see the
        module docstring): the entry's name in every output.
    """

    path: str
    key: str


def is_model_file(name: str) -> bool:
    """Whether a file name has a mesh or point-cloud suffix (any letter case)."""
    suffix = PurePosixPath(name).suffix.lower()
    return suffix in MODEL_SUFFIXES


def is_remote_entry(path: str) -> bool:
    """Whether an entry's path is a URL (``scheme://...``)."""
    return bool(_URL.match(path))


def discover(source: str | os.PathLike[str]) -> Iterator[Entry]:
    """Yield the entries of a folder, a glob or a list file (``@list.txt``), streamed.

    Parameters
    ----------
    source : str or path-like
        A folder, a glob pattern, one model file, or ``@`` and a list file
        (see the module docstring).

    Yields
    ------
    Entry
        In the walk's order (a list's in its line order).

    Raises
    ------
    InputError
        If the folder, the glob's fixed part or the list file does not
        exist, or ``source`` is a single file that is no model file.
    """
    text = os.fspath(source)
    if text.startswith(LIST_PREFIX):
        yield from _listed(Path(text[len(LIST_PREFIX):]))
        return
    if _PATTERN.search(text):
        yield from _globbed(text)
        return
    root = Path(text)
    if root.is_dir():
        yield from (Entry(os.path.join(text, key), key) for key in _walk(root, ""))
        return
    if root.is_file():
        if not is_model_file(root.name):
            raise InputError(f"{text}: not a model file; give a model file, a folder, a glob "
                             "or @list.txt (a list file of paths or URLs)")
        yield Entry(text, root.name)
        return
    raise InputError(f"{text}: no such folder")


def _walk(folder: Path, prefix: str) -> Iterator[str]:
    """Keys (``prefix`` + name) of the model files below ``folder``, each folder sorted."""
    try:
        with os.scandir(folder) as listing:
            names = sorted((item.name, item.is_dir(follow_symlinks=False)) for item in listing
                           if not item.name.startswith("."))
    except OSError as err:
        raise InputError(f"{folder}: cannot list ({err.strerror or err})") from err
    for name, is_folder in names:
        if is_folder:
            yield from _walk(folder / name, f"{prefix}{name}/")
        elif is_model_file(name):
            yield f"{prefix}{name}"


def _globbed(pattern: str) -> Iterator[Entry]:
    parts = PurePosixPath(pattern.replace(os.sep, "/")).parts
    fixed = next(index for index, part in enumerate(parts) if _PATTERN.search(part))
    root = PurePosixPath(*parts[:fixed]) if fixed else PurePosixPath(".")
    if not Path(root).is_dir():
        raise InputError(f"{pattern}: no such folder {root}")
    rest = parts[fixed:]
    for key in _walk(Path(root), ""):
        if _matches(tuple(key.split("/")), rest):
            yield Entry(str(Path(root) / key), key)


def _matches(names: tuple[str, ...], patterns: tuple[str, ...]) -> bool:
    """Whether path components match pattern components; ``**`` matches any number of them."""
    if not patterns:
        return not names
    if patterns[0] == "**":
        return any(_matches(names[skip:], patterns[1:]) for skip in range(len(names) + 1))
    return bool(names) and fnmatch.fnmatchcase(names[0], patterns[0]) and _matches(
        names[1:], patterns[1:])


def _listed(list_file: Path) -> Iterator[Entry]:
    if not list_file.is_file():
        raise InputError(f"{LIST_PREFIX}{list_file}: no such list file")
    base = list_file.parent
    try:
        with list_file.open(encoding="utf-8") as lines:
            for number, line in enumerate(lines, start=1):
                written = line.strip()
                if not written or written.startswith("#"):
                    continue
                yield _listed_entry(written, base)
    except UnicodeDecodeError as err:
        raise InputError(f"{list_file}: not UTF-8 text ({err.reason} near line "
                         f"{number + 1})") from err


def _listed_entry(written: str, base: Path) -> Entry:
    if is_remote_entry(written):
        return Entry(written, written)
    posix = written.replace(os.sep, "/")
    relative = PurePosixPath(posix)
    if relative.is_absolute() or ".." in relative.parts:
        return Entry(written, posix)
    return Entry(str(base / relative), relative.as_posix())
