"""The triangle mesh container of vptoolkit, and other libraries' meshes turned into it.

Every public function that takes a mesh takes a :data:`MeshLike`: a
:class:`Mesh`, a ``trimesh.Trimesh``, an Open3D ``TriangleMesh`` or a
``(vertices, faces)`` tuple, converted once at its entry by :func:`as_mesh`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, TypeAlias, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.errors import InputError

__all__ = ["MAX_COORDINATE", "MIN_COORDINATE", "Mesh", "MeshLike", "as_mesh",
           "check_coordinate_range"]

MAX_COORDINATE = 1e38
"""Largest coordinate magnitude a mesh may have: float32 (points, stored meshes) ends at 3.4e38.

Below it every product the measures, the cleaning and the sampling form
(cross products, squared lengths) stays finite in float64.
"""

MIN_COORDINATE = 1e-37
"""Smallest magnitude the largest coordinate of a mesh or point cloud may have.

float32 (points, stored meshes) holds full precision down to 1.2e-38; a
smaller shape would be stored (and then verified) as zeros or as a few
subnormal steps. A shape whose coordinates are all exactly zero is left to
the checks for a shape without extent.
"""


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh as plain arrays.

    Parameters
    ----------
    vertices : (n_vertices, 3) float64
        Vertex positions in model units.
    faces : (n_faces, 3) int64
        Vertex indices per triangle, counter-clockwise seen from the front
        (outward normals by the right-hand rule).
    name : str
        A label for messages and outputs, usually the file stem (default: "mesh").

    Raises
    ------
    InputError
        If the arrays have the wrong shape, hold non-finite coordinates or
        coordinates beyond :data:`MAX_COORDINATE` in magnitude, there
        are no faces, or a face index is out of range. The message starts with
        ``name``.
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    name: str = field(default="mesh")

    def __post_init__(self) -> None:
        vertices = _as_array(self.vertices, np.float64, self.name, "vertices")
        faces = _as_array(self.faces, np.int64, self.name, "faces")
        if vertices.ndim != 2 or vertices.shape[1] != 3:
            raise InputError(f"{self.name}: vertices must have shape (n, 3), got {vertices.shape}")
        if faces.ndim != 2 or faces.shape[1] != 3:
            raise InputError(f"{self.name}: faces must have shape (n, 3), got {faces.shape}")
        if len(faces) == 0:
            raise InputError(f"{self.name}: mesh has no faces")
        if not np.isfinite(vertices).all():
            n_bad = int((~np.isfinite(vertices).all(axis=1)).sum())
            raise InputError(f"{self.name}: {n_bad} vertices have NaN or infinite coordinates")
        check_coordinate_range(vertices, self.name, "mesh")
        low, high = int(faces.min()), int(faces.max())
        if low < 0 or high >= len(vertices):
            bad = low if low < 0 else high
            raise InputError(
                f"{self.name}: face index {bad} out of range for {len(vertices)} vertices"
            )
        vertices.setflags(write=False)
        faces.setflags(write=False)
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(self, "faces", faces)

    @property
    def n_vertices(self) -> int:
        """Number of vertices."""
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        """Number of triangles."""
        return int(self.faces.shape[0])

    def __repr__(self) -> str:
        return f"Mesh(name={self.name!r}, n_vertices={self.n_vertices}, n_faces={self.n_faces})"


class _FaceListMesh(Protocol):
    """A mesh with ``vertices`` and ``faces`` arrays, as ``trimesh.Trimesh``."""

    @property
    def vertices(self) -> Any: ...

    @property
    def faces(self) -> Any: ...


class _TriangleListMesh(Protocol):
    """A mesh with ``vertices`` and ``triangles`` vectors, as Open3D's ``TriangleMesh``."""

    @property
    def vertices(self) -> Any: ...

    @property
    def triangles(self) -> Any: ...


MeshLike: TypeAlias = "Mesh | _FaceListMesh | _TriangleListMesh | tuple[ArrayLike, ArrayLike]"
"""What a function that takes a mesh accepts; :func:`as_mesh` converts it."""


