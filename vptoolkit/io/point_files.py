"""Read files that hold points only: NPY, NPZ, XYZ, XYZN, XYZRGB, PTS, PCD, LAS and LAZ.

A PLY, OBJ or OFF without faces is read by its mesh reader and becomes a
point cloud there (the PLY reader already parses vertex normals and colours,
so a cloud PLY needs nothing more). The readers here return a
:class:`~vptoolkit.io._polygons.Reading` without polygons; the points' own
checks (finite, within float32's range, not on one line) are
:class:`~vptoolkit.point_cloud.PointCloud`'s.

Which reader reads what, and why:

* PCD: Open3D's ``read_point_cloud`` (ASCII, binary and compressed bodies,
  packed ``rgb``), imported on first use, after the header's point count has
  been checked against the file's size, so that a header promising 10^9
  points in a small file is refused before anything is allocated.
* LAS and LAZ: laspy (the ``las`` extra), the maintained reader of the
  format, with the same check of the header's count for LAS.
* XYZ, XYZN, XYZRGB, PTS: our own numpy reader. Open3D reads these formats
  too, but skips lines it cannot parse and wraps PTS colours above 255
  without a word; here a bad line is an error naming its line number.
* NPY and NPZ: numpy, never unpickling, each array's header checked against
  its size first (:func:`vptoolkit.checks.check_npy_header`).
"""

from __future__ import annotations

import re
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO, cast

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import check_npy_header, one_line
from vptoolkit.errors import InputError
from vptoolkit.io._polygons import FormatError, Reading, parse_floats, rgba
from vptoolkit.optional import require

__all__ = ["PATH_SUFFIXES", "POINT_READERS"]

_NO_POLYGONS = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))


def read_npy(path: Path) -> Reading:
    """An ``(N, 3)`` or ``(N, 6)`` float ``.npy`` array: ``x y z``, then ``nx ny nz``.

    Raises
    ------
    FormatError
        If the file is not a numpy array, its header promises more than the
        file holds, it does not fit in memory, or it is not a float array of
        one of those shapes.
    """
    try:
        with open(path, "rb") as stream:
            check_npy_header(stream, path.name, path.stat().st_size)
            table = np.load(stream, allow_pickle=False)
    except InputError as err:
        raise FormatError(str(err).removeprefix(f"{path.name}: ")) from err
    except (OSError, ValueError, EOFError) as err:
        raise FormatError(f"cannot read a numpy array ({one_line(err)})") from err
    except MemoryError as err:
        raise FormatError(f"its {path.stat().st_size:,} bytes of points do not fit in "
                          "memory; subsample it first") from err
    return _table_reading(table, "")


def read_npz(path: Path) -> Reading:
    """An ``.npz`` archive: arrays ``points`` (N, 3) and optional ``normals`` (N, 3) and
    ``colors`` (N, 3 or 4; floats 0..1 or integers 0..255), or one ``(N, 3)`` / ``(N, 6)`` array.

    Raises
    ------
    FormatError
        If it is not a zip of ``.npy`` arrays, an array's header promises more
        than its member holds, or the arrays have other names or shapes.
    """
    try:
        with zipfile.ZipFile(path) as archive:
            arrays: dict[str, NDArray[Any]] = {}
            for info in archive.infolist():
                if not info.filename.endswith(".npy"):
                    raise FormatError(f"member {info.filename!r} is not a .npy array")
                with archive.open(info) as stream:
                    check_npy_header(cast("BinaryIO", stream), f"{path.name}:{info.filename}",
                                     info.file_size)
                    arrays[info.filename[:-4]] = np.load(stream, allow_pickle=False)
    except InputError as err:
        raise FormatError(str(err).removeprefix(f"{path.name}:")) from err
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
        raise FormatError(f"cannot read an .npz archive ({one_line(err)})") from err
    if "points" not in arrays:
        if len(arrays) != 1:
            raise FormatError(f"expected an array 'points' or exactly one array, found "
                              f"{sorted(arrays) or 'none'}")
        return _table_reading(next(iter(arrays.values())), "the array ")
    unknown = sorted(set(arrays) - {"points", "normals", "colors"})
    if unknown:
        raise FormatError(f"unknown arrays {unknown}; expected points, normals, colors")
    points = _float_columns(arrays["points"], (3,), "points")
    normals = _float_columns(arrays["normals"], (3,), "normals") if "normals" in arrays else None
    colors = None
    if "colors" in arrays:
        raw = arrays["colors"]
        colors = rgba(_float_columns(raw, (3, 4), "colors"),
                      is_float=np.issubdtype(raw.dtype, np.floating), what="point colours")
    for name, values in (("normals", normals), ("colors", colors)):
        if values is not None and len(values) != len(points):
            raise FormatError(f"{len(values)} {name} for {len(points)} points")
    return Reading(points, _NO_POLYGONS, normals=normals, vertex_colors=colors)


