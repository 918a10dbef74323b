"""Per-face pixel histograms of many views on the CPU (numba), the default backend.

Each view is scan-converted by :mod:`._scan` into one 64-bit key per pixel
(quantised inverse depth above, ``face + 1`` below; the largest key is the
visible face) and counted here. The per-face histogram of each view is
taken while clearing the frame, only over the span of each row that was
written, so the full frame is never scanned; it is counted pixel by pixel or
run by run of equal IDs, whichever the thread's previous view suggests (the
same counts). Views are split over the threads; each thread owns its
buffers (:class:`RasterWorkspace`), so there are no atomics, and faces are
put in an order that keeps those buffers in cache (:func:`locality_order`).

The kernel before issue 15 is :mod:`._raster_reference`:
``tools/bench_measures.py`` times both and ``tests/test_raster_kernel.py``
checks that they give the same pixels bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import get_num_threads, njit, prange, uint64
from numpy.typing import NDArray

from vptoolkit._numba import numba  # noqa: F401  (OpenMP before TBB, see vptoolkit._numba)
from vptoolkit.visibility._scan import _project_vertices, _rasterize_view

_ID_MASK = np.int64(0xFFFFFFFF)


@dataclass
class RasterWorkspace:
    """Per-thread buffers reused across batches of views.

    Attributes
    ----------
    frames : (n_threads, resolution * resolution) int64
        Depth-and-ID keys; zero means background. Cleared by the kernel.
    row_low, row_high : (n_threads, resolution) int64
        Written span of each row (``low > high`` when the row is untouched).
    id_counts : (n_threads, n_faces + 1) int64
        Pixel count per key ID (``face + 1``; 0 is the background) of the
        view in progress; cleared by the kernel.
    touched : (n_threads, capacity + 1) int32
        IDs with a non-zero count in the view in progress, and one slot for
        the branch-free append.
    screen_x, screen_y : (n_threads, n_vertices) int64
        Fixed-point vertex positions of the view in progress.
    inverse_depth : (n_threads, n_vertices) float64
        Normalised inverse depth of each vertex in [0, 1] (1 = nearest).
    """

    frames: NDArray[np.int64]
    row_low: NDArray[np.int64]
    row_high: NDArray[np.int64]
    id_counts: NDArray[np.int64]
    touched: NDArray[np.int32]
    screen_x: NDArray[np.int64]
    screen_y: NDArray[np.int64]
    inverse_depth: NDArray[np.float64]

    @classmethod
    def allocate(cls, *, resolution: int, n_faces: int, n_vertices: int) -> RasterWorkspace:
        capacity = histogram_capacity(resolution, n_faces)
        n_threads = threads_within_budget(resolution=resolution, n_faces=n_faces,
                                          n_vertices=n_vertices, capacity=capacity)
        return cls(
            frames=np.zeros((n_threads, resolution * resolution), dtype=np.int64),
            row_low=np.full((n_threads, resolution), resolution, dtype=np.int64),
            row_high=np.full((n_threads, resolution), -1, dtype=np.int64),
            id_counts=np.zeros((n_threads, n_faces + 1), dtype=np.int64),
            touched=np.zeros((n_threads, capacity + 1), dtype=np.int32),
            screen_x=np.zeros((n_threads, n_vertices), dtype=np.int64),
            screen_y=np.zeros((n_threads, n_vertices), dtype=np.int64),
            inverse_depth=np.zeros((n_threads, n_vertices), dtype=np.float64),
        )


FRAME_BUDGET_BYTES = 1 << 30
"""Most bytes the per-thread buffers may take together; more threads than fit share views.

