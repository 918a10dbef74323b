"""Read models (meshes and point clouds) and write meshes.

Meshes: OFF, OBJ, PLY, STL, glTF, GLB. Points only: NPY, NPZ, XYZ, XYZN,
XYZRGB, PTS, PCD, LAS and LAZ (:data:`POINT_SUFFIXES`).

:func:`load` is the one reader of a model: it turns a file, or another
library's object, into a :class:`~vptoolkit.mesh.Mesh` or a
:class:`~vptoolkit.point_cloud.PointCloud`, decided by what it holds, not by
its suffix: a PLY, OBJ or OFF with faces is a mesh, one with vertices and no
faces is a point cloud (as trimesh's loader decides), a points-only
format is always one. A point cloud larger than ``max_points`` is thinned,
with a warning, given once per file and ``max_points`` in a process
(:func:`load`). :func:`require_surface` is the one check (and message) where
a surface is needed, and :func:`load_mesh` is the two together.
:func:`load_with_appearance` also returns the
:class:`~vptoolkit.appearance.Appearance` (colours, texture coordinates,
texture) the same file holds; only the picture code reads it, and it is a
separate function, not a flag of :func:`load`, so that each returns one type.
:func:`save_mesh` writes a mesh back.

OFF, OBJ, PLY and STL are read by small numpy readers, one module per format
(:mod:`~vptoolkit.io.off`, :mod:`~vptoolkit.io.obj`, :mod:`~vptoolkit.io.ply`,
:mod:`~vptoolkit.io.stl`), that keep the file's vertices in file order (no
merging, no splitting by texture coordinates) and check the counts a header
declares. glTF and GLB scenes go through trimesh (:mod:`~vptoolkit.io.gltf`),
imported on first use, and are flattened with every node transform applied.
Point-only files are read by :mod:`~vptoolkit.io.point_files`, and other
libraries' objects converted by :mod:`~vptoolkit.io.objects`; texture
images are decoded by :mod:`~vptoolkit.io.images`. The readers
return a :class:`~vptoolkit.io._polygons.Reading` of plain arrays; this module
checks it and builds the model and its appearance. The readers share the
private :mod:`~vptoolkit.io._polygons` (polygon lists, number parsing, errors,
and the checks and fan triangulation this module applies).

Polygons with more than three vertices are fan-triangulated: ``(a, b, c, d)``
becomes ``(a, b, c)`` and ``(a, c, d)``, in file order. OBJ and PLY faces with
fewer than three vertices (points and lines) are skipped; in OFF they are an
error, as they mostly mean that the header counts are wrong. Cleaning
degenerate or duplicate faces is not the loader's business, and unused
vertices are kept.

Every problem with a file raises :class:`~vptoolkit.errors.MeshLoadError`
whose one-line message starts with the file name, e.g.
``chair.off: header declares 1200 faces, file has 1187``.
"""

from __future__ import annotations

import logging
import os
import stat
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from vptoolkit.appearance import Appearance
from vptoolkit.checks import as_path, check_int, one_line
from vptoolkit.errors import InputError, MeshLoadError, MissingDependencyError
from vptoolkit.files import write_bytes_atomic
from vptoolkit.io import gltf, obj, off, ply, stl
from vptoolkit.io._polygons import FormatError, Reading, check_and_triangulate, triangle_rows
from vptoolkit.io.objects import model_of
from vptoolkit.io.point_files import PATH_SUFFIXES, POINT_READERS
from vptoolkit.mesh import Mesh, MeshLike, as_mesh
from vptoolkit.point_cloud import MAX_POINTS, PointCloud, voxel_subset

__all__ = ["MODEL_SUFFIXES", "POINT_SUFFIXES", "SUPPORTED_SUFFIXES", "WRITABLE_SUFFIXES",
           "find_mesh_files", "find_model_files", "load", "load_mesh", "load_with_appearance",
           "require_surface", "save_mesh"]

#: Suffixes of the formats that hold meshes, read by :func:`load` and :func:`load_mesh`
#: (compared case-insensitively); PLY, OBJ and OFF may hold points only.
SUPPORTED_SUFFIXES: tuple[str, ...] = (".off", ".obj", ".ply", ".stl", ".glb", ".gltf")

