"""Moved to :mod:`vptoolkit.pictures.report`; importable here for one release."""

from vptoolkit.pictures.report import write_report

__all__ = ["write_report"]