At 16384 px one frame is 2 GiB of int64 keys, so each thread's own frame
would multiply that by the thread count (3.2 GB on 2 threads).
"""


def threads_within_budget(*, resolution: int, n_faces: int, n_vertices: int,
                          capacity: int) -> int:
    """Threads whose buffers fit :data:`FRAME_BUDGET_BYTES`: at least 1, at most numba's.

    The result depends only on the sizes and the thread count, never on the
    views, and every view is drawn the same way on any thread, so the counts
    are identical whatever it returns.
    """
    per_thread = (8 * resolution * resolution + 16 * resolution + 8 * (n_faces + 1)
                  + 4 * (capacity + 1) + 24 * n_vertices)
    return int(max(1, min(get_num_threads(), FRAME_BUDGET_BYTES // max(per_thread, 1))))


def locality_order(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int32]]:
    """Reorder faces along a Morton curve and vertices by first use.

    Neighbouring faces then touch neighbouring pixels and vertices, which
    keeps the frame and vertex buffers in cache; vertices no face uses are
    dropped.

    Returns
    -------
    face_order : (n_faces,) int64
        Original index of each reordered face.
    vertex_order : (n_used,) int64
        Original index of each kept vertex.
    local_faces : (n_faces, 3) int32
        The reordered faces, indexing the kept vertices.
    """
    centroids = vertices[faces].mean(axis=1)
    low = centroids.min(axis=0)
    extent = np.maximum(centroids.max(axis=0) - low, 1e-300)
    grid = ((centroids - low) / extent * 1023.0).astype(np.uint64)
    code = np.zeros(len(faces), dtype=np.uint64)
    for bit in range(10):
        for axis in range(3):
            code |= ((grid[:, axis] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit + axis)
    face_order = np.argsort(code, kind="stable")
    flat = faces[face_order].ravel()
    used, first_use = np.unique(flat, return_index=True)
    vertex_order = used[np.argsort(first_use, kind="stable")]
    renumber = np.zeros(len(vertices), dtype=np.int64)
    renumber[vertex_order] = np.arange(len(vertex_order))
    local_faces = renumber[flat].reshape(-1, 3).astype(np.int32)
    return face_order, vertex_order, local_faces


def histogram_capacity(resolution: int, n_faces: int) -> int:
    """Most distinct faces one view can show: one per pixel, at most all faces."""
    return int(min(resolution * resolution, n_faces))


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _emit_histogram(n_touched: int, id_counts: NDArray[np.int64], touched: NDArray[np.int32],
                    out_ids: NDArray[np.int32], out_counts: NDArray[np.int32]) -> int:
    """Copy the counts of the ``touched`` IDs out as ``(face, pixels)`` and zero them."""
    id_counts[0] = 0
    for j in range(n_touched):
        key_id = touched[j]
        out_ids[j] = key_id - 1
        out_counts[j] = id_counts[key_id]
        id_counts[key_id] = 0
    return n_touched


_RUN_PIXELS = 128
"""Mean pixels per seen face above which a thread counts its next view run by run."""


@njit(cache=True, nogil=True, error_model="numpy")
def _collect_histogram(
    resolution: int,
    frame: NDArray[np.int64],
    row_low: NDArray[np.int64],
    row_high: NDArray[np.int64],
    id_counts: NDArray[np.int64],
    touched: NDArray[np.int32],
    out_ids: NDArray[np.int32],
    out_counts: NDArray[np.int32],
    count_runs: bool,
) -> tuple[int, int]:
    """Pixel count of each face over the written span of each row, clearing the frame.

    Faces come out in the order of their first pixel (row by row, left to
    right). ``id_counts`` is indexed by the key's ID ``face + 1``; slot 0 counts
    the background and is reset here. Two ways give the same counts in the
    same order: with ``count_runs``, each run of equal IDs is counted first
    and added at once (fast when faces cover many pixels: a row of a big
    face is one run); otherwise every pixel adds one to its ID and is
    appended to ``touched`` with no branch, the append kept only when the
    count was zero (fast for many small faces, whose runs are short).

    Returns
    -------
    n_seen, n_pixels
        Faces seen (written to ``out_ids[:n_seen]`` and ``out_counts[:n_seen]``)
        and pixels scanned.
    """
    n_touched = 0
    n_pixels = 0
    for y in range(resolution):
        low = row_low[y]
        high = row_high[y]
        if low > high:
            continue
        base = y * resolution
        n_pixels += high - low + 1
        if count_runs:
            n_touched = _count_row_runs(frame, base + low, base + high, id_counts, touched,
                                        n_touched)
        else:
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
    return _emit_histogram(n_touched, id_counts, touched, out_ids, out_counts), n_pixels


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _count_row_runs(frame: NDArray[np.int64], first: np.int64, last: np.int64,
                    id_counts: NDArray[np.int64], touched: NDArray[np.int32],
                    n_touched: int) -> int:
    """Count and clear ``frame[first:last + 1]`` run by run of equal IDs; the new ``n_touched``."""
    run_id = uint64(0)
    run_length = 0
    for x in range(first, last + 1):
        i = uint64(x)
        key_id = uint64(frame[i] & _ID_MASK)
        frame[i] = 0
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
    return n_touched


@njit(parallel=True, cache=True, nogil=True, error_model="numpy")
def rasterize_batch(
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
    """Per-face pixel histograms of a batch of views.

    ``face_normals`` and ``face_offsets`` are the unnormalised face planes
    ``n . x = offset``; a face is front-facing from ``eye`` when
    ``n . eye > offset``. ``is_drawable`` is False for faces never drawn
    (zero area). Results of view ``i`` go to ``out_ids[i, :out_lengths[i]]``
    and ``out_counts[i, :out_lengths[i]]``.
    """
    n_views = eyes.shape[0]
    n_threads = frames.shape[0]
    half = resolution / 2.0
    for thread in prange(n_threads):
        count_runs = False  # decided from the thread's previous view: the same counts either way
        for view in range(thread, n_views, n_threads):
            _project_vertices(
                vertices, eyes[view], rights[view], ups[view], forwards[view], focal, half, near,
                far, screen_x[thread], screen_y[thread], inverse_depth[thread],
            )
            _rasterize_view(
                faces, face_normals, face_offsets, is_drawable, cull_back_faces, eyes[view],
                screen_x[thread], screen_y[thread], inverse_depth[thread],
                resolution, frames[thread], row_low[thread], row_high[thread],
            )
            n_seen, n_pixels = _collect_histogram(
                resolution, frames[thread], row_low[thread], row_high[thread],
                id_counts[thread], touched[thread], out_ids[view], out_counts[view], count_runs,
            )
            out_lengths[view] = n_seen
            count_runs = n_pixels > _RUN_PIXELS * n_seen
