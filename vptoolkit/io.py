"""Read and write triangle meshes: OFF, OBJ, PLY, STL, glTF and GLB.

:func:`load_mesh` turns a file into a :class:`~vptoolkit.mesh.Mesh`, and
:func:`save_mesh` writes one back. OFF, OBJ, PLY and STL are read by small
numpy readers in this module, one per format, that keep the file's vertices
in file order (no merging, no splitting by texture coordinates) and check the
counts a header declares. glTF and GLB scenes go through trimesh, imported on
first use, and are flattened with every node transform applied.

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

import json
import os
import re
import secrets
import stat
import struct
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from vptoolkit.errors import InputError, MeshLoadError
from vptoolkit.mesh import Mesh

__all__ = ["SUPPORTED_SUFFIXES", "WRITABLE_SUFFIXES", "load_mesh", "save_mesh"]

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
_MAX_MESSAGE_CHARS = 200

Polygons = tuple[NDArray[np.int64], NDArray[np.int64]]
"""Polygon faces as ``(flat_indices, sizes)``: ``(sum(sizes),) int64`` vertex
indices of every polygon in file order, and ``(n_polygons,) int64`` vertex
counts per polygon."""


PlyTable = dict[str, "NDArray[np.float64] | Polygons"]
"""The columns read from one PLY element: scalars as ``(count,)`` arrays, lists
as :data:`Polygons` pairs."""


class _FormatError(Exception):
    """A reader's complaint about the file content; load_mesh prefixes the name."""


# --------------------------------------------------------------------------
# public API


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
    path = _as_path(path, "path")
    file_name = path.name or str(path)
    data = _read_file(path, file_name)
    suffix = path.suffix.lower()
    try:
        if suffix == ".off":
            vertices, polygons = _read_off(data)
        elif suffix == ".obj":
            vertices, polygons = _read_obj(data)
        elif suffix == ".ply":
            vertices, polygons = _read_ply(data)
        elif suffix == ".stl":
            vertices, polygons = _read_stl(data)
        else:
            vertices, polygons = _read_gltf(path, data, suffix)
        faces = _check_and_triangulate(vertices, polygons)
    except _FormatError as err:
        raise MeshLoadError(f"{file_name}: {err}") from err.__cause__
    except Exception as err:  # any parser failure, chained as the cause
        raise MeshLoadError(
            f"{file_name}: cannot parse {_FORMAT_LABELS[suffix]} file "
            f"({type(err).__name__}: {_one_line(str(err))})"
        ) from err
    try:
        return Mesh(vertices=vertices, faces=faces, name=path.stem)
    except InputError as err:  # pragma: no cover - the checks above are stricter
        raise MeshLoadError(f"{file_name}: invalid mesh ({err})") from err


def save_mesh(mesh: Mesh, path: str | os.PathLike[str]) -> Path:
    """Write ``mesh`` to ``path`` atomically, in the format its suffix names.

    The data goes to a temporary file in the target directory, which then
    replaces ``path`` in one step, so readers never see a half-written file.

    Parameters
    ----------
    mesh : Mesh
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
        If ``mesh`` is not a Mesh, the suffix is not writable or the target
        directory does not exist. Other OS errors propagate unchanged.
    """
    if not isinstance(mesh, Mesh):
        raise InputError(f"mesh: expected a vptoolkit Mesh, got {type(mesh).__name__}")
    path = _as_path(path, "path")
    suffix = path.suffix.lower()
    writers = {".off": _off_bytes, ".ply": _ply_bytes, ".obj": _obj_bytes, ".stl": _stl_bytes}
    if suffix not in writers:
        raise InputError(
            f"{path.name}: cannot write {suffix or 'files without a suffix'}; "
            f"supported: {', '.join(WRITABLE_SUFFIXES)}"
        )
    directory = path.parent
    if not directory.is_dir():
        raise InputError(f"{path.name}: target directory does not exist: {directory}")
    payload = writers[suffix](mesh)
    temp_path = directory / f".{path.name}.{secrets.token_hex(6)}.tmp"
    # O_EXCL never clobbers; mode 0o666 lets the umask decide the permissions.
    handle = os.open(temp_path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(payload)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temp_path, path)
    except BaseException:
        temp_path.unlink(missing_ok=True)
        raise
    return path


# --------------------------------------------------------------------------
# shared steps


