"""Moved to :mod:`vptoolkit.pictures.thumbnails`; importable here for one release."""

from vptoolkit.pictures.thumbnails import ThumbnailFailure, ThumbnailResult, render_thumbnails

__all__ = ["ThumbnailFailure", "ThumbnailResult", "render_thumbnails"]
