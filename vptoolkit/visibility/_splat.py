"""Point-ID z-buffer splatting on the CPU (numba): the points' counterpart of :mod:`._raster`.

Each point ``p`` of radius ``R`` is drawn as a splat, the solid
``|x|**2 + beta (x . n)**2 <= R**2`` around it (``x`` the offset from
``p``, ``n`` its unit normal, ``beta = 1 / thickness**2 - 1``): a spheroid
of radius ``R`` across the surface and ``thickness * R`` along the normal,
a ball without normals. It is seen through the camera of
:mod:`vptoolkit.camera` with the rays across it taken as parallel (a splat
is a few pixels wide): the pixel whose centre lies ``o`` (in model units,
along ``right`` and ``up``) from the point's projection, at the point's
depth, covers the splat where the ray ``o + t forward`` meets it, at the
depth of the nearer crossing (:func:`_splat_view` tests every pixel of a
small splat's bounding box, and solves each row's run of a bigger one).
The z-buffer keeps the nearest splat at each pixel. Where the splats of
neighbouring points of one surface overlap, a point of the front surface of
their union lies on splat ``i`` and outside splat ``j`` exactly when it is
nearer to ``p_i`` than to ``p_j`` in the splats' metric (for equal radii
and normals), so the overlaps are shared out as the points' Voronoi cells,
whatever their depth order, and each point gets about the pixels of the
surface around it; a disc facing the camera at the point's depth would give
every overlap to the nearer point. Flattened along the normal, a splat seen
edge-on covers few pixels, as a face seen edge-on does.

Keys and counting are the rasteriser's layout: one 64-bit key per pixel,
the quantised depth in the high bits (``2**30 (far - z) / (far - near)``,
clipped to ``[0, 2**30]``; larger is nearer) and ``point + 1`` in the low
32 bits, so a depth test is an integer maximum and ties go to the higher
index; the pixels of each point are counted over the written span of each
row while the frame is cleared. With normals and ``cull``, a point whose
normal points away from the eye (``n . (eye - p) <= 0``) is not drawn, as
the rasteriser culls back faces. Views are split over the threads, each
with its own buffers (:class:`._workspace.RasterWorkspace`). No function is
shared with :mod:`._raster`: numba's on-disk cache checks only the source
file of the function it caches.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange, uint64
from numpy.typing import NDArray

from vptoolkit._numba import numba  # noqa: F401  (OpenMP before TBB, see vptoolkit._numba)

_DEPTH_LEVELS = float(1 << 30)
"""Quantisation of the normalised depth, as :mod:`._raster` quantises its inverse depth."""
_ID_MASK = np.int64(0xFFFFFFFF)
_SMALL_SPLAT = 2.0
"""Splats at most this many pixels in radius are tested pixel by pixel over their bounding
box; bigger ones solve each row's run first."""