def _as_path(path: object, argument: str) -> Path:
    try:
        return Path(os.fspath(path))  # type: ignore[arg-type]
    except TypeError as err:
        raise InputError(
            f"{argument}: expected a str or os.PathLike, got {type(path).__name__}"
        ) from err


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


def _one_line(text: str) -> str:
    text = " ".join(text.split())
    if len(text) > _MAX_MESSAGE_CHARS:
        return text[: _MAX_MESSAGE_CHARS - 3] + "..."
    return text or "no details"


def _check_and_triangulate(vertices: NDArray[np.float64], polygons: Polygons) -> NDArray[np.int64]:
    """Validate vertices and polygons and return ``(n_faces, 3) int64`` triangles."""
    flat, sizes = polygons
    n_vertices = len(vertices)
    if n_vertices == 0 and len(sizes) == 0:
        raise _FormatError("no geometry (no vertices, no faces)")
    is_finite = np.isfinite(vertices).all(axis=1)
    if not is_finite.all():
        first = int(np.argmin(is_finite))
        n_bad = int((~is_finite).sum())
        raise _FormatError(
            f"{_plural(n_bad, 'vertex has', 'vertices have')} NaN or infinite coordinates "
            f"(first: vertex {first})"
        )
    if len(sizes) == 0:
        raise _FormatError(
            f"no faces, only {_plural(n_vertices, 'vertex', 'vertices')} (a point cloud?)"
        )
    is_bad = (flat < 0) | (flat >= n_vertices)
    if is_bad.any():
        first = int(np.argmax(is_bad))
        polygon = int(np.searchsorted(np.cumsum(sizes), first, side="right"))
        raise _FormatError(
            f"face {polygon} refers to vertex {int(flat[first])}, file has {n_vertices} vertices"
        )
    faces = _fan_triangulate(flat, sizes)
    if len(faces) == 0:
        shorter = _plural(len(sizes), "shorter one", "shorter ones")
        raise _FormatError(f"no faces with 3 or more vertices, only {shorter}")
    return faces


def _fan_triangulate(flat: NDArray[np.int64], sizes: NDArray[np.int64]) -> NDArray[np.int64]:
    """Fan-triangulate polygons; those with fewer than 3 vertices are dropped.

    Returns ``(sum(max(sizes - 2, 0)), 3) int64``, triangles of each polygon
    contiguous and in file order.
    """
    if len(sizes) and (sizes == 3).all():
        return flat.reshape(-1, 3)
    starts = np.cumsum(sizes) - sizes
    n_triangles = np.maximum(sizes - 2, 0)
    polygon_of = np.repeat(np.arange(len(sizes)), n_triangles)
    first_triangle = np.cumsum(n_triangles) - n_triangles
    corner = np.arange(int(n_triangles.sum())) - first_triangle[polygon_of]
    base = starts[polygon_of]
    return np.stack([flat[base], flat[base + corner + 1], flat[base + corner + 2]], axis=1)


def _floats(
    rows: list[list[str]], line_numbers: list[int], n_columns: int, what: str
) -> NDArray[np.float64]:
    """Convert rows of ``n_columns`` number strings to ``(n_rows, n_columns) float64``."""
    if not rows:
        return np.zeros((0, n_columns), dtype=np.float64)
    try:
        return np.array(rows, dtype=np.float64).reshape(len(rows), n_columns)
    except ValueError as err:
        for row, number in zip(rows, line_numbers):
            try:
                [float(token) for token in row]
            except ValueError:
                raise _FormatError(f"line {number}: cannot read {what} {' '.join(row)!r}") from err
        raise


