"""Read and write the vertex and face elements of ASCII and binary PLY files."""

from __future__ import annotations

import contextvars
import logging
import re
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from vptoolkit.errors import InputError
from vptoolkit.io._polygons import (
    FormatError,
    Polygons,
    Reading,
    parse_counted_polygons,
    parse_floats,
    plural,
    rgba,
)

__all__ = ["ply_bytes", "read_ply"]

_log = logging.getLogger(__name__)

file_label: contextvars.ContextVar[str] = contextvars.ContextVar("file_label", default="PLY file")
"""Name of the file being read, for warnings (set by :func:`vptoolkit.io.load`)."""

_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}  # fmt: skip
_FORMATS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}
_INDEX_NAMES = ("vertex_indices", "vertex_index")

Table = dict[str, "NDArray[np.float64] | Polygons"]
"""The columns read from one PLY element: scalars as ``(n_rows,)`` arrays, lists
as :data:`~vptoolkit.io._polygons.Polygons` pairs."""


class _Property(NamedTuple):
    name: str
    dtype: str  # numpy type code of the value (of each item for a list)
    count_dtype: str | None  # numpy type code of a list's count, None for a scalar


class _Element(NamedTuple):
    name: str
    n_rows: int
    properties: list[_Property]


_NORMALS = ("nx", "ny", "nz")
_COLORS = ("red", "green", "blue", "alpha")
_UV_NAMES = (("s", "t"), ("u", "v"), ("texture_u", "texture_v"))


def read_ply(data: bytes) -> Reading:
    """Read the ``vertex`` and ``face`` elements of an ASCII or binary PLY.

    Besides x, y, z and the face index list, the reader keeps per-vertex
    normals (``nx ny nz``), colours (``red green blue [alpha]``, integers
    0..255 or floats 0..1) and texture coordinates (``s t``, ``u v`` or
    ``texture_u texture_v``) and per-face colours; other elements and
    properties are read past and dropped. The face list may be called
    ``vertex_indices`` or ``vertex_index``. A file without a face element (or
    with no face rows) is a point cloud: its vertices are the points.

    Parameters
    ----------
    data : bytes
        The whole file: a text header, then an ASCII or binary body.

    Returns
    -------
    Reading
        ``vertices (n_vertices, 3) float64`` in file order, the face
        element's index lists as ``(flat_indices, sizes)``, and the normals,
        colours and texture coordinates found.

    Raises
    ------
    FormatError
        If the header is invalid, a needed property is missing, the body
        does not hold exactly the elements the header declares, or a colour
        is outside its range.
    """
    byte_order, elements, body_offset = _read_header(data)
    by_name = {element.name: element for element in elements}
    vertex_element = by_name.get("vertex")
    face_element = by_name.get("face")
    vertex_names: list[str] = []
    if vertex_element is not None:
        vertex_names = [prop.name for prop in vertex_element.properties]
        missing = [axis for axis in ("x", "y", "z") if axis not in vertex_names]
        if missing:
            raise FormatError(f"PLY vertex element has no {'/'.join(missing)} property")
    index_name = None
    face_names: list[str] = []
    if face_element is not None:
        face_names = [prop.name for prop in face_element.properties]
        index_name = next((name for name in _INDEX_NAMES if name in face_names), None)
        if index_name is None:
            raise FormatError("PLY face element has no vertex_indices list")
    vertex_wanted = ("x", "y", "z", *_NORMALS, *_COLORS, *(n for pair in _UV_NAMES for n in pair))
    wanted = {"vertex": tuple(name for name in vertex_wanted if name in vertex_names),
              "face": (index_name, *(name for name in _COLORS if name in face_names))}
    if byte_order:
        tables = _read_binary(data, body_offset, elements, byte_order, wanted)
    else:
        tables = _read_ascii(data, body_offset, elements, wanted)
    vertices = np.zeros((0, 3), dtype=np.float64)
    normals = vertex_colors = vertex_uv = polygon_colors = None
    if vertex_element is not None:
        columns = tables["vertex"]
        vertices = _stack(columns, ("x", "y", "z"))
        if all(name in columns for name in _NORMALS):
            normals = _stack(columns, _NORMALS)
        vertex_colors = _colors(vertex_element, columns, "vertex colours")
        uv_names = next((pair for pair in _UV_NAMES if all(n in columns for n in pair)), None)
        if uv_names is not None:
            vertex_uv = _stack(columns, uv_names)
    polygons: Polygons = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    if face_element is not None and index_name is not None:
        polygons = tables["face"][index_name]  # type: ignore[assignment]
        polygon_colors = _colors(face_element, tables["face"], "face colours")
    return Reading(vertices, polygons, normals=normals, vertex_colors=vertex_colors,
                   polygon_colors=polygon_colors, vertex_uv=vertex_uv)