#: Suffixes of the formats that hold points only, read by :func:`load`
#: (:mod:`~vptoolkit.io.point_files`; LAS and LAZ need the ``las`` extra).
POINT_SUFFIXES: tuple[str, ...] = tuple(POINT_READERS)

#: Every suffix :func:`load` reads.
MODEL_SUFFIXES: tuple[str, ...] = SUPPORTED_SUFFIXES + POINT_SUFFIXES

#: File suffixes :func:`save_mesh` writes (compared case-insensitively).
WRITABLE_SUFFIXES: tuple[str, ...] = (".off", ".ply", ".obj", ".stl")

_log = logging.getLogger(__name__)

_thinning_warned: set[tuple[str, int, int]] = set()
"""``(absolute path, points read, max_points)`` of every thinning warned of in this process:
a file read again the same way (a check before the work, a picture's colours) warns once."""

_FORMAT_LABELS = {".gltf": "glTF"}
"""Format names in messages where the upper-case suffix is not the name."""


def _points_only(read: Callable[[Path, bytes], Reading], path: Path, data: bytes,
                 appearance: bool) -> Reading:
    """A points-only reader called as the others are (it reads colours either way)."""
    return read(path, data)


#: The reader of each suffix, given the file's path, its bytes and whether the
#: appearance is wanted (OBJ reads its material files only then).
_READERS: dict[str, Callable[[Path, bytes, bool], Reading]] = {
    ".off": lambda path, data, look: off.read_off(data),
    ".obj": lambda path, data, look: obj.read_obj(data, path.parent if look else None),
    ".ply": lambda path, data, look: ply.read_ply(data),
    ".stl": lambda path, data, look: stl.read_stl(data),
    ".glb": lambda path, data, look: gltf.read_gltf(path, data),
    ".gltf": lambda path, data, look: gltf.read_gltf(path, data),
    **{suffix: partial(_points_only, read) for suffix, read in POINT_READERS.items()},
}


def find_mesh_files(folder: str | os.PathLike[str]) -> list[Path]:
    """The mesh files below a folder, in sorted order.

    A mesh file is one whose suffix is in :data:`SUPPORTED_SUFFIXES` (any
    letter case). Hidden files and everything in hidden folders (a name
    starting with ``.``, below ``folder``) are skipped, e.g. editor backups and
    partial downloads; ``folder`` itself may be hidden. Symbolic links to
    folders are not followed.

    Parameters
    ----------
    folder : str or os.PathLike
        The folder searched, recursively.

    Returns
    -------
    list of Path
        ``folder / relative path`` for every mesh file, sorted.

    Raises
    ------
    InputError
        If ``folder`` is not an existing folder.
    """
    return _find_files(folder, SUPPORTED_SUFFIXES)


def find_model_files(folder: str | os.PathLike[str]) -> list[Path]:
    """The model files below a folder, meshes and point clouds, in sorted order.

    As :func:`find_mesh_files` with every suffix of :data:`MODEL_SUFFIXES`
    (any letter case): what :func:`load` reads as a mesh or a point cloud.

    Raises
    ------
    InputError
        If ``folder`` is not an existing folder.
    """
    return _find_files(folder, MODEL_SUFFIXES)


def _find_files(folder: str | os.PathLike[str], suffixes: tuple[str, ...]) -> list[Path]:
    """``folder / relative path`` of the files below ``folder`` ending in ``suffixes``, sorted,
    hidden files and folders skipped."""
    root = as_path(folder, "folder")
    if not root.is_dir():
        raise InputError(f"{root}: not a folder")
    found: list[Path] = []
    for parent, subfolders, files in os.walk(root):
        subfolders[:] = sorted(name for name in subfolders if not name.startswith("."))
        found.extend(
            Path(parent) / name for name in files
            if not name.startswith(".") and Path(name).suffix.lower() in suffixes
        )
    return sorted(found)