def _counted_polygons(
    rows: list[list[str]], line_numbers: list[int], *, lead: int, is_exact: bool, min_size: int
) -> Polygons:
    """Parse rows holding ``count i_1 ... i_count`` after ``lead`` other values.

    With ``is_exact`` the row must end after the indices (PLY without further
    properties); otherwise trailing values such as OFF face colours are ignored.
    A count below ``min_size`` is an error.
    """
    sizes = np.zeros(len(rows), dtype=np.int64)
    index_tokens: list[str] = []
    for k, row in enumerate(rows):
        try:
            size = int(row[lead])
        except (ValueError, IndexError) as err:
            found = repr(row[lead]) if len(row) > lead else "nothing"
            raise _FormatError(
                f"line {line_numbers[k]}: expected the face's vertex count, found {found}"
            ) from err
        n_listed = len(row) - lead - 1
        if size < min_size:
            raise _FormatError(
                f"line {line_numbers[k]}: face has {size} vertices, need at least {min_size}"
            )
        if size < 0 or n_listed < size or (is_exact and n_listed != size):
            raise _FormatError(
                f"line {line_numbers[k]}: face declares {size} vertices but lists {n_listed} values"
            )
        sizes[k] = size
        index_tokens.extend(row[lead + 1 : lead + 1 + size])
    try:
        flat = np.array(index_tokens, dtype=np.int64)
    except ValueError as err:
        for k, row in enumerate(rows):
            for token in row[lead + 1 : lead + 1 + int(sizes[k])]:
                if not re.fullmatch(r"[+-]?\d+", token):
                    raise _FormatError(
                        f"line {line_numbers[k]}: face index {token!r} is not an integer"
                    ) from err
        raise
    return flat, sizes


def _plural(count: int, singular: str, plural: str) -> str:
    return f"{count} {singular if count == 1 else plural}"


# --------------------------------------------------------------------------
# OFF

_OFF_KEYWORDS = {"OFF", "COFF", "NOFF", "CNOFF", "STOFF", "STCOFF", "STNOFF", "STCNOFF"}


def _read_off(data: bytes) -> tuple[NDArray[np.float64], Polygons]:
    """Read (ST)(C)(N)OFF text, including ModelNet40's ``OFF490 518 0`` header.

    ``#`` starts a comment anywhere; blank lines are skipped. Each vertex line
    gives x y z first (colours or normals may follow), each face line gives
    ``n i_1 ... i_n`` with 0-based indices (a colour may follow).
    """
    text = data.decode("latin-1")
    has_comments = "#" in text
    numbers: list[int] = []
    lines: list[str] = []
    for number, line in enumerate(text.splitlines(), start=1):
        if has_comments:
            line = line.partition("#")[0]
        line = line.strip()
        if line:
            numbers.append(number)
            lines.append(line)
    if not lines:
        raise _FormatError("no geometry (only comments and blank lines)")
    keyword, rest = re.match(r"([A-Za-z]*)(.*)", lines[0]).groups()  # type: ignore[union-attr]
    if keyword.upper() == "OFF":
        keyword = "OFF"
    if keyword not in _OFF_KEYWORDS:
        if keyword.endswith("OFF"):
            raise _FormatError(f"unsupported OFF variant {keyword!r}")
        raise _FormatError(f"line {numbers[0]}: expected the OFF keyword, found {lines[0][:40]!r}")
    count_tokens, body_start = rest.split(), 1
    if count_tokens and count_tokens[0].upper() == "BINARY":
        raise _FormatError("binary OFF is not supported")
    if not count_tokens:
        if len(lines) < 2:
            raise _FormatError("header has no vertex and face counts")
        count_tokens, body_start = lines[1].split(), 2
    header_line = numbers[body_start - 1]
    try:
        counts = [int(token) for token in count_tokens]
    except ValueError:
        counts = []
    if len(counts) not in (2, 3) or min(counts) < 0:
        raise _FormatError(
            f"line {header_line}: expected 'n_vertices n_faces n_edges', "
            f"found {' '.join(count_tokens)[:40]!r}"
        )
    n_vertices, n_faces = counts[0], counts[1]
    n_body = len(lines) - body_start
    if n_body < n_vertices:
        raise _FormatError(f"header declares {n_vertices} vertices, file has {n_body}")
    if n_body < n_vertices + n_faces:
        raise _FormatError(f"header declares {n_faces} faces, file has {n_body - n_vertices}")
    if n_body > n_vertices + n_faces:
        extra_line = numbers[body_start + n_vertices + n_faces]
        raise _FormatError(
            f"line {extra_line}: unexpected data after the {n_vertices} vertices "
            f"and {n_faces} faces the header declares"
        )
    face_start = body_start + n_vertices
    vertex_rows = [line.split() for line in lines[body_start:face_start]]
    vertex_numbers = numbers[body_start:face_start]
    for row, number in zip(vertex_rows, vertex_numbers):
        if len(row) < 3:
            raise _FormatError(f"line {number}: vertex needs 3 coordinates, found {len(row)}")
        # equal lengths catch a header whose vertex count is off by a few lines
        if len(row) != len(vertex_rows[0]):
            raise _FormatError(
                f"line {number}: vertex has {len(row)} values, the first has "
                f"{len(vertex_rows[0])} (does the header count the vertices right?)"
            )
    coordinates = [row[:3] for row in vertex_rows]
    vertices = _floats(coordinates, vertex_numbers, 3, "vertex coordinates")
    face_rows = [line.split() for line in lines[face_start:]]
    polygons = _counted_polygons(
        face_rows, numbers[face_start:], lead=0, is_exact=False, min_size=3
    )
    return vertices, polygons


