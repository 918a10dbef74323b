"""Deprecated: moved to :mod:`vptoolkit.dataset.build.plan`; importing from here warns."""

from vptoolkit.deprecation import moved_module

__getattr__ = moved_module(__name__, "vptoolkit.dataset.build.plan")
