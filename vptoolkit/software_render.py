"""Moved to :mod:`vptoolkit.pictures.software_engine`; importable here for one release."""

from vptoolkit.pictures.software_engine import SoftwareRenderer

__all__ = ["SoftwareRenderer"]