# --------------------------------------------------------------------------
# OBJ


def _read_obj(data: bytes) -> tuple[NDArray[np.float64], Polygons]:
    """Read the ``v`` and ``f`` statements of a Wavefront OBJ file.

    Indices are 1-based; negative ones count back from the last vertex defined
    so far. Only the vertex part of ``v/vt/vn`` is used; materials, texture
    coordinates, normals, lines and points are ignored.
    """
    text = data.decode("utf-8", errors="replace")
    if "\\" in text:  # line continuation
        text = re.sub(r"\\[ \t]*\r?\n", " ", text)
    vertex_rows: list[list[str]] = []
    vertex_numbers: list[int] = []
    face_indices: list[int] = []
    face_sizes: list[int] = []
    face_numbers: list[int] = []
    n_defined: list[int] = []  # vertices defined before each face
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.lstrip()
        if line[:2] not in ("v ", "v\t", "f ", "f\t"):
            continue
        tokens = line.partition("#")[0].split()
        if tokens[0] == "v":
            if len(tokens) < 4:
                raise _FormatError(
                    f"line {number}: vertex needs 3 coordinates, found {len(tokens) - 1}"
                )
            vertex_rows.append(tokens[1:4])
            vertex_numbers.append(number)
            continue
        try:
            face_indices.extend(int(token.partition("/")[0]) for token in tokens[1:])
        except ValueError as err:
            raise _FormatError(f"line {number}: cannot read face {line.strip()[:60]!r}") from err
        face_sizes.append(len(tokens) - 1)
        face_numbers.append(number)
        n_defined.append(len(vertex_rows))
    vertices = _floats(vertex_rows, vertex_numbers, 3, "vertex coordinates")
    raw = np.array(face_indices, dtype=np.int64)
    sizes = np.array(face_sizes, dtype=np.int64)
    defined = np.repeat(np.array(n_defined, dtype=np.int64), sizes)
    flat = np.where(raw > 0, raw - 1, defined + raw)
    is_bad = (raw == 0) | (flat < 0) | (flat >= len(vertices))
    if is_bad.any():
        first = int(np.argmax(is_bad))
        polygon = int(np.searchsorted(np.cumsum(sizes), first, side="right"))
        number, value = face_numbers[polygon], int(raw[first])
        if value == 0:
            raise _FormatError(f"line {number}: face index 0 is invalid (OBJ indices start at 1)")
        if value < 0:
            raise _FormatError(
                f"line {number}: relative face index {value} reaches before the first vertex "
                f"({_plural(int(defined[first]), 'vertex', 'vertices')} defined so far)"
            )
        raise _FormatError(
            f"line {number}: face index {value} out of range, file has "
            f"{_plural(len(vertices), 'vertex', 'vertices')}"
        )
    return vertices, (flat, sizes)


# --------------------------------------------------------------------------
# PLY

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}  # fmt: skip
_PLY_FORMATS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}
_PLY_INDEX_NAMES = ("vertex_indices", "vertex_index")


class _PlyProperty(NamedTuple):
    name: str
    dtype: str  # numpy type code of the value (of each item for a list)
    count_dtype: str | None  # numpy type code of a list's count, None for a scalar


class _PlyElement(NamedTuple):
    name: str
    count: int
    properties: list[_PlyProperty]


