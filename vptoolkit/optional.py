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

__all__ = ["require", "is_available", "install_hint", "EXTRAS"]

# pip distribution name for each importable module, where they differ.
_DISTRIBUTIONS = {"open3d": "open3d-cpu", "PIL": "pillow"}

EXTRAS = {
    "numba": "measures",
    "trimesh": "measures",
    "open3d": "measures",
    "scipy": "measures",
    "pymeshlab": "clean",
    "zarr": "dataset",
    "pyarrow": "dataset",
    "distributed": "cluster",
    "dask": "cluster",
    "torch": "learn",
    "safetensors": "learn",
    "matplotlib": "pictures",
    "PIL": "pictures",
    "fsspec": "remote",
    "laspy": "las",
}
"""The vptoolkit extra that installs each optional top-level module.

A plain ``pip install vptoolkit`` holds only the reader (numpy, click, tqdm,
h5py); ``pip install 'vptoolkit[all]'`` installs every extra.
"""


def install_hint(module: str, extra: str | None = None) -> str:
    """Return the pip command that installs ``module``.

    Parameters
    ----------
    module : str
        Importable module name; only its top-level package is looked up.
    extra : str, optional
        The extra to name (default: the one :data:`EXTRAS` gives, else the
        package itself).

    Examples
    --------
    >>> install_hint("open3d.core")
    "pip install 'vptoolkit[measures]'"
    >>> install_hint("h5py")
    'pip install h5py'
    """
    top = module.split(".")[0]
    chosen = extra or EXTRAS.get(top)
    if chosen:
        return f"pip install 'vptoolkit[{chosen}]'"
    return f"pip install {_DISTRIBUTIONS.get(top, top)}"


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
        hint = install_hint(module, extra)
        raise MissingDependencyError(
            f"{module}: not importable ({err}); install it with {hint}"
        ) from err
