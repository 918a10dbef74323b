"""Read files that hold points only: numpy ``.npy`` point arrays.

A PLY, OBJ or OFF without faces is read by its mesh reader and becomes a
point cloud there; this module reads the formats that never hold faces.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vptoolkit.checks import check_npy_header, one_line
from vptoolkit.errors import InputError
from vptoolkit.io._polygons import FormatError, Reading

__all__ = ["read_npy_points"]


def read_npy_points(path: Path) -> Reading:
    """Read an ``(N, 3)`` or ``(N, 6)`` float ``.npy`` array: ``x y z`` then ``nx ny nz``.

    The header is checked against the file's size before anything is
    allocated (:func:`vptoolkit.checks.check_npy_header`), and no pickle is
    ever loaded. The points' own checks (finite, in range, not on one line)
    are :class:`~vptoolkit.point_cloud.PointCloud`'s.

    Parameters
    ----------
    path : Path
        The file, as ``vptool sample`` writes it.

    Returns
    -------
    Reading
        The points as vertices and no polygons; the normals of an ``(N, 6)`` array.

    Raises
    ------
    FormatError
        If the file is not a numpy array, its header promises more than the
        file holds, it does not fit in memory, or it is not a float array of
        shape ``(N, 3)`` or ``(N, 6)``.
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
    if table.ndim != 2 or table.shape[1] not in (3, 6) or table.shape[0] < 1:
        raise FormatError(f"expected an (N, 3) or (N, 6) point array, got shape {table.shape}")
    if not np.issubdtype(table.dtype, np.floating):
        raise FormatError(f"expected float columns, got {table.dtype}")
    empty = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    normals = np.asarray(table[:, 3:], dtype=np.float64) if table.shape[1] == 6 else None
    return Reading(np.asarray(table[:, :3], dtype=np.float64), empty, normals=normals)
