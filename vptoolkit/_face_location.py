"""The numba kernel of :func:`vptoolkit.point_features.locate_faces`: nearest face per point.

Written by hand because the libraries that answer nearest-triangle queries
(trimesh's proximity, with rtree; Open3D's ``RaycastingScene``) are optional
or slow for 20000 points, while a grid over the points and the closest-point
test of Ericson, *Real-Time Collision Detection* (2005), section 5.1.5, are
a page of numba.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from vptoolkit._numba import numba  # noqa: F401  (OpenMP before TBB, see vptoolkit._numba)

__all__ = ["nearest_faces"]


@njit(cache=True, nogil=True, error_model="numpy")
def _squared_distance(p: NDArray[np.float64], a: NDArray[np.float64], b: NDArray[np.float64],
                      c: NDArray[np.float64]) -> float:  # pragma: no cover - compiled
    """Squared distance from ``p`` to the triangle ``a b c`` (Ericson's region tests).

    With numpy's error model a degenerate face can give NaN, which no
    comparison prefers, so such a face is never the nearest.
    """
    ab = b - a
    ac = c - a
    ap = p - a
    d1 = ab @ ap
    d2 = ac @ ap
    if d1 <= 0.0 and d2 <= 0.0:
        q = a
    else:
        bp = p - b
        d3 = ab @ bp
        d4 = ac @ bp
        if d3 >= 0.0 and d4 <= d3:
            q = b
        else:
            vc = d1 * d4 - d3 * d2
            if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
                q = a + ab * (d1 / (d1 - d3))
            else:
                cp = p - c
                d5 = ab @ cp
                d6 = ac @ cp
                if d6 >= 0.0 and d5 <= d6:
                    q = c
                else:
                    vb = d5 * d2 - d1 * d6
                    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
                        q = a + ac * (d2 / (d2 - d6))
                    else:
                        va = d3 * d6 - d5 * d4
                        if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
                            q = b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))
                        else:
                            total = va + vb + vc
                            if total == 0.0:  # a degenerate face: its nearest corner
                                da = ap @ ap
                                db = bp @ bp
                                dc = cp @ cp
                                return float(min(da, min(db, dc)))
                            q = a + ab * (vb / total) + ac * (vc / total)
    d = p - q
    return float(d @ d)


@njit(cache=True, nogil=True, error_model="numpy")
def nearest_faces(vertices: NDArray[np.float64], faces: NDArray[np.int64],
                  points: NDArray[np.float64], low: NDArray[np.float64], size: float,
                  shape: NDArray[np.int64], order: NDArray[np.int64], starts: NDArray[np.int64],
                  slack: float) -> NDArray[np.int64]:  # pragma: no cover - compiled
    """Index of the nearest face of every point; ties to the lower index.

    The points are binned in a grid (origin ``low``, cells of side ``size``,
    ``shape`` cells per axis; the points of cell ``k`` are
    ``order[starts[k]:starts[k + 1]]``). Each face is compared with the points
    of the cells its bounding box, widened by ``slack``, touches: every face
    within ``slack`` of a point is compared with it, so a point that found one
    that near has its nearest. Any other point is compared with every face.
    """
    n = points.shape[0]
    best = np.full(n, np.inf)
    found = np.full(n, -1, np.int64)
    for f in range(faces.shape[0]):
        a = vertices[faces[f, 0]]
        b = vertices[faces[f, 1]]
        c = vertices[faces[f, 2]]
        first = np.empty(3, np.int64)
        last = np.empty(3, np.int64)
        for axis in range(3):
            lo = min(a[axis], min(b[axis], c[axis])) - slack - low[axis]
            hi = max(a[axis], max(b[axis], c[axis])) + slack - low[axis]
            first[axis] = max(0, min(shape[axis] - 1, int(np.floor(lo / size))))
            last[axis] = max(0, min(shape[axis] - 1, int(np.floor(hi / size))))
        for i in range(first[0], last[0] + 1):
            for j in range(first[1], last[1] + 1):
                for k in range(first[2], last[2] + 1):
                    key = (i * shape[1] + j) * shape[2] + k
                    for s in range(starts[key], starts[key + 1]):
                        p = order[s]
                        d = _squared_distance(points[p], a, b, c)
                        if d < best[p]:
                            best[p] = d
                            found[p] = f
    for p in range(n):
        if found[p] < 0 or best[p] > slack * slack:
            for f in range(faces.shape[0]):
                d = _squared_distance(points[p], vertices[faces[f, 0]], vertices[faces[f, 1]],
                                      vertices[faces[f, 2]])
                if d < best[p]:
                    best[p] = d
                    found[p] = f
    return found
