"""Moved to :mod:`vptoolkit.pictures` (engine, open3d_engine, views, png) for one release."""

from vptoolkit.pictures.engine import ENGINES, open_renderer
from vptoolkit.pictures.engine import Engine as AnyRenderer  # noqa: F401 (the old name)
from vptoolkit.pictures.open3d_engine import Renderer, check_renderer
from vptoolkit.pictures.png import png_bytes, save_png
from vptoolkit.pictures.shading import RenderStyle
from vptoolkit.pictures.views import (
    DirectionSource,
    RenderedView,
    render_best,
    render_predicted,
    render_view,
    render_views,
    resolve_direction,
)

__all__ = [
    "RenderStyle",
    "Renderer",
    "RenderedView",
    "DirectionSource",
    "render_view",
    "render_views",
    "render_best",
    "render_predicted",
    "resolve_direction",
    "check_renderer",
    "ENGINES",
    "open_renderer",
    "png_bytes",
    "save_png",
]