@njit(cache=True, nogil=True, error_model="numpy")
def _splat_view(
    points: NDArray[np.float64],
    radii: NDArray[np.float64],
    normals: NDArray[np.float64],
    flatness: float,
    cull: bool,
    eye: NDArray[np.float64],
    right: NDArray[np.float64],
    up: NDArray[np.float64],
    forward: NDArray[np.float64],
    focal: float,
    resolution: int,
    near: float,
    far: float,
    frame: NDArray[np.int64],
    row_low: NDArray[np.int64],
    row_high: NDArray[np.int64],
) -> None:
    """Draw every point's splat into ``frame`` (row-major keys), widening each row's written span.

    In units of the point's radius, the splat is ``|x|**2 + beta (x . n)**2 <= 1``
    around the point (``beta = flatness``, 0 for a ball), ``x = o + t d`` on
    the ray of a pixel, with ``o = o_r right + o_u up`` the pixel's offset at
    the point's depth and ``d = forward``. With ``A = 1 + beta (d . n)**2``
    and ``o_n = o . n``, the ray meets it where ``A t**2 + 2 beta o_n (d . n)
    t + |o|**2 + beta o_n**2 - 1 = 0`` has real roots, that is where ``A
    |o|**2 + beta o_n**2 <= A`` (an ellipse, solved for the run of each row),
    and the depth is the point's plus the radius times the smaller root.
    """
    half = resolution / 2.0
    depth_scale = _DEPTH_LEVELS / (far - near)
    last = resolution - 1
    has_normals = normals.shape[1] == 3
    beta = flatness if has_normals else 0.0
    shrink = 1.0 / (1.0 + beta)
    n_r = 0.0
    n_u = 0.0
    n_d = 0.0
    for i in range(points.shape[0]):
        dx = points[i, 0] - eye[0]
        dy = points[i, 1] - eye[1]
        dz = points[i, 2] - eye[2]
        if has_normals:
            if cull and normals[i, 0] * dx + normals[i, 1] * dy + normals[i, 2] * dz >= 0.0:
                continue
            n_r = normals[i, 0] * right[0] + normals[i, 1] * right[1] + normals[i, 2] * right[2]
            n_u = normals[i, 0] * up[0] + normals[i, 1] * up[1] + normals[i, 2] * up[2]
            n_d = (normals[i, 0] * forward[0] + normals[i, 1] * forward[1]
                   + normals[i, 2] * forward[2])
        p_f = dx * forward[0] + dy * forward[1] + dz * forward[2]
        radius = radii[i]
        if not (p_f > 0.0 and radius > 0.0):
            continue
        pixels_per_unit = focal / p_f
        pixels_per_radius = radius * pixels_per_unit
        # the ellipse's half extents (unit normal: A + beta |n_screen|**2 = 1 + beta)
        half_height = pixels_per_radius * math.sqrt(1.0 - beta * n_u * n_u * shrink)
        cy = half - (dx * up[0] + dy * up[1] + dz * up[2]) * pixels_per_unit
        y0 = max(math.ceil(cy - half_height - 0.5), 0)
        y1 = min(math.floor(cy + half_height - 0.5), last)
        if y0 > y1:
            continue
        half_width = pixels_per_radius * math.sqrt(1.0 - beta * n_r * n_r * shrink)
        cx = half + (dx * right[0] + dy * right[1] + dz * right[2]) * pixels_per_unit
        if cx + half_width < 0.5 or cx - half_width > last + 0.5:
            continue
        step = 1.0 / pixels_per_radius  # one pixel in radii
        a = 1.0 + beta * n_d * n_d
        inverse_a = 1.0 / a
        row_a = a + beta * n_r * n_r
        run_scale = pixels_per_radius / row_a
        depth_step = radius * inverse_a
        key_id = np.int64(i + 1)
        if pixels_per_radius <= _SMALL_SPLAT:
            # every pixel centre of the bounding box, with no branch but the loops
            x0 = max(math.ceil(cx - half_width - 0.5), 0)
            x1 = min(math.floor(cx + half_width - 0.5), last)
            if x0 > x1:
                continue
            for y in range(y0, y1 + 1):
                o_u = (cy - y - 0.5) * step
                o_u_n = o_u * n_u
                c_row = o_u * o_u - 1.0
                base = y * resolution
                for x in range(x0, x1 + 1):
                    o_r = (x + 0.5 - cx) * step
                    o_n = o_r * n_r + o_u_n
                    b = beta * o_n * n_d
                    discriminant = b * b - a * (o_r * o_r + c_row + beta * o_n * o_n)
                    z = p_f - (b + math.sqrt(max(discriminant, 0.0))) * depth_step
                    q = min(max((far - z) * depth_scale, 0.0), _DEPTH_LEVELS)
                    key = (np.int64(q) << 32) | key_id
                    j = uint64(base + x)
                    frame[j] = max(frame[j], key if discriminant >= 0.0 else np.int64(0))
                row_low[y] = min(row_low[y], x0)
                row_high[y] = max(row_high[y], x1)
            continue
        for y in range(y0, y1 + 1):
            o_u = (cy - y - 0.5) * step  # up is against the rows
            # the row's run: row_a o_r**2 + 2 row_b o_r + row_c <= 0
            row_b = beta * n_r * n_u * o_u
            row_c = (a + beta * n_u * n_u) * o_u * o_u - a
            discriminant = row_b * row_b - row_a * row_c
            if discriminant < 0.0:
                continue
            root = math.sqrt(discriminant)
            x0 = max(math.ceil(cx - (row_b + root) * run_scale - 0.5), 0)
            x1 = min(math.floor(cx + (root - row_b) * run_scale - 0.5), last)
            if x0 > x1:
                continue
            row_low[y] = min(row_low[y], x0)
            row_high[y] = max(row_high[y], x1)
            base = y * resolution
            o_u_n = o_u * n_u
            c_row = o_u * o_u - 1.0
            for x in range(x0, x1 + 1):
                o_r = (x + 0.5 - cx) * step
                o_n = o_r * n_r + o_u_n
                b = beta * o_n * n_d
                c = o_r * o_r + c_row + beta * o_n * o_n
                z = p_f - (b + math.sqrt(max(b * b - a * c, 0.0))) * depth_step
                q = min(max((far - z) * depth_scale, 0.0), _DEPTH_LEVELS)
                j = uint64(base + x)
                frame[j] = max(frame[j], (np.int64(q) << 32) | key_id)


