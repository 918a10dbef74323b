"""Lazy access to optional heavy packages (open3d, torch, pymeshlab, numba).

Nothing here imports a heavy package at module import time. Call
:func:`require` inside the function that needs the package::

    o3d = require("open3d", extra="measures")

A missing package raises :class:`~vptoolkit.errors.MissingDependencyError`
naming the pip command that installs it.
"""

from __future__ import annotations

import importlib
import importlib.util
from types import ModuleType

from vptoolkit.errors import MissingDependencyError

__all__ = ["require", "is_available"]

# pip distribution name for each importable module, where they differ.
_DISTRIBUTIONS = {"open3d": "open3d-cpu"}


def is_available(module: str) -> bool:
    """Return whether ``module`` can be imported, without importing it."""
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def require(module: str, *, extra: str | None = None) -> ModuleType:
    """Import and return ``module`` or raise a one-line install hint.

    Parameters
    ----------
    module : str
        Importable module name, e.g. ``"open3d"``.
    extra : str, optional
        The vptoolkit extra that provides it (``pip install 'vptoolkit[extra]'``).

    Raises
    ------
    MissingDependencyError
        If the module is not installed or fails to import (the import error is
        chained as the cause, never swallowed).
    """
    try:
        return importlib.import_module(module)
    except ImportError as err:
        hint = (
            f"pip install 'vptoolkit[{extra}]'"
            if extra
            else f"pip install {_DISTRIBUTIONS.get(module, module)}"
        )
        raise MissingDependencyError(
            f"{module}: not importable ({err}); install it with {hint}"
        ) from err
