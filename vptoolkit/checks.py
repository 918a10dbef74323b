"""Argument checks and message helpers shared by every module.

Each check returns the value in its plain Python type or raises an
:class:`~vptoolkit.errors.InputError` whose one-line message starts with the
argument's name, e.g. ``max_faces: must be at least 4, got 2``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from vptoolkit.errors import InputError

__all__ = [
    "as_path",
    "changed_values",
    "check_bool",
    "check_float",
    "check_int",
    "check_int_range",
    "check_keys",
    "check_npy_header",
    "check_suffix",
    "one_line",
    "short_repr",
]

_MAX_MESSAGE_CHARS = 200


def check_int(
    value: object, argument: str, *, minimum: int | None = None, maximum: int | None = None,
    expected: str | None = None, numpy: bool = True,
) -> int:
    """Return ``value`` as an int within ``[minimum, maximum]`` (bools are refused).

    With ``expected`` every refusal reads ``{argument}: expected {expected}, got
    {value}``, e.g. ``seed: expected a non-negative integer, got -1``. With
    ``numpy=False`` numpy integers are refused too (for values kept as given,
    e.g. in JSON records).
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
            or (not numpy and not isinstance(value, int)):
        if expected is not None:
            raise InputError(f"{argument}: expected {expected}, got {short_repr(value)}")
        raise InputError(f"{argument}: expected an integer, got {value!r}")
    number = int(value)
    if expected is not None and ((minimum is not None and number < minimum)
                                 or (maximum is not None and number > maximum)):
        raise InputError(f"{argument}: expected {expected}, got {number}")
    if minimum is not None and number < minimum:
        raise InputError(f"{argument}: must be at least {minimum}, got {number}")
    if maximum is not None and number > maximum:
        raise InputError(f"{argument}: must be at most {maximum}, got {number}")
    return number


