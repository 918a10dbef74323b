"""Old import paths of moved public names, kept working with a deprecation warning.

A module that moved leaves a small module (or a package ``__getattr__``) at
its old path whose attributes are served from the new module, each access
warning once per call site with :class:`DeprecationWarning` that names the
new path.
"""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Callable
from typing import Any

__all__ = ["moved_module"]


def moved_module(old: str, new: str) -> Callable[[str], Any]:
    """A module ``__getattr__`` serving the public names of ``new`` at ``old``.

    Parameters
    ----------
    old : str
        The old dotted module path (the shim's ``__name__``).
    new : str
        The dotted path the names moved to; its ``__all__`` lists them.

    Returns
    -------
    callable
        ``__getattr__(name)``: the attribute of ``new`` with a
        :class:`DeprecationWarning`, or :class:`AttributeError` for a name
        that ``new`` does not export.
    """

    def __getattr__(name: str) -> Any:
        module = importlib.import_module(new)
        if name not in getattr(module, "__all__", ()):
            raise AttributeError(f"module {old!r} has no attribute {name!r}")
        warnings.warn(f"{old}.{name} moved to {new}.{name}; import it from there",
                      DeprecationWarning, stacklevel=2)
        return getattr(module, name)

    return __getattr__