def _table_reading(table: NDArray[Any], what: str) -> Reading:
    """The points (and normals) of an ``(N, 3)`` or ``(N, 6)`` float array."""
    if table.ndim != 2 or table.shape[1] not in (3, 6) or table.shape[0] < 1:
        raise FormatError(f"expected {what}an (N, 3) or (N, 6) point array, "
                          f"got shape {table.shape}")
    if not np.issubdtype(table.dtype, np.floating):
        raise FormatError(f"expected float columns, got {table.dtype}")
    normals = np.asarray(table[:, 3:], dtype=np.float64) if table.shape[1] == 6 else None
    return Reading(np.asarray(table[:, :3], dtype=np.float64), _NO_POLYGONS, normals=normals)


def _float_columns(values: NDArray[Any], widths: tuple[int, ...], name: str) -> NDArray[np.float64]:
    if values.ndim != 2 or values.shape[1] not in widths or not (
            np.issubdtype(values.dtype, np.floating) or np.issubdtype(values.dtype, np.integer)):
        shapes = " or ".join(f"(N, {width})" for width in widths)
        raise FormatError(f"{name} must be a number array {shapes}, got {values.shape} "
                          f"{values.dtype}")
    return np.asarray(values, dtype=np.float64)


# --------------------------------------------------------------------------
# text formats


def _text_rows(data: bytes) -> tuple[list[list[str]], list[int]]:
    """The whitespace-split non-blank lines (``#`` starts a comment) and their numbers."""
    rows: list[list[str]] = []
    numbers: list[int] = []
    for number, line in enumerate(data.decode("latin-1").splitlines(), start=1):
        tokens = line.partition("#")[0].replace(",", " ").split()
        if tokens:
            rows.append(tokens)
            numbers.append(number)
    return rows, numbers


def _columns(rows: list[list[str]], numbers: list[int], widths: tuple[int, ...],
             layout: str) -> NDArray[np.float64]:
    """All rows as floats; every row has the first row's width, one of ``widths``."""
    if not rows:
        raise FormatError("holds no points")
    width = len(rows[0])
    for row, number in zip(rows, numbers):
        if len(row) != width or width not in widths:
            raise FormatError(f"line {number}: expected {layout} "
                              f"({' or '.join(map(str, widths))} values), found {len(row)}")
    return parse_floats(rows, numbers, width, "point values")


def _colour_columns(values: NDArray[np.float64], rows: list[list[str]], start: int,
                    *, integers: bool | None = None) -> NDArray[np.uint8]:
    """RGB columns from ``start``: integers 0..255 when every value is an integer, else 0..1."""
    if integers is None:
        integers = all(re.fullmatch(r"[+-]?\d+", token) is not None
                       for row in rows for token in row[start:start + 3])
    return rgba(values[:, start:start + 3], is_float=not integers, what="point colours")


def read_xyz(data: bytes, suffix: str) -> Reading:
    """``x y z`` (XYZ), ``x y z nx ny nz`` (XYZN) or ``x y z r g b`` (XYZRGB) per line.

    XYZRGB colours are floats 0..1 (Open3D's convention), or integers 0..255
    when every colour value is an integer.
    """
    rows, numbers = _text_rows(data)
    if suffix == ".xyz":
        table = _columns(rows, numbers, (3,), "x y z")
        return Reading(table, _NO_POLYGONS)
    if suffix == ".xyzn":
        table = _columns(rows, numbers, (6,), "x y z nx ny nz")
        return Reading(table[:, :3], _NO_POLYGONS, normals=table[:, 3:])
    table = _columns(rows, numbers, (6,), "x y z r g b")
    return Reading(table[:, :3], _NO_POLYGONS, vertex_colors=_colour_columns(table, rows, 3))


def read_pts(data: bytes) -> Reading:
    """A PTS scan: an optional first line with the point count, then ``x y z [intensity] [r g b]``.

    Rows of 3 or 4 values have no colour; rows of 6 (``x y z r g b``) or 7
    (``x y z intensity r g b``) carry integer colours 0..255. A count line
    must match the number of rows.
    """
    rows, numbers = _text_rows(data)
    if rows and len(rows[0]) == 1:
        try:
            declared = int(rows[0][0])
        except ValueError as err:
            raise FormatError(f"line {numbers[0]}: expected the point count, "
                              f"found {rows[0][0]!r}") from err
        rows, numbers = rows[1:], numbers[1:]
        if declared != len(rows):
            raise FormatError(f"header declares {declared} points, file has {len(rows)}")
    table = _columns(rows, numbers, (3, 4, 6, 7), "x y z [intensity] [r g b]")
    colors = None
    if table.shape[1] in (6, 7):
        colors = _colour_columns(table, rows, table.shape[1] - 3, integers=True)
    return Reading(table[:, :3], _NO_POLYGONS, vertex_colors=colors)


# --------------------------------------------------------------------------
# PCD and LAS, through the maintained readers


def _pcd_header(data: bytes) -> dict[str, list[str]]:
    """The PCD header's fields, up to and including ``DATA``."""
    header: dict[str, list[str]] = {}
    for line in data[:65536].decode("latin-1").splitlines():
        tokens = line.partition("#")[0].split()
        if not tokens:
            continue
        header[tokens[0].upper()] = tokens[1:]
        if tokens[0].upper() == "DATA":
            return header
    raise FormatError("not a PCD file (no DATA line in its header)")