def _read_ply(data: bytes) -> tuple[NDArray[np.float64], Polygons]:
    """Read the ``vertex`` (x, y, z) and ``face`` elements of an ASCII or binary PLY."""
    byte_order, elements, body_offset = _read_ply_header(data)
    by_name = {element.name: element for element in elements}
    vertex_element = by_name.get("vertex")
    face_element = by_name.get("face")
    if vertex_element is not None:
        names = [prop.name for prop in vertex_element.properties]
        missing = [axis for axis in ("x", "y", "z") if axis not in names]
        if missing:
            raise _FormatError(f"PLY vertex element has no {'/'.join(missing)} property")
    index_name = None
    if face_element is not None:
        names = [prop.name for prop in face_element.properties]
        index_name = next((name for name in _PLY_INDEX_NAMES if name in names), None)
        if index_name is None:
            raise _FormatError("PLY face element has no vertex_indices list")
    wanted = {"vertex": ("x", "y", "z"), "face": (index_name,)}
    if byte_order:
        tables = _read_ply_binary(data, body_offset, elements, byte_order, wanted)
    else:
        tables = _read_ply_ascii(data, body_offset, elements, wanted)
    vertices = np.zeros((0, 3), dtype=np.float64)
    if vertex_element is not None:
        columns = tables["vertex"]
        vertices = np.stack([columns[axis] for axis in ("x", "y", "z")], axis=1).astype(np.float64)
    polygons: Polygons = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    if face_element is not None and index_name is not None:
        polygons = tables["face"][index_name]  # type: ignore[assignment]
    return vertices, polygons


def _read_ply_header(data: bytes) -> tuple[str, list[_PlyElement], int]:
    """Return the byte order (``""`` for ASCII), the elements and the body offset."""
    if not re.match(rb"ply[ \t]*\r?\n", data):
        raise _FormatError("not a PLY file (it does not start with 'ply')")
    match = re.search(rb"(?m)^end_header[ \t]*(\r?\n|$)", data)
    if match is None:
        raise _FormatError("PLY header has no end_header line")
    header_lines = data[: match.start()].decode("latin-1").splitlines()
    byte_order = None
    elements: list[_PlyElement] = []
    for number, line in enumerate(header_lines[1:], start=2):
        tokens = line.split()
        if not tokens or tokens[0] in ("comment", "obj_info"):
            continue
        keyword = tokens[0]
        if keyword == "format" and len(tokens) == 3 and tokens[1] in _PLY_FORMATS:
            byte_order = _PLY_FORMATS[tokens[1]]
        elif keyword == "element" and len(tokens) == 3 and tokens[2].isdigit():
            elements.append(_PlyElement(tokens[1], int(tokens[2]), []))
        elif keyword == "property" and elements and len(tokens) == 3 and tokens[1] in _PLY_TYPES:
            elements[-1].properties.append(_PlyProperty(tokens[2], _PLY_TYPES[tokens[1]], None))
        elif (
            keyword == "property"
            and elements
            and len(tokens) == 5
            and tokens[1] == "list"
            and tokens[2] in _PLY_TYPES
            and tokens[3] in _PLY_TYPES
        ):
            prop = _PlyProperty(tokens[4], _PLY_TYPES[tokens[3]], _PLY_TYPES[tokens[2]])
            elements[-1].properties.append(prop)
        else:
            raise _FormatError(f"PLY header line {number} is invalid: {line.strip()[:60]!r}")
    if byte_order is None:
        raise _FormatError("PLY header has no valid format line")
    return byte_order, elements, match.end()


def _element_label(element: _PlyElement, count: int) -> str:
    if element.name == "vertex":
        return _plural(count, "vertex", "vertices")
    if element.name == "face":
        return _plural(count, "face", "faces")
    return f"{count} '{element.name}' elements"



def _read_ply_ascii(
    data: bytes, offset: int, elements: list[_PlyElement], wanted: dict[str, tuple[str | None, ...]]
) -> dict[str, PlyTable]:
    """Read ASCII PLY rows, one element row per line; return the wanted properties."""
    header_line_count = data[:offset].count(b"\n")
    numbers: list[int] = []
    rows: list[list[str]] = []
    for number, line in enumerate(data[offset:].decode("latin-1").splitlines(), start=1):
        tokens = line.split()
        if tokens:
            numbers.append(number + header_line_count)
            rows.append(tokens)
    tables: dict[str, PlyTable] = {}
    start = 0
    for element in elements:
        stop = start + element.count
        if stop > len(rows):
            raise _FormatError(
                f"PLY header declares {_element_label(element, element.count)}, "
                f"file has {max(len(rows) - start, 0)}"
            )
        names = wanted.get(element.name)
        if names is not None:
            tables[element.name] = _ply_ascii_element(
                element, rows[start:stop], numbers[start:stop], names
            )
        start = stop
    if start < len(rows):
        raise _FormatError(f"line {numbers[start]}: unexpected data after the last PLY element")
    return tables


