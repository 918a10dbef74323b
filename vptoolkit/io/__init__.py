"""Read and write triangle meshes: OFF, OBJ, PLY, STL, glTF and GLB.

:func:`load_mesh` turns a file into a :class:`~vptoolkit.mesh.Mesh`, and
:func:`save_mesh` writes one back. OFF, OBJ, PLY and STL are read by small
numpy readers, one module per format (:mod:`~vptoolkit.io.off`,
:mod:`~vptoolkit.io.obj`, :mod:`~vptoolkit.io.ply`, :mod:`~vptoolkit.io.stl`),
that keep the file's vertices in file order (no merging, no splitting by
texture coordinates) and check the counts a header declares. glTF and GLB
scenes go through trimesh (:mod:`~vptoolkit.io.gltf`), imported on first use,
and are flattened with every node transform applied. The readers return plain
arrays; this module checks them and builds the Mesh. The readers share the
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

import os
import stat
from pathlib import Path

from vptoolkit.checks import as_path, one_line
from vptoolkit.errors import InputError, MeshLoadError
from vptoolkit.files import write_bytes_atomic
from vptoolkit.io import gltf, obj, off, ply, stl
from vptoolkit.io._polygons import FormatError, check_and_triangulate
from vptoolkit.mesh import Mesh, MeshLike, as_mesh

__all__ = ["SUPPORTED_SUFFIXES", "WRITABLE_SUFFIXES", "find_mesh_files", "load_mesh", "save_mesh"]

#: File suffixes :func:`load_mesh` reads (compared case-insensitively).
SUPPORTED_SUFFIXES: tuple[str, ...] = (".off", ".obj", ".ply", ".stl", ".glb", ".gltf")

#: File suffixes :func:`save_mesh` writes (compared case-insensitively).
WRITABLE_SUFFIXES: tuple[str, ...] = (".off", ".ply", ".obj", ".stl")

_FORMAT_LABELS = {
    ".off": "OFF",
    ".obj": "OBJ",
    ".ply": "PLY",
    ".stl": "STL",
    ".glb": "GLB",
    ".gltf": "glTF",
}

#: Readers of the formats that need nothing but the file's bytes; glTF also needs its path.
_BYTE_READERS = {
    ".off": off.read_off,
    ".obj": obj.read_obj,
    ".ply": ply.read_ply,
    ".stl": stl.read_stl,
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
    root = as_path(folder, "folder")
    if not root.is_dir():
        raise InputError(f"{root}: not a folder")
    found: list[Path] = []
    for parent, subfolders, files in os.walk(root):
        subfolders[:] = sorted(name for name in subfolders if not name.startswith("."))
        found.extend(
            Path(parent) / name for name in files
            if not name.startswith(".") and Path(name).suffix.lower() in SUPPORTED_SUFFIXES
        )
    return sorted(found)


def load_mesh(path: str | os.PathLike[str]) -> Mesh:
    """Read a mesh file into a triangle :class:`~vptoolkit.mesh.Mesh`.

    Parameters
    ----------
    path : str or os.PathLike
        A file ending in one of :data:`SUPPORTED_SUFFIXES` (any letter case).
        OFF may glue the counts to the keyword as ModelNet40 does
        (``OFF490 518 0``); STL may be ASCII or binary.

    Returns
    -------
    Mesh
        ``vertices : (n_vertices, 3) float64`` in file order (glTF: all scene
        nodes with their transforms applied), ``faces : (n_faces, 3) int64``
        with polygons fan-triangulated, ``name`` the file stem.

    Raises
    ------
    MeshLoadError
        If the file does not exist or cannot be read, has an unknown suffix,
        is empty, holds no faces, has NaN or infinite coordinates, a face index
        out of range, or cannot be parsed. The message starts with the file
        name; a parser's own exception is chained as the cause.
    InputError
        If ``path`` is not a str or path-like object.
    """
    path = as_path(path, "path")
    file_name = path.name or str(path)
    data = _read_file(path, file_name)
    suffix = path.suffix.lower()
    label = ply.file_label.set(file_name)
    try:
        if suffix in _BYTE_READERS:
            vertices, polygons = _BYTE_READERS[suffix](data)
        else:
            vertices, polygons = gltf.read_gltf(path, data)
        faces = check_and_triangulate(vertices, polygons)
    except FormatError as err:
        raise MeshLoadError(f"{file_name}: {err}") from err.__cause__
    except Exception as err:  # any parser failure, chained as the cause
        raise MeshLoadError(
            f"{file_name}: cannot parse {_FORMAT_LABELS[suffix]} file "
            f"({type(err).__name__}: {one_line(str(err))})"
        ) from err
    finally:
        ply.file_label.reset(label)
    try:
        return Mesh(vertices=vertices, faces=faces, name=path.stem)
    except InputError as err:  # pragma: no cover - the checks above are stricter
        raise MeshLoadError(f"{file_name}: invalid mesh ({err})") from err


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
    """Return the bytes of a regular file with a supported suffix, or raise."""
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
    if suffix not in SUPPORTED_SUFFIXES:
        found = f"unknown suffix {path.suffix!r}" if path.suffix else "no file suffix"
        raise MeshLoadError(f"{file_name}: {found}; supported: {', '.join(SUPPORTED_SUFFIXES)}")
    if info.st_size == 0:
        raise MeshLoadError(f"{file_name}: file is empty (0 bytes)")
    try:
        return path.read_bytes()
    except OSError as err:
        raise MeshLoadError(f"{file_name}: cannot read file ({err.strerror or err})") from err
