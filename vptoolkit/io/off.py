"""Read and write Object File Format (OFF) text, as ModelNet and Princeton ship it."""

from __future__ import annotations

import re

import numpy as np
from numpy.typing import NDArray

from vptoolkit.io._polygons import (
    FormatError,
    Reading,
    parse_counted_polygons,
    parse_floats,
    rgba,
)

__all__ = ["off_bytes", "read_off"]

_KEYWORDS = {"OFF", "COFF", "NOFF", "CNOFF", "STOFF", "STCOFF", "STNOFF", "STCNOFF"}


def read_off(data: bytes) -> Reading:
    """Read (ST)(C)(N)OFF text, including ModelNet40's ``OFF490 518 0`` header.

    ``#`` starts a comment anywhere; blank lines are skipped. Each vertex line
    gives x y z first, then what the keyword announces in this order: ``N`` a
    normal, ``C`` a colour (3 or 4 values), ``ST`` texture coordinates. Each
    face line gives ``n i_1 ... i_n`` with 0-based indices; 3 or 4 values
    after the indices are the face's colour. Colours whose values are all
    integers are 0..255, others 0..1 (the Princeton OFF convention). The
    header's counts must match the file exactly, and every face needs 3 or
    more vertices.

    Parameters
    ----------
    data : bytes
        The whole file, decoded as Latin-1 text.

    Returns
    -------
    Reading
        The x y z of each vertex line in file order, the face lines as
        ``(flat_indices, sizes)`` (indices 0-based as in the file), and the
        normals, colours and texture coordinates found.

    Raises
    ------
    FormatError
        If the header or a line cannot be read, the counts disagree or a
        colour is outside its range.
    """
    numbers, lines = _content_lines(data.decode("latin-1"))
    keyword, n_vertices, n_faces, body_start = _read_header(lines, numbers)
    n_body = len(lines) - body_start
    if n_body < n_vertices:
        raise FormatError(f"header declares {n_vertices} vertices, file has {n_body}")
    if n_body < n_vertices + n_faces:
        raise FormatError(f"header declares {n_faces} faces, file has {n_body - n_vertices}")
    if n_body > n_vertices + n_faces:
        extra_line = numbers[body_start + n_vertices + n_faces]
        raise FormatError(
            f"line {extra_line}: unexpected data after the {n_vertices} vertices "
            f"and {n_faces} faces the header declares"
        )
    face_start = body_start + n_vertices
    table = _read_vertices(lines[body_start:face_start], numbers[body_start:face_start])
    face_rows = [line.split() for line in lines[face_start:]]
    polygons = parse_counted_polygons(
        face_rows, numbers[face_start:], lead=0, is_exact=False, min_size=3
    )
    reading = _vertex_extras(keyword, table, numbers[body_start:face_start])
    return reading._replace(polygons=polygons,
                            polygon_colors=_face_colors(face_rows, numbers[face_start:]))


def _vertex_extras(keyword: str, table: list[list[str]], numbers: list[int]) -> Reading:
    """The coordinates and the normals, colours and texture coordinates the keyword announces."""
    vertices = parse_floats([row[:3] for row in table], numbers, 3, "vertex coordinates")
    empty = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    width = len(table[0]) if table else 3
    flags = keyword[:-3]  # the letters before OFF: ST, C, N in this order
    n_colour = width - 3 - 3 * ("N" in flags) - 2 * ("ST" in flags)
    if ("C" in flags and n_colour not in (3, 4)) or ("C" not in flags and n_colour != 0):
        return Reading(vertices, empty)  # values the keyword does not explain: coordinates only
    columns = parse_floats([row[3:] for row in table], numbers, width - 3, "vertex values")
    normals = columns[:, :3] if "N" in flags else None
    at = 3 * ("N" in flags)
    colors = None
    if "C" in flags:
        is_float = any(not _is_integer(token)
                       for row in table for token in row[3 + at:3 + at + n_colour])
        colors = rgba(columns[:, at:at + n_colour], is_float=is_float, what="vertex colours")
    uv = columns[:, -2:] if "ST" in flags else None
    return Reading(vertices, empty, normals=normals, vertex_colors=colors, vertex_uv=uv)


def _face_colors(rows: list[list[str]], numbers: list[int]) -> NDArray[np.uint8] | None:
    """The face colours: 3 or 4 values after every face's indices, or None."""
    tails = [row[1 + int(row[0]):] for row in rows]
    if not tails or len({len(tail) for tail in tails}) != 1 or len(tails[0]) not in (3, 4):
        return None
    is_float = any(not _is_integer(token) for tail in tails for token in tail)
    channels = parse_floats(tails, numbers, len(tails[0]), "face colour")
    return rgba(channels, is_float=is_float, what="face colours")


def _is_integer(token: str) -> bool:
    return token.lstrip("+-").isdigit()


def off_bytes(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> bytes:
    """Return OFF text for ``(n_vertices, 3) float64`` vertices and ``(n_faces, 3) int64`` faces.

    Each float is written as its shortest exact repr, so the file reads back exactly.
    """
    lines = [f"OFF\n{len(vertices)} {len(faces)} 0\n"]
    lines.extend(f"{x!r} {y!r} {z!r}\n" for x, y, z in vertices.tolist())
    lines.extend(f"3 {a} {b} {c}\n" for a, b, c in faces.tolist())
    return "".join(lines).encode("ascii")


def _content_lines(text: str) -> tuple[list[int], list[str]]:
    """Return the 1-based numbers and the stripped text of the non-blank lines, comments cut."""
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
        raise FormatError("no geometry (only comments and blank lines)")
    return numbers, lines


def _read_header(lines: list[str], numbers: list[int]) -> tuple[str, int, int, int]:
    """Return the keyword, the vertex count, the face count and the index of the first body line."""
    keyword, rest = re.match(r"([A-Za-z]*)(.*)", lines[0]).groups()  # type: ignore[union-attr]
    if keyword.upper() == "OFF":
        keyword = "OFF"
    if keyword not in _KEYWORDS:
        if keyword.endswith("OFF"):
            raise FormatError(f"unsupported OFF variant {keyword!r}")
        raise FormatError(f"line {numbers[0]}: expected the OFF keyword, found {lines[0][:40]!r}")
    count_tokens, body_start = rest.split(), 1
    if count_tokens and count_tokens[0].upper() == "BINARY":
        raise FormatError("binary OFF is not supported")
    if not count_tokens:
        if len(lines) < 2:
            raise FormatError("header has no vertex and face counts")
        count_tokens, body_start = lines[1].split(), 2
    try:
        counts = [int(token) for token in count_tokens]
    except ValueError:
        counts = []
    if len(counts) not in (2, 3) or min(counts) < 0:
        raise FormatError(
            f"line {numbers[body_start - 1]}: expected 'n_vertices n_faces n_edges', "
            f"found {' '.join(count_tokens)[:40]!r}"
        )
    return keyword, counts[0], counts[1], body_start


def _read_vertices(lines: list[str], numbers: list[int]) -> list[list[str]]:
    """Split the vertex lines: x y z first; all lines need equally many values."""
    rows = [line.split() for line in lines]
    for row, number in zip(rows, numbers):
        if len(row) < 3:
            raise FormatError(f"line {number}: vertex needs 3 coordinates, found {len(row)}")
        # equal lengths catch a header whose vertex count is off by a few lines
        if len(row) != len(rows[0]):
            raise FormatError(
                f"line {number}: vertex has {len(row)} values, the first has "
                f"{len(rows[0])} (does the header count the vertices right?)"
            )
    return rows