def _ply_ascii_element(
    element: _PlyElement, rows: list[list[str]], numbers: list[int], names: tuple[str | None, ...]
) -> PlyTable:
    props = element.properties
    if all(prop.count_dtype is None for prop in props):
        for row, number in zip(rows, numbers):
            if len(row) != len(props):
                raise _FormatError(
                    f"line {number}: {element.name} row has {len(row)} values, "
                    f"expected {len(props)}"
                )
        values = _floats(rows, numbers, len(props), f"{element.name} values")
        return {prop.name: values[:, i] for i, prop in enumerate(props) if prop.name in names}
    # the face index list after `lead` scalars; anything else with lists is rare
    list_positions = [i for i, prop in enumerate(props) if prop.count_dtype is not None]
    position = next((i for i, prop in enumerate(props) if prop.name in names), None)
    if position is None or list_positions[0] != position or len(list_positions) != 1:
        raise _FormatError(f"PLY element {element.name!r} has an unsupported ASCII list layout")
    n_trailing = len(props) - position - 1
    rows_without_tail = [row[: len(row) - n_trailing] for row in rows] if n_trailing else rows
    return {props[position].name: _counted_polygons(
        rows_without_tail, numbers, lead=position, is_exact=True, min_size=0
    )}


def _read_ply_binary(
    data: bytes,
    offset: int,
    elements: list[_PlyElement],
    byte_order: str,
    wanted: dict[str, tuple[str | None, ...]],
) -> dict[str, PlyTable]:
    """Read binary PLY elements in order; return the wanted properties."""
    tables: dict[str, PlyTable] = {}
    for element in elements:
        table, offset = _ply_binary_element(data, offset, element, byte_order)
        names = wanted.get(element.name)
        if names is not None:
            tables[element.name] = {name: table[name] for name in names if name is not None}
    trailing = data[offset:]
    if trailing.strip():
        raise _FormatError(f"{len(trailing)} bytes of unexpected data after the last PLY element")
    return tables


def _ply_binary_element(
    data: bytes, offset: int, element: _PlyElement, byte_order: str
) -> tuple[PlyTable, int]:
    """Read one binary element at ``offset``; return its columns and the next offset.

    Scalars become ``(count,)`` arrays, lists become :data:`Polygons` pairs. Rows
    whose lists all have the first row's lengths are read in one numpy call;
    otherwise the rows are walked one at a time.
    """
    props = element.properties
    if element.count == 0 or not props:
        return _ply_empty_table(props), offset
    lengths = []
    cursor = offset
    for prop in props:  # list lengths of the first row
        if prop.count_dtype is None:
            cursor += np.dtype(prop.dtype).itemsize
            continue
        size = _list_length(data, cursor, byte_order + prop.count_dtype, element)
        lengths.append(size)
        cursor += np.dtype(prop.count_dtype).itemsize + size * np.dtype(prop.dtype).itemsize
    fields: list[tuple[str, str] | tuple[str, str, tuple[int, ...]]] = []
    list_lengths = iter(lengths)
    for i, prop in enumerate(props):
        if prop.count_dtype is None:
            fields.append((f"p{i}", byte_order + prop.dtype))
        else:
            fields.append((f"n{i}", byte_order + prop.count_dtype))
            fields.append((f"p{i}", byte_order + prop.dtype, (next(list_lengths),)))
    row_dtype = np.dtype(fields)
    if offset + element.count * row_dtype.itemsize <= len(data):
        rows = np.frombuffer(data, dtype=row_dtype, count=element.count, offset=offset)
        is_uniform = all(
            (rows[f"n{i}"] == rows[f"n{i}"][0]).all()
            for i, prop in enumerate(props)
            if prop.count_dtype is not None
        )
        if is_uniform:
            table: PlyTable = {}
            for i, prop in enumerate(props):
                column = rows[f"p{i}"]
                if prop.count_dtype is None:
                    table[prop.name] = column
                else:
                    sizes = rows[f"n{i}"].astype(np.int64)
                    table[prop.name] = (column.astype(np.int64).reshape(-1), sizes)
            return table, offset + element.count * row_dtype.itemsize
    return _ply_binary_rows(data, offset, element, byte_order)