def _stack(columns: Table, names: tuple[str, ...]) -> NDArray[np.float64]:
    """The scalar columns ``names`` side by side, ``(n_rows, len(names)) float64``."""
    return np.stack([np.asarray(columns[name], dtype=np.float64) for name in names], axis=1)


def _colors(element: _Element, columns: Table, what: str) -> NDArray[np.uint8] | None:
    """The RGBA of an element's ``red green blue [alpha]`` columns, or None without them."""
    if not all(name in columns for name in _COLORS[:3]):
        return None
    names = tuple(name for name in _COLORS if name in columns)
    is_float = any(prop.dtype.startswith("f") for prop in element.properties if prop.name in names)
    return rgba(_stack(columns, names), is_float=is_float, what=what)


def ply_bytes(vertices: NDArray[np.float64], faces: NDArray[np.int64], *, name: str) -> bytes:
    """Return binary little-endian PLY of ``(n_vertices, 3) float64`` vertices and faces.

    Vertices are stored as float64, so they read back exactly; the ``(n_faces, 3)
    int64`` faces are stored as lists of int32 indices.

    Raises
    ------
    InputError
        If there are too many vertices for int32 indices; the message starts with ``name``.
    """
    if len(vertices) > np.iinfo(np.int32).max:
        raise InputError(f"{name}: too many vertices for PLY int32 indices")
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(vertices)}\n"
        "property double x\nproperty double y\nproperty double z\n"
        f"element face {len(faces)}\n"
        "property list uchar int vertex_indices\nend_header\n"
    )
    face_rows = np.zeros(len(faces), dtype=[("n", "u1"), ("indices", "<i4", (3,))])
    face_rows["n"] = 3
    face_rows["indices"] = faces
    body = vertices.astype("<f8").tobytes() + face_rows.tobytes()
    return header.encode("ascii") + body


# --------------------------------------------------------------------------
# header


def _read_header(data: bytes) -> tuple[str, list[_Element], int]:
    """Return the byte order (``""`` for ASCII), the elements and the body offset."""
    if not re.match(rb"ply[ \t]*\r?\n", data):
        raise FormatError("not a PLY file (it does not start with 'ply')")
    match = re.search(rb"(?m)^end_header[ \t]*(\r?\n|$)", data)
    if match is None:
        raise FormatError("PLY header has no end_header line")
    header_lines = data[: match.start()].decode("latin-1").splitlines()
    byte_order = None
    elements: list[_Element] = []
    for number, line in enumerate(header_lines[1:], start=2):
        tokens = line.split()
        if not tokens or tokens[0] in ("comment", "obj_info"):
            continue
        keyword = tokens[0]
        prop = _parse_property(tokens) if keyword == "property" and elements else None
        if keyword == "format" and len(tokens) == 3 and tokens[1] in _FORMATS:
            byte_order = _FORMATS[tokens[1]]
        elif keyword == "element" and len(tokens) == 3 and tokens[2].isdigit():
            elements.append(_Element(tokens[1], int(tokens[2]), []))
        elif prop is not None:
            elements[-1].properties.append(prop)
        else:
            raise FormatError(f"PLY header line {number} is invalid: {line.strip()[:60]!r}")
    if byte_order is None:
        raise FormatError("PLY header has no valid format line")
    return byte_order, elements, match.end()


def _parse_property(tokens: list[str]) -> _Property | None:
    """Parse ``property <type> <name>`` or ``property list <count> <item> <name>``."""
    if len(tokens) == 3 and tokens[1] in _TYPES:
        return _Property(tokens[2], _TYPES[tokens[1]], None)
    if len(tokens) == 5 and tokens[1] == "list" and tokens[2] in _TYPES and tokens[3] in _TYPES:
        return _Property(tokens[4], _TYPES[tokens[3]], _TYPES[tokens[2]])
    return None