def as_mesh(mesh: MeshLike, name: str | None = None) -> Mesh:
    """The :class:`Mesh` of a vptoolkit, trimesh or Open3D mesh or of ``(vertices, faces)``.

    The type is recognised by its attributes, so neither trimesh nor Open3D
    is imported:

    * a :class:`Mesh` (or subclass) is returned as it is;
    * an object with ``vertices`` and ``faces`` (``trimesh.Trimesh``): its
      ``(n_vertices, 3)`` float and ``(n_faces, 3)`` int arrays;
    * an object with ``vertices`` and ``triangles`` (Open3D's legacy
      ``open3d.geometry.TriangleMesh``): its ``Vector3dVector`` and
      ``Vector3iVector``, read with ``np.asarray``;
    * a tuple ``(vertices, faces)`` of array_likes of those shapes.

    Vertices are copied to float64 and faces to int64; the winding is kept
    (counter-clockwise seen from the front is the convention of all three).

    Parameters
    ----------
    mesh : MeshLike
        The mesh.
    name : str, optional
        Name of a converted mesh, first in its messages (default: "mesh");
        a :class:`Mesh` keeps its own.

    Returns
    -------
    Mesh

    Raises
    ------
    InputError
        ``mesh: expected a vptoolkit Mesh, a trimesh.Trimesh, an Open3D
        TriangleMesh or (vertices, faces), got str`` for anything else, or the
        :class:`Mesh` check's message for bad arrays.
    """
    if isinstance(mesh, Mesh):
        return mesh
    label = "mesh" if name is None else name
    if isinstance(mesh, tuple) and len(mesh) == 2:
        vertices, faces = mesh  # array_likes: Mesh converts them and names what it cannot read
        return Mesh(cast("NDArray[np.float64]", vertices), cast("NDArray[np.int64]", faces),
                    name=label)
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        return Mesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), name=label)
    if hasattr(mesh, "vertices") and hasattr(mesh, "triangles"):
        return Mesh(np.asarray(mesh.vertices), np.asarray(mesh.triangles), name=label)
    got = (f"a tuple of {len(mesh)} items" if isinstance(mesh, tuple)
           else type(mesh).__qualname__)
    raise InputError("mesh: expected a vptoolkit Mesh, a trimesh.Trimesh, an Open3D "
                     f"TriangleMesh or (vertices, faces), got {got}")


def check_coordinate_range(coordinates: NDArray[np.float64], name: str, what: str) -> None:
    """Refuse finite coordinates that float32 cannot hold (see MAX_ and MIN_COORDINATE).

    Parameters
    ----------
    coordinates : (n, 3) float
        Finite vertex or point coordinates.
    name : str
        The file or mesh named first in the message.
    what : str
        ``"mesh"`` or ``"point cloud"``, the thing to rescale.

    Raises
    ------
    InputError
        ``name: coordinates up to 1e+300 overflow the float32 ...; rescale the mesh``
        or ``name: coordinates of at most 1e-46 underflow the float32 ...``.
    """
    largest = float(np.abs(coordinates).max()) if coordinates.size else 0.0
    if largest > MAX_COORDINATE:
        raise InputError(
            f"{name}: coordinates up to {largest:.3g} overflow the float32 of points, "
            f"stored meshes and pictures (limit {MAX_COORDINATE:.0e}); rescale the {what}"
        )
    if 0.0 < largest < MIN_COORDINATE:
        raise InputError(
            f"{name}: coordinates of at most {largest:.3g} underflow the float32 of points, "
            f"stored meshes and pictures (limit {MIN_COORDINATE:.0e}); rescale the {what}"
        )


def _as_array(values: ArrayLike, dtype: type, name: str, what: str) -> NDArray[Any]:
    try:
        return np.array(values, dtype=dtype, copy=True)
    except (TypeError, ValueError) as err:
        raise InputError(f"{name}: {what} cannot be read as {np.dtype(dtype).name}: {err}") from err