def _ply_binary_rows(
    data: bytes, offset: int, element: _PlyElement, byte_order: str
) -> tuple[PlyTable, int]:
    """Walk binary rows with variable list lengths one at a time (slow path)."""
    props = element.properties
    scalars: list[list[float]] = [[] for _ in props]
    list_items: list[list[NDArray[np.int64]]] = [[] for _ in props]
    list_sizes: list[list[int]] = [[] for _ in props]
    for _ in range(element.count):
        for i, prop in enumerate(props):
            if prop.count_dtype is None:
                scalars[i].append(_unpack(data, offset, byte_order + prop.dtype, element))
                offset += np.dtype(prop.dtype).itemsize
                continue
            size = _list_length(data, offset, byte_order + prop.count_dtype, element)
            offset += np.dtype(prop.count_dtype).itemsize
            item_dtype = np.dtype(byte_order + prop.dtype)
            if offset + size * item_dtype.itemsize > len(data):
                raise _truncated(element)
            items = np.frombuffer(data, dtype=item_dtype, count=size, offset=offset)
            list_items[i].append(items.astype(np.int64))
            list_sizes[i].append(size)
            offset += size * item_dtype.itemsize
    table: PlyTable = {}
    for i, prop in enumerate(props):
        if prop.count_dtype is None:
            table[prop.name] = np.array(scalars[i], dtype=np.float64)
        else:
            table[prop.name] = (
                np.concatenate(list_items[i]).astype(np.int64),
                np.array(list_sizes[i], dtype=np.int64),
            )
    return table, offset


def _ply_empty_table(props: list[_PlyProperty]) -> PlyTable:
    empty = np.zeros(0, dtype=np.int64)
    return {
        prop.name: np.zeros(0, dtype=np.float64) if prop.count_dtype is None else (empty, empty)
        for prop in props
    }


def _unpack(data: bytes, offset: int, code: str, element: _PlyElement) -> int | float:
    dtype = np.dtype(code)
    if offset + dtype.itemsize > len(data):
        raise _truncated(element)
    value = np.frombuffer(data, dtype=dtype, count=1, offset=offset)[0]
    return value.item()  # type: ignore[no-any-return]


def _list_length(data: bytes, offset: int, code: str, element: _PlyElement) -> int:
    size = int(_unpack(data, offset, code, element))
    if size < 0:
        raise _FormatError(f"PLY {element.name} list has negative length {size}")
    return size


def _truncated(element: _PlyElement) -> _FormatError:
    return _FormatError(
        f"PLY file ends before the {_element_label(element, element.count)} its header declares"
    )


# --------------------------------------------------------------------------
# STL

_STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
_STL_VERTEX = re.compile(rb"(?i)\bvertex[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)")


def _read_stl(data: bytes) -> tuple[NDArray[np.float64], Polygons]:
    """Read binary or ASCII STL as triangle soup (three vertices per face).

    A file whose length matches its binary triangle count is binary, even if
    its 80-byte header starts with ``solid`` (as some CAD exporters write).
    """
    n_declared = int.from_bytes(data[80:84], "little") if len(data) >= 84 else -1
    if n_declared >= 0 and len(data) == 84 + 50 * n_declared:
        records = np.frombuffer(data, dtype=_STL_RECORD, count=n_declared, offset=84)
        vertices = records["corners"].reshape(-1, 3).astype(np.float64)
    elif data.lstrip()[:5].lower() == b"solid" and b"\0" not in data:
        vertices = _read_stl_ascii(data)
    elif n_declared < 0:
        raise _FormatError(f"not an STL file (binary STL needs 84+ bytes, file has {len(data)})")
    else:
        raise _FormatError(
            f"binary STL header declares {n_declared} triangles ({84 + 50 * n_declared} bytes), "
            f"file has {len(data)} bytes"
        )
    n_faces = len(vertices) // 3
    return vertices, (np.arange(3 * n_faces, dtype=np.int64), np.full(n_faces, 3, dtype=np.int64))


def _read_stl_ascii(data: bytes) -> NDArray[np.float64]:
    matches = _STL_VERTEX.findall(data)
    if len(matches) % 3:
        raise _FormatError(f"ASCII STL has {len(matches)} vertex lines, not a multiple of 3")
    if not matches:
        return np.zeros((0, 3), dtype=np.float64)
    rows = [[token.decode("latin-1") for token in match] for match in matches]
    try:
        return np.array(rows, dtype=np.float64)
    except ValueError as err:
        for row in rows:
            try:
                [float(token) for token in row]
            except ValueError:
                raise _FormatError(f"cannot read STL vertex {' '.join(row)[:60]!r}") from err
        raise