def _element_label(element: _Element) -> str:
    """Return ``"12 faces"``, ``"1 vertex"`` or ``"3 'edge' elements"``."""
    if element.name == "vertex":
        return plural(element.n_rows, "vertex", "vertices")
    if element.name == "face":
        return plural(element.n_rows, "face", "faces")
    return f"{element.n_rows} '{element.name}' elements"


# --------------------------------------------------------------------------
# ASCII body


def _read_ascii(
    data: bytes, offset: int, elements: list[_Element], wanted: dict[str, tuple[str | None, ...]]
) -> dict[str, Table]:
    """Read ASCII PLY rows, one element row per line; return the wanted properties."""
    header_line_count = data[:offset].count(b"\n")
    numbers: list[int] = []
    rows: list[list[str]] = []
    for number, line in enumerate(data[offset:].decode("latin-1").splitlines(), start=1):
        tokens = line.split()
        if tokens:
            numbers.append(number + header_line_count)
            rows.append(tokens)
    tables: dict[str, Table] = {}
    start = 0
    for element in elements:
        stop = start + element.n_rows
        if stop > len(rows):
            raise FormatError(
                f"PLY header declares {_element_label(element)}, "
                f"file has {max(len(rows) - start, 0)}"
            )
        names = wanted.get(element.name)
        if names is not None:
            tables[element.name] = _ascii_element(
                element, rows[start:stop], numbers[start:stop], names
            )
        start = stop
    if start < len(rows):
        raise FormatError(f"line {numbers[start]}: unexpected data after the last PLY element")
    return tables


def _ascii_element(
    element: _Element, rows: list[list[str]], numbers: list[int], names: tuple[str | None, ...]
) -> Table:
    props = element.properties
    if all(prop.count_dtype is None for prop in props):
        for row, number in zip(rows, numbers):
            if len(row) != len(props):
                raise FormatError(
                    f"line {number}: {element.name} row has {len(row)} values, "
                    f"expected {len(props)}"
                )
        values = parse_floats(rows, numbers, len(props), f"{element.name} values")
        return {prop.name: values[:, i] for i, prop in enumerate(props) if prop.name in names}
    # the face index list after `lead` scalars; anything else with lists is rare
    list_positions = [i for i, prop in enumerate(props) if prop.count_dtype is not None]
    position = next((i for i, prop in enumerate(props)
                     if prop.name in names and prop.count_dtype is not None), None)
    if position is None or list_positions[0] != position:
        raise FormatError(f"PLY element {element.name!r} has an unsupported ASCII list layout")
    if len(list_positions) != 1:
        # MeshLab (VCGLIB) writes e.g. `list uchar float texcoord` and colours after
        # the indices, and its lines may carry more values than the header says.
        # The index list comes first, so it reads unambiguously; the rest is skipped.
        _log.warning(
            "%s: PLY element %r: reading only its %r list; the %d properties after it "
            "(lists whose lines need not match the header) are ignored",
            file_label.get(), element.name, props[position].name, len(props) - position - 1,
        )
        return {props[position].name: parse_counted_polygons(
            rows, numbers, lead=position, is_exact=False, min_size=0
        )}
    n_trailing = len(props) - position - 1
    rows_without_tail = [row[: len(row) - n_trailing] for row in rows] if n_trailing else rows
    table: Table = {props[position].name: parse_counted_polygons(
        rows_without_tail, numbers, lead=position, is_exact=True, min_size=0
    )}
    trailing = [prop.name for prop in props[position + 1:]]
    if any(name in names for name in trailing):  # scalars after the list, e.g. face colours
        tails = parse_floats([row[len(row) - n_trailing:] for row in rows], numbers, n_trailing,
                             f"{element.name} values")
        table.update({name: tails[:, i] for i, name in enumerate(trailing) if name in names})
    return table


# --------------------------------------------------------------------------
# binary body


def _read_binary(
    data: bytes,
    offset: int,
    elements: list[_Element],
    byte_order: str,
    wanted: dict[str, tuple[str | None, ...]],
) -> dict[str, Table]:
    """Read binary PLY elements in order; return the wanted properties."""
    tables: dict[str, Table] = {}
    for element in elements:
        table, offset = _binary_element(data, offset, element, byte_order)
        names = wanted.get(element.name)
        if names is not None:
            tables[element.name] = {name: table[name] for name in names if name is not None}
    trailing = data[offset:]
    if trailing.strip():
        raise FormatError(f"{len(trailing)} bytes of unexpected data after the last PLY element")
    return tables