def check_float(
    value: object, argument: str, *, expected: str, minimum: float | None = None,
    maximum: float | None = None, above: float | None = None, below: float | None = None,
) -> float:
    """Return ``value`` as a float if it is a finite int or float within the bounds.

    ``minimum`` and ``maximum`` are inclusive, ``above`` and ``below``
    exclusive; bools are refused. A refusal reads ``{argument}: expected
    {expected}, got {value!r}``, e.g. ``lr: expected a positive finite number, got nan``.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value) \
            or (minimum is not None and value < minimum) \
            or (maximum is not None and value > maximum) \
            or (above is not None and value <= above) \
            or (below is not None and value >= below):
        raise InputError(f"{argument}: expected {expected}, got {value!r}")
    return float(value)


def check_int_range(value: object, argument: str, low: int, high: int) -> int:
    """Return ``value`` as an int from ``low`` to ``high``; the message states the range.

    E.g. ``budget: expected an integer from 1 to 100000, got 0`` (bools are refused).
    """
    return check_int(value, argument, minimum=low, maximum=high,
                     expected=f"an integer from {low} to {high}")


def check_keys(record: object, keys: Sequence[str], what: str, *,
               missing_ok: bool = False) -> dict[str, Any]:
    """Return ``record`` as a new dict if it is a mapping with exactly ``keys``.

    Else name what is missing or unknown, e.g. ``measure settings: missing
    backend; unknown n_views``. With ``missing_ok`` only unknown keys are
    refused (a record whose absent keys take their defaults).
    """
    if not isinstance(record, Mapping):
        raise InputError(f"{what}: expected a mapping, got {type(record).__name__}")
    missing = [] if missing_ok else [key for key in keys if key not in record]
    unknown = sorted(set(record) - set(keys))
    if missing or unknown:
        problems = ([f"missing {', '.join(missing)}"] if missing else []) + (
            [f"unknown {', '.join(unknown)}"] if unknown else [])
        raise InputError(f"{what}: {'; '.join(problems)}")
    return dict(record)


def changed_values(before: Mapping[str, Any], now: Mapping[str, Any]) -> dict[str, tuple[Any, Any]]:
    """Each key of ``now`` whose value is not that of ``before``: key to ``(before, now)``.

    Nested mappings are compared key by key, named ``outer.inner``; a key
    ``before`` lacks compares as None, and keys only ``before`` has are not
    listed. E.g. ``{"measure.views": (1000, 500)}`` for two option records.
    """
    changed: dict[str, tuple[Any, Any]] = {}
    for key, value in now.items():
        old = before.get(key)
        if isinstance(value, Mapping) and isinstance(old, Mapping):
            changed.update({f"{key}.{inner}": pair
                            for inner, pair in changed_values(old, value).items()})
        elif old != value:
            changed[key] = (old, value)
    return changed


def check_bool(value: object, argument: str) -> bool:
    """Return ``value`` as a bool; only True and False (or numpy bools) pass."""
    if not isinstance(value, (bool, np.bool_)):
        raise InputError(f"{argument}: expected True or False, got {value!r}")
    return bool(value)


def as_path(value: str | os.PathLike[str], argument: str) -> Path:
    """Return ``value`` as a Path; other types raise an InputError naming ``argument``."""
    try:
        return Path(os.fspath(value))
    except TypeError as err:
        raise InputError(
            f"{argument}: expected a str or os.PathLike, got {type(value).__name__}"
        ) from err


def one_line(error: BaseException | str) -> str:
    """Fold an error (or text) into one line of at most 200 characters.

    Line breaks and the ``<br>`` tags of pymeshlab's messages become spaces; an
    error without a message is named by its type.
    """
    text = " ".join(str(error).replace("<br>", " ").split())
    if not text:
        return type(error).__name__ if isinstance(error, BaseException) else "no details"
    if len(text) > _MAX_MESSAGE_CHARS:
        return text[: _MAX_MESSAGE_CHARS - 3] + "..."
    return text


def short_repr(value: object, limit: int = 40) -> str:
    """``repr(value)`` cut to ``limit`` characters, for a message quoting a maybe huge value."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def check_npy_header(stream: BinaryIO, label: str, n_bytes: int) -> None:
    """Refuse an ``.npy`` stream whose header claims more data than it holds.

    ``np.load`` trusts the header and allocates the whole array first, so a
    damaged or hostile header (e.g. a shape of 8.7 TiB) would exhaust memory
    before any read fails. The stream is left where it was.

    Parameters
    ----------
    stream : binary file object
        Positioned at the start of the ``.npy`` data (its magic string).
    label : str
        The file (or ``archive:member``) named in the message.
    n_bytes : int
        Bytes of the ``.npy`` data, header included.

    Raises
    ------
    InputError
        If the header is unreadable, holds objects (pickles), or its shape and
        dtype need more bytes than ``n_bytes`` leaves after the header.
    """
    start = stream.tell()
    try:
        version = np.lib.format.read_magic(stream)
        reader = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                  else np.lib.format.read_array_header_2_0)
        shape, _, dtype = reader(stream)
        header_bytes = stream.tell() - start
    except (ValueError, OSError, EOFError, SyntaxError) as err:
        raise InputError(f"{label}: not a readable .npy array ({one_line(err)})") from err
    finally:
        stream.seek(start)
    if dtype.hasobject:
        raise InputError(f"{label}: .npy array holds Python objects; they are never unpickled "
                         "(allow_pickle=False)")
    needed = math.prod(shape) * dtype.itemsize
    available = n_bytes - header_bytes
    if needed > available:
        raise InputError(
            f"{label}: .npy header claims shape {tuple(shape)} of {dtype} ({needed:,} bytes) "
            f"but the file holds {max(available, 0):,}"
        )


def check_suffix(path: str | os.PathLike[str], suffix: str, *, what: str = "output") -> Path:
    """Return ``path`` as a Path if it ends in ``suffix`` (any case), else raise.

    The message names the file: ``out.txt: output must end in .npz``.
    """
    target = Path(path)
    if target.suffix.lower() != suffix.lower():
        raise InputError(f"{target.name}: {what} must end in {suffix}")
    return target
