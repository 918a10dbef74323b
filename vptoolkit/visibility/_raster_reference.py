"""The rasteriser's kernel as it was before issue 15, kept to check and time the current one.

The same projection, edge set-up and keys as :mod:`._raster`, but the
straightforward loops: each row's covered run solved with one integer
division per edge (:func:`_edge_span`), the inverse depth walked by one float
addition per pixel from the bounding box's left edge, every face drawn that
way whatever its size, and the histogram counted run by run of equal IDs;
signed frame indices and a compare before each store, as then. Only the
projection, the edge set-up and the copy-out of the counts are shared with
the current kernel (they have not changed).
``tests/test_raster_kernel.py`` checks that the current kernel gives the same
counts bit for bit; ``tools/bench_measures.py`` times both in one run.
Selected by ``reference=True`` of :func:`vptoolkit.visibility._raster_view_histograms`.
Compiled in each process that uses it, never cached on disk: numba's cache
checks only this file, not the helpers it inlines from :mod:`._raster`.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from vptoolkit.visibility._raster import (
    _ID_MASK,
    _edge_setup,
    _emit_histogram,
    _faces_viewer,
    _pixel_box,
    _project_vertices,
)


@njit(cache=False, nogil=True, error_model="numpy")
def _edge_span(edge: np.int64, step: np.int64, k_low: np.int64,
               k_high: np.int64) -> tuple[np.int64, np.int64]:
    """Narrow ``[k_low, k_high]`` to the offsets ``k`` with ``edge + k * step >= 0``."""
    if step > 0:
        if edge < 0:
            k_low = max(k_low, -((edge) // step))  # ceil(-edge / step)
    elif step < 0:
        if edge < 0:
            return np.int64(1), np.int64(0)
        k_high = min(k_high, edge // (-step))
    elif edge < 0:
        return np.int64(1), np.int64(0)
    return k_low, k_high


@njit(cache=False, nogil=True, error_model="numpy", inline="always")
def _walk_row(q: float, dq: float, k_low: np.int64, k_high: np.int64, face_id: np.int64,
              frame: NDArray[np.int64], start: np.int64) -> None:
    """Depth-test pixels ``start + k_low .. start + k_high``, walking the depth from ``start``."""
    for _ in range(k_low):
        q += dq
    for k in range(k_low, k_high + 1):
        key = (np.int64(q) << 32) | face_id
        if key > frame[start + k]:
            frame[start + k] = key
        q += dq


@njit(cache=False, nogil=True, error_model="numpy")
def rasterize_view_reference(
    faces: NDArray[np.int32],
    face_normals: NDArray[np.float64],
    face_offsets: NDArray[np.float64],
    is_drawable: NDArray[np.bool_],
    cull_back_faces: bool,
    eye: NDArray[np.float64],
    screen_x: NDArray[np.int64],
    screen_y: NDArray[np.int64],
    inverse_depth: NDArray[np.float64],
    resolution: int,
    frame: NDArray[np.int64],
    row_low: NDArray[np.int64],
    row_high: NDArray[np.int64],
) -> None:
    """:func:`._raster._rasterize_view` the straightforward way: the same frame and spans."""
    for f in range(faces.shape[0]):
        if not is_drawable[f]:
            continue
        if cull_back_faces and not _faces_viewer(face_normals, face_offsets, f, eye):
            continue
        a = faces[f, 0]
        b = faces[f, 1]
        c = faces[f, 2]
        ax, ay = screen_x[a], screen_y[a]
        bx, by = screen_x[b], screen_y[b]
        cx, cy = screen_x[c], screen_y[c]
        x0, x1, y0, y1 = _pixel_box(ax, ay, bx, by, cx, cy, resolution)
        if x0 > x1 or y0 > y1:
            continue
        area2 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
        if area2 == 0:
            continue
        (row_ab, row_bc, row_ca, sx_ab, sy_ab, sx_bc, sy_bc, sx_ca, sy_ca, q_row, dq_dx,
         dq_dy) = _edge_setup(ax, ay, bx, by, cx, cy, inverse_depth[a], inverse_depth[b],
                              inverse_depth[c], area2, x0, y0)
        face_id = np.int64(f + 1)
        for y in range(y0, y1 + 1):
            k_low, k_high = _edge_span(row_ab, sx_ab, np.int64(0), x1 - x0)
            k_low, k_high = _edge_span(row_bc, sx_bc, k_low, k_high)
            k_low, k_high = _edge_span(row_ca, sx_ca, k_low, k_high)
            if k_low <= k_high:
                _walk_row(q_row, dq_dx, k_low, k_high, face_id, frame, y * resolution + x0)
                if x0 + k_low < row_low[y]:
                    row_low[y] = x0 + k_low
                if x0 + k_high > row_high[y]:
                    row_high[y] = x0 + k_high
            row_ab += sy_ab
            row_bc += sy_bc
            row_ca += sy_ca
            q_row += dq_dy


@njit(cache=False, nogil=True, error_model="numpy")
def _collect_histogram_reference(
    resolution: int,
    frame: NDArray[np.int64],
    row_low: NDArray[np.int64],
    row_high: NDArray[np.int64],
    id_counts: NDArray[np.int64],
    touched: NDArray[np.int32],
    out_ids: NDArray[np.int32],
    out_counts: NDArray[np.int32],
) -> int:
    """Per-face pixel counts of the written spans, run by run of equal IDs; clears the frame."""
    n_touched = 0
    for y in range(resolution):
        if row_low[y] > row_high[y]:
            continue
        run_id = np.int64(0)
        run_length = 0
        for x in range(y * resolution + row_low[y], y * resolution + row_high[y] + 1):
            key_id = frame[x] & _ID_MASK
            frame[x] = 0
            if key_id == run_id:
                run_length += 1
                continue
            if run_id != 0:
                if id_counts[run_id] == 0:
                    touched[n_touched] = run_id
                    n_touched += 1
                id_counts[run_id] += run_length
            run_id = key_id
            run_length = 1
        if run_id != 0:
            if id_counts[run_id] == 0:
                touched[n_touched] = run_id
                n_touched += 1
            id_counts[run_id] += run_length
        row_low[y] = resolution
        row_high[y] = -1
    return _emit_histogram(n_touched, id_counts, touched, out_ids, out_counts)


@njit(parallel=True, cache=False, nogil=True, error_model="numpy")
def rasterize_batch_reference(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int32],
    face_normals: NDArray[np.float64],
    face_offsets: NDArray[np.float64],
    is_drawable: NDArray[np.bool_],
    cull_back_faces: bool,
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
    screen_x: NDArray[np.int64],
    screen_y: NDArray[np.int64],
    inverse_depth: NDArray[np.float64],
    out_ids: NDArray[np.int32],
    out_counts: NDArray[np.int32],
    out_lengths: NDArray[np.int64],
) -> None:
    """:func:`._raster.rasterize_batch` with this module's view and histogram."""
    n_views = eyes.shape[0]
    n_threads = frames.shape[0]
    half = resolution / 2.0
    for thread in prange(n_threads):
        for view in range(thread, n_views, n_threads):
            _project_vertices(
                vertices, eyes[view], rights[view], ups[view], forwards[view], focal, half, near,
                far, screen_x[thread], screen_y[thread], inverse_depth[thread],
            )
            rasterize_view_reference(
                faces, face_normals, face_offsets, is_drawable, cull_back_faces, eyes[view],
                screen_x[thread], screen_y[thread], inverse_depth[thread],
                resolution, frames[thread], row_low[thread], row_high[thread],
            )
            out_lengths[view] = _collect_histogram_reference(
                resolution, frames[thread], row_low[thread], row_high[thread],
                id_counts[thread], touched[thread], out_ids[view], out_counts[view],
            )
