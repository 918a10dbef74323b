"""Moved to :mod:`vptoolkit.pictures.shading`; importable here for one release."""

from vptoolkit.pictures.shading import (
    CreaseNormals,
    RenderStyle,
    crease_normals,
    light_direction,
    linear_to_srgb,
    picture_camera,
    srgb_to_linear,
)

__all__ = [
    "RenderStyle",
    "CreaseNormals",
    "crease_normals",
    "picture_camera",
    "light_direction",
    "srgb_to_linear",
    "linear_to_srgb",
]