def read_pcd(path: Path) -> Reading:
    """A PCD file through Open3D, its header's count checked against the file's size first.

    Raises
    ------
    FormatError
        If the header is unreadable, declares no points or more than the
        file can hold (binary: ``points x row bytes``; ASCII: two bytes per
        value at least), or Open3D reads fewer points than declared.
    """
    with open(path, "rb") as stream:
        header = _pcd_header(stream.read(65536))
    n_bytes = path.stat().st_size
    try:
        declared = int(header.get("POINTS", ["-1"])[0])
        sizes = [int(size) for size in header.get("SIZE", [])]
        counts = [int(count) for count in header.get("COUNT", ["1"] * len(sizes))]
    except ValueError as err:
        raise FormatError(f"unreadable PCD header ({one_line(err)})") from err
    kind = (header.get("DATA") or ["?"])[0].lower()
    if declared <= 0:
        raise FormatError("PCD header declares no points" if declared == 0
                          else "PCD header has no valid POINTS line")
    row_bytes = sum(size * count for size, count in zip(sizes, counts)) or 12
    needed = {"binary": declared * row_bytes, "ascii": declared * 2 * sum(counts or [3]),
              "binary_compressed": declared * row_bytes // 256}.get(kind)
    if needed is None:
        raise FormatError(f"unknown PCD DATA kind {kind!r}")
    if needed > n_bytes:
        raise FormatError(f"PCD header declares {declared:,} points, more than its "
                          f"{n_bytes:,} bytes can hold")
    o3d = require("open3d", extra="measures")
    cloud = o3d.io.read_point_cloud(str(path), format="pcd", remove_nan_points=False,
                                    remove_infinite_points=False)
    points = np.asarray(cloud.points, dtype=np.float64)
    if len(points) != declared:
        raise FormatError(f"PCD header declares {declared:,} points, Open3D read {len(points):,} "
                          "(a damaged or truncated file)")
    normals = np.asarray(cloud.normals, dtype=np.float64) if cloud.has_normals() else None
    colors = (rgba(np.asarray(cloud.colors, dtype=np.float64), is_float=True,
                   what="point colours") if cloud.has_colors() else None)
    return Reading(points, _NO_POLYGONS, normals=normals, vertex_colors=colors)


def read_las(path: Path) -> Reading:
    """A LAS or LAZ point cloud through laspy (the ``las`` extra): scaled x y z, and colours.

    LAS colours are 16-bit; a file whose colour values all fit in 8 bits (as
    some writers store them) is read as 0..255.

    Raises
    ------
    FormatError
        If laspy cannot read the file, it holds no points, or (LAS) its
        header declares more point records than the file holds.
    MissingDependencyError
        If laspy is not installed.
    """
    laspy = require("laspy", extra="las")
    try:
        with laspy.open(str(path)) as reader:
            header = reader.header
            declared = int(header.point_count)
            if declared == 0:
                raise FormatError("holds no points (its header declares 0)")
            needed = header.offset_to_point_data + declared * header.point_format.size
            if path.suffix.lower() == ".las" and needed > path.stat().st_size:
                raise FormatError(f"LAS header declares {declared:,} points, more than its "
                                  f"{path.stat().st_size:,} bytes can hold")
            las = reader.read()
    except FormatError:
        raise
    except Exception as err:  # laspy's own errors, chained
        raise FormatError(f"cannot read LAS/LAZ ({type(err).__name__}: {one_line(err)})") from err
    points = np.stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)], axis=1)
    colors = None
    if "red" in las.point_format.dimension_names:
        channels = np.stack([np.asarray(las.red), np.asarray(las.green), np.asarray(las.blue)],
                            axis=1).astype(np.float64)
        if channels.max() > 255:
            channels = channels / 65535.0 * 255.0
        colors = rgba(np.rint(channels), is_float=False, what="point colours")
    return Reading(points.astype(np.float64), _NO_POLYGONS, vertex_colors=colors)


POINT_READERS: dict[str, Callable[[Path, bytes], Reading]] = {
    ".npy": lambda path, data: read_npy(path),
    ".npz": lambda path, data: read_npz(path),
    ".xyz": lambda path, data: read_xyz(data, ".xyz"),
    ".xyzn": lambda path, data: read_xyz(data, ".xyzn"),
    ".xyzrgb": lambda path, data: read_xyz(data, ".xyzrgb"),
    ".pts": lambda path, data: read_pts(data),
    ".pcd": lambda path, data: read_pcd(path),
    ".las": lambda path, data: read_las(path),
    ".laz": lambda path, data: read_las(path),
}
"""The reader of each points-only suffix, given the file's path and its bytes
(empty for the formats read from the path: NPY, NPZ, PCD, LAS, LAZ)."""

PATH_SUFFIXES: tuple[str, ...] = (".npy", ".npz", ".pcd", ".las", ".laz")
"""The points-only suffixes whose readers read the file themselves, so the loader does not."""