@njit(cache=True, nogil=True, error_model="numpy")
def _count_points(
    resolution: int,
    frame: NDArray[np.int64],
    row_low: NDArray[np.int64],
    row_high: NDArray[np.int64],
    id_counts: NDArray[np.int64],
    touched: NDArray[np.int32],
    out_ids: NDArray[np.int32],
    out_counts: NDArray[np.int32],
) -> int:
    """Pixels of each point over the written span of each row, clearing the frame and spans.

    Points come out in the order of their first pixel; ``id_counts`` (indexed
    by ``point + 1``, slot 0 the background) is left zero. Returns the number
    of points seen, written to ``out_ids`` and ``out_counts``.
    """
    n_touched = 0
    for y in range(resolution):
        low = row_low[y]
        high = row_high[y]
        if low > high:
            continue
        base = y * resolution
        for x in range(base + low, base + high + 1):
            i = uint64(x)
            key_id = uint64(frame[i] & _ID_MASK)
            frame[i] = 0
            count = id_counts[key_id]
            id_counts[key_id] = count + 1
            touched[n_touched] = key_id
            n_touched += (count == 0) & (key_id != 0)
        row_low[y] = resolution
        row_high[y] = -1
    id_counts[0] = 0
    for j in range(n_touched):
        key_id = touched[j]
        out_ids[j] = key_id - 1
        out_counts[j] = id_counts[key_id]
        id_counts[key_id] = 0
    return n_touched


@njit(parallel=True, cache=True, nogil=True, error_model="numpy")
def splat_batch(
    points: NDArray[np.float64],
    radii: NDArray[np.float64],
    normals: NDArray[np.float64],
    flatness: float,
    cull: bool,
    eyes: NDArray[np.float64],
    rights: NDArray[np.float64],
    ups: NDArray[np.float64],
    forwards: NDArray[np.float64],
    focal: float,
    resolution: int,
    near: float,
    far: float,
    frames: NDArray[np.int64],
    row_low: NDArray[np.int64],
    row_high: NDArray[np.int64],
    id_counts: NDArray[np.int64],
    touched: NDArray[np.int32],
    out_ids: NDArray[np.int32],
    out_counts: NDArray[np.int32],
    out_lengths: NDArray[np.int64],
) -> None:
    """Per-point pixel histograms of a batch of views.

    ``normals`` (``(n_points, 3)``, or ``(n_points, 0)`` without ``cull``)
    decide which points face each eye. Results of view ``i`` go to
    ``out_ids[i, :out_lengths[i]]`` and ``out_counts[i, :out_lengths[i]]``.
    The per-thread buffers are :class:`._workspace.RasterWorkspace`'s, with
    one ID per point; ``frames`` and ``id_counts`` must be zero, ``row_low``
    ``resolution`` and ``row_high`` -1, and are left so.
    """
    n_views = eyes.shape[0]
    n_threads = frames.shape[0]
    for thread in prange(n_threads):
        for view in range(thread, n_views, n_threads):
            _splat_view(points, radii, normals, flatness, cull, eyes[view], rights[view], ups[view],
                        forwards[view], focal, resolution, near, far, frames[thread],
                        row_low[thread], row_high[thread])
            out_lengths[view] = _count_points(
                resolution, frames[thread], row_low[thread], row_high[thread],
                id_counts[thread], touched[thread], out_ids[view], out_counts[view],
            )


@njit(cache=True, nogil=True, error_model="numpy")
def splat_ids(
    points: NDArray[np.float64],
    radii: NDArray[np.float64],
    normals: NDArray[np.float64],
    flatness: float,
    cull: bool,
    eye: NDArray[np.float64],
    right: NDArray[np.float64],
    up: NDArray[np.float64],
    forward: NDArray[np.float64],
    focal: float,
    resolution: int,
    near: float,
    far: float,
    ids: NDArray[np.int32],
) -> None:
    """The point-ID image of one view: ``ids`` (``resolution**2``, row-major) gets the
    index of the nearest splat at each pixel centre, -1 where none is.

    The splats and the z-buffer are :func:`splat_batch`'s (the same
    :func:`_splat_view`), so a pixel shows the point it counts for.
    """
    frame = np.zeros(resolution * resolution, dtype=np.int64)
    row_low = np.full(resolution, resolution, dtype=np.int64)
    row_high = np.full(resolution, -1, dtype=np.int64)
    _splat_view(points, radii, normals, flatness, cull, eye, right, up, forward, focal,
                resolution, near, far, frame, row_low, row_high)
    for j in range(resolution * resolution):
        ids[j] = np.int32((frame[j] & _ID_MASK) - 1)