# --------------------------------------------------------------------------
# glTF / GLB


def _read_gltf(path: Path, data: bytes, suffix: str) -> tuple[NDArray[np.float64], Polygons]:
    """Flatten a glTF or GLB scene through trimesh, applying every node transform.

    Mesh instances are concatenated in scene-graph order; a transform with a
    negative determinant reverses the triangles' winding to keep them facing out.
    Point and line primitives are ignored.
    """
    import trimesh  # lazy: only glTF needs it

    if suffix == ".gltf":
        try:
            json.loads(data)
        except ValueError as err:
            raise _FormatError(f"invalid glTF JSON ({_one_line(str(err))})") from err
    elif not data.startswith(b"glTF"):
        raise _FormatError("not a GLB file (it does not start with 'glTF')")
    scene = trimesh.load_scene(str(path), file_type=suffix[1:], process=False)
    vertex_blocks: list[NDArray[np.float64]] = []
    face_blocks: list[NDArray[np.int64]] = []
    n_vertices = n_other_points = 0
    for node in scene.graph.nodes_geometry:
        transform, geometry_name = scene.graph[node]
        geometry = scene.geometry[geometry_name]
        if not isinstance(geometry, trimesh.Trimesh):
            n_other_points += len(getattr(geometry, "vertices", ()))
            continue
        rotation, translation = transform[:3, :3], transform[:3, 3]
        points = np.asarray(geometry.vertices, dtype=np.float64).reshape(-1, 3)
        faces = np.asarray(geometry.faces, dtype=np.int64).reshape(-1, 3)
        if np.linalg.det(rotation) < 0:
            faces = faces[:, ::-1]
        vertex_blocks.append(points @ rotation.T + translation)
        face_blocks.append(faces + n_vertices)
        n_vertices += len(points)
    if not vertex_blocks:  # report points and lines as vertices without faces
        return np.zeros((n_other_points, 3)), (np.zeros(0, np.int64), np.zeros(0, np.int64))
    vertices = np.concatenate(vertex_blocks)
    faces = np.concatenate(face_blocks)
    return vertices, (faces.reshape(-1), np.full(len(faces), 3, dtype=np.int64))


# --------------------------------------------------------------------------
# writers


def _off_bytes(mesh: Mesh) -> bytes:
    lines = [f"OFF\n{mesh.n_vertices} {mesh.n_faces} 0\n"]
    lines.extend(f"{x!r} {y!r} {z!r}\n" for x, y, z in mesh.vertices.tolist())
    lines.extend(f"3 {a} {b} {c}\n" for a, b, c in mesh.faces.tolist())
    return "".join(lines).encode("ascii")


def _obj_bytes(mesh: Mesh) -> bytes:
    lines = [f"# {mesh.name}: {mesh.n_vertices} vertices, {mesh.n_faces} faces\n"]
    lines.extend(f"v {x!r} {y!r} {z!r}\n" for x, y, z in mesh.vertices.tolist())
    lines.extend(f"f {a} {b} {c}\n" for a, b, c in (mesh.faces + 1).tolist())
    return "".join(lines).encode("ascii")


def _ply_bytes(mesh: Mesh) -> bytes:
    if mesh.n_vertices > np.iinfo(np.int32).max:
        raise InputError(f"{mesh.name}: too many vertices for PLY int32 indices")
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {mesh.n_vertices}\n"
        "property double x\nproperty double y\nproperty double z\n"
        f"element face {mesh.n_faces}\n"
        "property list uchar int vertex_indices\nend_header\n"
    )
    face_rows = np.zeros(mesh.n_faces, dtype=[("n", "u1"), ("indices", "<i4", (3,))])
    face_rows["n"] = 3
    face_rows["indices"] = mesh.faces
    body = mesh.vertices.astype("<f8").tobytes() + face_rows.tobytes()
    return header.encode("ascii") + body


def _stl_bytes(mesh: Mesh) -> bytes:
    corners = mesh.vertices[mesh.faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0)
    records = np.zeros(mesh.n_faces, dtype=_STL_RECORD)
    records["normal"] = normals
    records["corners"] = corners
    header = f"vptoolkit binary STL: {mesh.name}".encode("utf-8", errors="replace")[:80]
    return header.ljust(80, b" ") + struct.pack("<I", mesh.n_faces) + records.tobytes()

