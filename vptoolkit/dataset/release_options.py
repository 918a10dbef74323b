"""Deprecated: moved to :mod:`vptoolkit.dataset.release.options`; importing from here warns."""

from vptoolkit.deprecation import moved_module

__getattr__ = moved_module(__name__, "vptoolkit.dataset.release.options")
