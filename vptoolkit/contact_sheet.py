"""Moved to :mod:`vptoolkit.pictures.contact_sheet`; importable here for one release."""

from vptoolkit.pictures.contact_sheet import contact_sheet, view_set_captions, view_set_sheet

__all__ = ["contact_sheet", "view_set_captions", "view_set_sheet"]