def _binary_element(
    data: bytes, offset: int, element: _Element, byte_order: str
) -> tuple[Table, int]:
    """Read one binary element at ``offset``; return its columns and the next offset.

    Scalars become ``(n_rows,)`` arrays, lists become :data:`Polygons` pairs. Rows
    whose lists all have the first row's lengths are read in one numpy call;
    otherwise the rows are walked one at a time.
    """
    props = element.properties
    if element.n_rows == 0 or not props:
        return _empty_table(props), offset
    row_dtype = _first_row_dtype(data, offset, element, byte_order)
    end = offset + element.n_rows * row_dtype.itemsize
    if end > len(data):
        return _binary_rows(data, offset, element, byte_order)
    rows = np.frombuffer(data, dtype=row_dtype, count=element.n_rows, offset=offset)
    list_columns = [i for i, prop in enumerate(props) if prop.count_dtype is not None]
    if not all((rows[f"n{i}"] == rows[f"n{i}"][0]).all() for i in list_columns):
        return _binary_rows(data, offset, element, byte_order)
    table: Table = {}
    for i, prop in enumerate(props):
        column = rows[f"p{i}"]
        if prop.count_dtype is None:
            table[prop.name] = column
        else:
            sizes = rows[f"n{i}"].astype(np.int64)
            table[prop.name] = (column.astype(np.int64).reshape(-1), sizes)
    return table, end


def _empty_table(props: list[_Property]) -> Table:
    empty = np.zeros(0, dtype=np.int64)
    return {
        prop.name: np.zeros(0, dtype=np.float64) if prop.count_dtype is None else (empty, empty)
        for prop in props
    }


def _first_row_dtype(
    data: bytes, offset: int, element: _Element, byte_order: str
) -> np.dtype[np.void]:
    """Return the structured dtype of the row at ``offset``, its list lengths as found there.

    Scalar ``i`` becomes field ``p{i}``; list ``i`` becomes its count ``n{i}``
    and an items field ``p{i}`` of that count.
    """
    fields: list[tuple[str, str] | tuple[str, str, tuple[int, ...]]] = []
    cursor = offset
    for i, prop in enumerate(element.properties):
        if prop.count_dtype is None:
            fields.append((f"p{i}", byte_order + prop.dtype))
            cursor += np.dtype(prop.dtype).itemsize
            continue
        size = _list_length(data, cursor, byte_order + prop.count_dtype, element)
        fields.append((f"n{i}", byte_order + prop.count_dtype))
        fields.append((f"p{i}", byte_order + prop.dtype, (size,)))
        cursor += np.dtype(prop.count_dtype).itemsize + size * np.dtype(prop.dtype).itemsize
    return np.dtype(fields)


def _binary_rows(
    data: bytes, offset: int, element: _Element, byte_order: str
) -> tuple[Table, int]:
    """Walk binary rows with variable list lengths one at a time (slow path)."""
    props = element.properties
    scalars: list[list[float]] = [[] for _ in props]
    list_items: list[list[NDArray[np.int64]]] = [[] for _ in props]
    list_sizes: list[list[int]] = [[] for _ in props]
    for _ in range(element.n_rows):
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
    table: Table = {}
    for i, prop in enumerate(props):
        if prop.count_dtype is None:
            table[prop.name] = np.array(scalars[i], dtype=np.float64)
        else:
            table[prop.name] = (
                np.concatenate(list_items[i]).astype(np.int64),
                np.array(list_sizes[i], dtype=np.int64),
            )
    return table, offset


def _unpack(data: bytes, offset: int, code: str, element: _Element) -> int | float:
    dtype = np.dtype(code)
    if offset + dtype.itemsize > len(data):
        raise _truncated(element)
    value = np.frombuffer(data, dtype=dtype, count=1, offset=offset)[0]
    return value.item()


def _list_length(data: bytes, offset: int, code: str, element: _Element) -> int:
    size = int(_unpack(data, offset, code, element))
    if size < 0:
        raise FormatError(f"PLY {element.name} list has negative length {size}")
    return size


def _truncated(element: _Element) -> FormatError:
    return FormatError(
        f"PLY file ends before the {_element_label(element)} its header declares"
    )