def load(source: str | os.PathLike[str] | Any, *, name: str | None = None,
         max_points: int = MAX_POINTS) -> Mesh | PointCloud:
    """Read a model: a :class:`~vptoolkit.mesh.Mesh` if it has faces, else a point cloud.

    The point cloud is a :class:`~vptoolkit.point_cloud.PointCloud`.

    Parameters
    ----------
    source : str, os.PathLike or a model object
        A file ending in one of :data:`MODEL_SUFFIXES` (any letter case), or
        an object :func:`vptoolkit.io.objects.model_of` converts: a Mesh or
        PointCloud, a ``trimesh.Trimesh``, ``trimesh.PointCloud`` or
        ``trimesh.Scene``, an Open3D ``TriangleMesh`` or ``PointCloud``, an
        ``(N, 3)`` / ``(N, 6)`` array of points (with normals) or a
        ``(vertices, faces)`` tuple. Neither trimesh nor Open3D is imported
        for a file that does not need it.
    name : str, optional
        The name of a model made from an object (default: "mesh" or
        "points"); a file's model is named by its stem.
    max_points : int
        Most points a point cloud file keeps (default:
        :data:`~vptoolkit.point_cloud.MAX_POINTS`, 20 million). A larger
        cloud is thinned to at most this many by
        :func:`~vptoolkit.point_cloud.voxel_subset`, never silently: a
        warning (logger ``vptoolkit.io``) names the file and both counts,
        once per file, point count and ``max_points`` in a process.
        Meshes are never thinned.

    Returns
    -------
    Mesh or PointCloud
        A mesh: ``vertices (n_vertices, 3) float64`` in file order (glTF: all
        scene nodes with their transforms applied), ``faces (n_faces, 3)
        int64`` with polygons fan-triangulated. A point cloud: the vertices
        as ``points`` and the file's per-vertex normals, if any.

    Raises
    ------
    MeshLoadError
        If the file does not exist or cannot be read, has an unknown suffix,
        is empty, holds no vertices, has NaN or infinite coordinates, a face
        index out of range, or cannot be parsed, or its points fail the
        :class:`~vptoolkit.point_cloud.PointCloud` checks. The message starts
        with the file name; a parser's own exception is chained as the cause.
    InputError
        If ``source`` is neither a path nor a model object, or the object's
        arrays fail the checks.
    """
    if not isinstance(source, (str, os.PathLike)):
        return model_of(source, name)
    path = as_path(source, "path")
    max_points = check_int(max_points, "max_points", minimum=1)
    return _model(path, _read(path), max_points)[0]


def load_with_appearance(path: str | os.PathLike[str], *,
                         max_points: int = MAX_POINTS) -> tuple[Mesh | PointCloud, Appearance]:
    """Read a model file and how it looks: :func:`load`'s model and its appearance.

    The appearance is an :class:`~vptoolkit.appearance.Appearance`.

    The appearance's arrays index the model's vertices (or points) and
    triangles: PLY and OFF vertex and face colours, OBJ material colours
    (``Kd``) and texture coordinates with the ``map_Kd`` image, glTF and GLB
    base colours, vertex colours and the base-colour texture of every
    instance placed by its node transform. Decoding a texture image needs
    Pillow (the ``pictures`` extra).

    Parameters
    ----------
    path : str or os.PathLike
        A file as for :func:`load`.
    max_points : int
        As for :func:`load`: a larger point cloud and its colours are thinned alike.

    Returns
    -------
    model : Mesh or PointCloud
        As :func:`load` returns it.
    appearance : Appearance
        Every field None that the file does not hold.

    Raises
    ------
    MeshLoadError
        As :func:`load`, and if a texture image cannot be decoded.
    MissingDependencyError
        If the file has a texture and Pillow is not installed.
    """
    path = as_path(path, "path")
    max_points = check_int(max_points, "max_points", minimum=1)
    reading = _read(path, appearance=True)
    model, faces = _model(path, reading, max_points)
    file_name = path.name or str(path)
    try:
        return model, _appearance(reading, faces)
    except (FormatError, InputError) as err:
        raise MeshLoadError(f"{file_name}: {err}") from err


def require_surface(model: Mesh | PointCloud, label: str | None = None) -> Mesh:
    """The model if it is a mesh; the one refusal of a point cloud where a surface is needed.

    Parameters
    ----------
    model : Mesh or PointCloud
        What :func:`load` returned.
    label : str, optional
        The file named in the message (default: the model's name).

    Returns
    -------
    Mesh

    Raises
    ------
    MeshLoadError
        ``bunny.ply: a point cloud (8171 points, no faces); this needs a
        surface (a mesh with faces)``.
    """
    if isinstance(model, Mesh):
        return model
    raise MeshLoadError(f"{label or model.name}: a point cloud ({model.n_points} points, "
                        "no faces); this needs a surface (a mesh with faces)")


