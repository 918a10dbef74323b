"""One progress bar for every long loop: a tqdm bar on stderr, or nothing.

:func:`progress_bar` is the one place the package starts a bar. tqdm is
imported only when a bar is shown, and a disabled bar is an object with the
same two methods that does nothing, so callers never branch on ``enabled``.
Bars go to stderr and never change what a function returns or writes.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator
from typing import Any, Protocol

__all__ = ["Bar", "progress_bar"]


class Bar(Protocol):
    """What a caller may do with a bar: count done items and show extra fields."""

    def update(self, n: int = 1) -> Any:
        """Count ``n`` more items as done."""

    def set_postfix(self, *, refresh: bool = True, **fields: Any) -> Any:
        """Show ``fields`` (e.g. ``failed=2``) after the counts."""


class _NoBar:
    """The bar of ``enabled=False``: accepts every call and shows nothing."""

    def update(self, n: int = 1) -> None:
        """Ignore progress."""

    def set_postfix(self, *, refresh: bool = True, **fields: Any) -> None:
        """Ignore the fields."""


@contextlib.contextmanager
def progress_bar(
    *,
    total: int,
    description: str,
    unit: str,
    enabled: bool = True,
    initial: int = 0,
    leave: bool = True,
) -> Iterator[Bar]:
    """A progress bar on stderr over ``total`` items, closed on exit.

    Parameters
    ----------
    total : int
        Items the loop will count.
    description : str
        Text before the bar, e.g. a model or file name.
    unit : str
        Name of one item, e.g. ``"model"`` or ``"view"``.
    enabled : bool
        Show the bar; False yields a bar that does nothing (default: True).
    initial : int
        Items already done when the bar starts, e.g. resumed ones (default: 0).
    leave : bool
        Keep the finished bar on screen; False erases it, for bars nested in
        a longer loop (default: True).

    Yields
    ------
    Bar
        ``update(n)`` and ``set_postfix(**fields)``.
    """
    if not enabled:
        yield _NoBar()
        return
    from tqdm import tqdm

    with tqdm(total=total, initial=initial, desc=description, unit=unit, leave=leave,
              file=sys.stderr) as bar:
        yield bar
