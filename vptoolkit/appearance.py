"""How a model looks, kept apart from its geometry: colours, texture coordinates, texture.

The readers of :mod:`vptoolkit.io` fill an :class:`Appearance` when asked
(:func:`vptoolkit.io.load_with_appearance`); only the picture code reads it.
Geometry (:class:`~vptoolkit.mesh.Mesh`, :class:`~vptoolkit.point_cloud.PointCloud`)
never carries it, so no measure, cleaning step or network can depend on a
colour, and a model that is cleaned or resampled simply has no appearance.

Every array is indexed like the geometry it was read with: ``vertex_colors``
by vertex (or point), ``face_colors`` and ``corner_uv`` by the triangles of
the mesh after the loader's fan triangulation.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.errors import InputError

__all__ = ["Appearance"]


@dataclass(frozen=True, eq=False)
class Appearance:
    """The colours and texture of one model, each None when the file has none.

    Parameters
    ----------
    vertex_colors : (n_vertices, 4) uint8 or None
        RGBA per vertex of a mesh, or per point of a point cloud (0..255,
        sRGB as stored; alpha 255 when the file has none).
    face_colors : (n_faces, 4) uint8 or None
        RGBA per triangle (a polygon's colour repeats over its triangles).
    base_color : (4,) float64 or None
        One RGBA in 0..1 for the whole model: glTF's ``baseColorFactor``, an
        OBJ material's ``Kd`` (alpha from ``d``), when the model has one material.
    corner_uv : (n_faces, 3, 2) float64 or None
        Texture coordinates per triangle corner, ``(u, v)`` with ``(0, 0)`` the
        bottom-left corner of ``texture`` and ``(1, 1)`` its top-right (the
        OBJ and OpenGL convention; glTF's top-left origin is flipped on
        reading). NaN for triangles without texture coordinates.
    texture : (height, width, 4) uint8 or None
        The base-colour image, RGBA, its first row the top of the image.

    Raises
    ------
    InputError
        If an array has the wrong shape or dtype.
    """

    vertex_colors: NDArray[np.uint8] | None = None
    face_colors: NDArray[np.uint8] | None = None
    base_color: NDArray[np.float64] | None = None
    corner_uv: NDArray[np.float64] | None = None
    texture: NDArray[np.uint8] | None = None

    def __post_init__(self) -> None:
        shapes: dict[str, tuple[tuple[int | None, ...], Any]] = {
            "vertex_colors": ((None, 4), np.uint8),
            "face_colors": ((None, 4), np.uint8),
            "base_color": ((4,), np.float64),
            "corner_uv": ((None, 3, 2), np.float64),
            "texture": ((None, None, 4), np.uint8),
        }
        for item in fields(self):
            value = getattr(self, item.name)
            if value is None:
                continue
            shape, dtype = shapes[item.name]
            array = np.asarray(value)
            if array.dtype != dtype or array.ndim != len(shape) or any(
                    want is not None and got != want for got, want in zip(array.shape, shape)):
                expected = ", ".join("n" if size is None else str(size) for size in shape)
                raise InputError(f"appearance: {item.name} must be ({expected}) "
                                 f"{np.dtype(dtype).name}, got {array.shape} {array.dtype}")
            array = array.copy()
            array.setflags(write=False)
            object.__setattr__(self, item.name, array)

    @property
    def is_empty(self) -> bool:
        """Whether the model has no colour and no texture at all."""
        return all(getattr(self, item.name) is None for item in fields(self))