def load_mesh(path: str | os.PathLike[str]) -> Mesh:
    """Read a mesh file into a triangle :class:`~vptoolkit.mesh.Mesh`.

    :func:`load`, then :func:`require_surface`.

    Parameters
    ----------
    path : str or os.PathLike
        A file ending in one of :data:`SUPPORTED_SUFFIXES` (any letter case).
        OFF may glue the counts to the keyword as ModelNet40 does
        (``OFF490 518 0``); STL may be ASCII or binary.

    Returns
    -------
    Mesh
        As :func:`load` returns it, ``name`` the file stem.

    Raises
    ------
    MeshLoadError
        As :func:`load`, and :func:`require_surface`'s message if the file
        holds points without faces.
    InputError
        If ``path`` is not a str or path-like object.
    """
    path = as_path(path, "path")
    return require_surface(load(path), path.name or str(path))


def _read(path: Path, *, appearance: bool = False) -> Reading:
    """What the reader of the file's suffix finds in it, or the loader's one-line error."""
    file_name = path.name or str(path)
    data = _read_file(path, file_name)
    suffix = path.suffix.lower()
    label = ply.file_label.set(file_name)
    try:
        return _READERS[suffix](path, data, appearance)
    except FormatError as err:
        raise MeshLoadError(f"{file_name}: {err}") from err.__cause__
    except MissingDependencyError:
        raise
    except Exception as err:  # any parser failure, chained as the cause
        raise MeshLoadError(
            f"{file_name}: cannot parse {_FORMAT_LABELS.get(suffix, suffix[1:].upper())} file "
            f"({type(err).__name__}: {one_line(str(err))})"
        ) from err
    finally:
        ply.file_label.reset(label)


def _model(path: Path, reading: Reading, max_points: int) -> tuple[Mesh | PointCloud, Any]:
    """The checked model of a reading, with its triangles (None for a point cloud)."""
    file_name = path.name or str(path)
    if len(reading.polygons[1]) == 0 and len(reading.vertices):  # vertices and no faces
        if len(reading.vertices) > max_points and np.isfinite(reading.vertices).all():
            reading = _thinned(reading, max_points, path)
        try:
            return PointCloud(reading.vertices, reading.normals, name=path.stem), None
        except InputError as err:
            raise MeshLoadError(f"{file_name}: {str(err).removeprefix(path.stem + ': ')}") from err
    try:
        faces = check_and_triangulate(reading.vertices, reading.polygons)
    except FormatError as err:
        raise MeshLoadError(f"{file_name}: {err}") from err.__cause__
    try:
        return Mesh(vertices=reading.vertices, faces=faces, name=path.stem), faces
    except InputError as err:  # pragma: no cover - the checks above are stricter
        raise MeshLoadError(f"{file_name}: invalid mesh ({err})") from err


def _thinned(reading: Reading, max_points: int, path: Path) -> Reading:
    """A point cloud reading thinned to at most ``max_points`` (:func:`voxel_subset`), warned
    once (:data:`_thinning_warned`)."""
    kept = voxel_subset(reading.vertices, max_points)
    file_name = path.name or str(path)
    warned = (os.path.abspath(path), len(reading.vertices), max_points)
    if warned not in _thinning_warned:
        _thinning_warned.add(warned)
        _log.warning("%s: %s points, more than max_points=%s; kept %s, one per voxel "
                     "(vptoolkit.point_cloud.voxel_subset)", file_name,
                     f"{len(reading.vertices):,}", f"{max_points:,}", f"{len(kept):,}")
    return reading._replace(
        vertices=reading.vertices[kept],
        normals=None if reading.normals is None else reading.normals[kept],
        vertex_colors=None if reading.vertex_colors is None else reading.vertex_colors[kept])


