"""Moved to :mod:`vptoolkit.pictures.sphere_map`; importable here for one release."""

from vptoolkit.pictures.sphere_map import (
    BEST_COLOR,
    PREDICTED_COLOR,
    VIEW_SET_COLOR,
    mercator_y,
    save_figure,
    sphere_grid,
    sphere_map,
    sphere_map_file,
    sphere_maps,
    view_coordinates,
)

__all__ = [
    "BEST_COLOR",
    "PREDICTED_COLOR",
    "VIEW_SET_COLOR",
    "view_coordinates",
    "mercator_y",
    "sphere_grid",
    "sphere_map",
    "sphere_maps",
    "save_figure",
    "sphere_map_file",
]
