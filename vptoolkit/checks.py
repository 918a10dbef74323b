"""Argument checks and message helpers shared by every module.

Each check returns the value in its plain Python type or raises an
:class:`~vptoolkit.errors.InputError` whose one-line message starts with the
argument's name, e.g. ``max_faces: must be at least 4, got 2``.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from vptoolkit.errors import InputError

__all__ = ["as_path", "check_bool", "check_int", "one_line"]

_MAX_MESSAGE_CHARS = 200


def check_int(
    value: object, argument: str, *, minimum: int | None = None, maximum: int | None = None
) -> int:
    """Return ``value`` as an int within ``[minimum, maximum]`` (bools are refused)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InputError(f"{argument}: expected an integer, got {value!r}")
    if minimum is not None and value < minimum:
        raise InputError(f"{argument}: must be at least {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise InputError(f"{argument}: must be at most {maximum}, got {value}")
    return int(value)


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