def _appearance(reading: Reading, faces: Any) -> Appearance:
    """The appearance of a reading, its per-polygon and per-corner rows carried onto ``faces``."""
    sizes = reading.polygons[1]
    face_colors = corner_uv = None
    if faces is not None:
        if reading.polygon_colors is not None:
            face_colors = triangle_rows(reading.polygon_colors, sizes, per_corner=False)
        if reading.corner_uv is not None:
            corner_uv = triangle_rows(reading.corner_uv, sizes, per_corner=True)
        elif reading.vertex_uv is not None:
            corner_uv = reading.vertex_uv[faces]
    texture = reading.texture() if reading.texture is not None and corner_uv is not None else None
    return Appearance(vertex_colors=reading.vertex_colors, face_colors=face_colors,
                      base_color=None if reading.base_color is None
                      else np.asarray(reading.base_color, dtype=np.float64),
                      corner_uv=corner_uv, texture=texture)


def save_mesh(mesh: MeshLike, path: str | os.PathLike[str]) -> Path:
    """Write ``mesh`` to ``path`` atomically, in the format its suffix names.

    The data goes to a temporary file in the target directory, which then
    replaces ``path`` in one step, so readers never see a half-written file.

    Parameters
    ----------
    mesh : MeshLike
        The mesh to write.
    path : str or os.PathLike
        Target file ending in one of :data:`WRITABLE_SUFFIXES`. OFF and OBJ
        are text with the shortest exact repr of each float and PLY is binary
        float64, so all three read back exactly. STL is binary float32
        triangle soup: it rounds coordinates and does not store shared
        vertices.

    Returns
    -------
    Path
        The path written.

    Raises
    ------
    InputError
        If ``mesh`` is not a mesh (:func:`~vptoolkit.mesh.as_mesh`), the suffix
        is not writable or the target directory does not exist. Other OS errors propagate unchanged.
    """
    mesh = as_mesh(mesh)
    path = as_path(path, "path")
    suffix = path.suffix.lower()
    if suffix not in WRITABLE_SUFFIXES:
        raise InputError(
            f"{path.name}: cannot write {suffix or 'files without a suffix'}; "
            f"supported: {', '.join(WRITABLE_SUFFIXES)}"
        )
    directory = path.parent
    if not directory.is_dir():
        raise InputError(f"{path.name}: target directory does not exist: {directory}")
    payload = _encode(mesh, suffix)
    return write_bytes_atomic(path, payload)


def _encode(mesh: Mesh, suffix: str) -> bytes:
    """Return the file content of ``mesh`` in the writable format ``suffix`` names."""
    if suffix == ".off":
        return off.off_bytes(mesh.vertices, mesh.faces)
    if suffix == ".obj":
        return obj.obj_bytes(mesh.vertices, mesh.faces, name=mesh.name)
    if suffix == ".ply":
        return ply.ply_bytes(mesh.vertices, mesh.faces, name=mesh.name)
    return stl.stl_bytes(mesh.vertices, mesh.faces, name=mesh.name)


def _read_file(path: Path, file_name: str) -> bytes:
    """Return the bytes of a regular file with a suffix :func:`load` reads, or raise.

    A file whose reader reads it from the path (NPY, NPZ, PCD, LAS, LAZ) is
    checked the same way but not read here, and ``b""`` is returned.
    """
    try:
        info = path.stat()
    except (FileNotFoundError, NotADirectoryError) as err:
        raise MeshLoadError(f"{file_name}: no such file: {path}") from err
    except OSError as err:
        raise MeshLoadError(f"{file_name}: cannot access file ({err.strerror or err})") from err
    if stat.S_ISDIR(info.st_mode):
        raise MeshLoadError(f"{file_name}: is a directory, not a mesh file")
    if not stat.S_ISREG(info.st_mode):
        raise MeshLoadError(f"{file_name}: not a regular file")
    suffix = path.suffix.lower()
    if suffix not in MODEL_SUFFIXES:
        found = f"unknown suffix {path.suffix!r}" if path.suffix else "no file suffix"
        raise MeshLoadError(f"{file_name}: {found}; supported: {', '.join(MODEL_SUFFIXES)}")
    if info.st_size == 0:
        raise MeshLoadError(f"{file_name}: file is empty (0 bytes)")
    if suffix in PATH_SUFFIXES:
        return b""
    try:
        return path.read_bytes()
    except OSError as err:
        raise MeshLoadError(f"{file_name}: cannot read file ({err.strerror or err})") from err
