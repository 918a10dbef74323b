"""The rasteriser's per-thread buffers and the face order that keeps them in cache.

:class:`RasterWorkspace` holds what each thread of :mod:`._raster` writes
(its frame of keys, the written span of each row, the per-face counts and
the projected vertices, and where the views' image statistics are asked
for, the silhouette mask), allocated once per call and reused across batches
of views, within :data:`FRAME_BUDGET_BYTES`. :func:`locality_order`
reorders faces along a Morton curve (:func:`morton_order` of their centroids)
so that consecutive faces touch neighbouring pixels and vertices. Plain numpy:
no compiled code lives here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vptoolkit._numba import numba  # OpenMP before TBB, see vptoolkit._numba


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
    masks : (n_threads, (resolution + 2) ** 2) uint8
        Covered pixels of the view in progress with a background border of
        one pixel, and the marks of the contours traced on them; all zero
        between views. ``(n_threads, 0)`` when drawn without features.
    """

    frames: NDArray[np.int64]
    row_low: NDArray[np.int64]
    row_high: NDArray[np.int64]
    id_counts: NDArray[np.int64]
    touched: NDArray[np.int32]
    screen_x: NDArray[np.int64]
    screen_y: NDArray[np.int64]
    inverse_depth: NDArray[np.float64]
    masks: NDArray[np.uint8]

    @property
    def has_features(self) -> bool:
        """Whether the buffers of the image statistics are there."""
        return bool(self.masks.shape[1] > 0)

    @classmethod
    def allocate(cls, *, resolution: int, n_faces: int, n_vertices: int,
                 features: bool = False) -> RasterWorkspace:
        """Buffers for as many threads as :func:`threads_within_budget` allows.

        With ``features`` the silhouette masks are allocated too (and
        counted in the budget); without, they are empty.
        """
        capacity = histogram_capacity(resolution, n_faces)
        n_threads = threads_within_budget(resolution=resolution, n_faces=n_faces,
                                          n_vertices=n_vertices, capacity=capacity,
                                          features=features)
        masks = silhouette_masks(resolution, n_threads) if features else np.zeros(
            (n_threads, 0), dtype=np.uint8)
        return cls(
            frames=np.zeros((n_threads, resolution * resolution), dtype=np.int64),
            row_low=np.full((n_threads, resolution), resolution, dtype=np.int64),
            row_high=np.full((n_threads, resolution), -1, dtype=np.int64),
            id_counts=np.zeros((n_threads, n_faces + 1), dtype=np.int64),
            touched=np.zeros((n_threads, capacity + 1), dtype=np.int32),
            screen_x=np.zeros((n_threads, n_vertices), dtype=np.int64),
            screen_y=np.zeros((n_threads, n_vertices), dtype=np.int64),
            inverse_depth=np.zeros((n_threads, n_vertices), dtype=np.float64),
            masks=masks,
        )


def silhouette_masks(resolution: int, n_threads: int) -> NDArray[np.uint8]:
    """Zeroed silhouette masks of ``n_threads`` threads (see :class:`RasterWorkspace`)."""
    return np.zeros((n_threads, (resolution + 2) ** 2), dtype=np.uint8)


FRAME_BUDGET_BYTES = 1 << 30
"""Most bytes the per-thread buffers may take together; more threads than fit share views.

At 16384 px one frame is 2 GiB of int64 keys, so each thread's own frame
would multiply that by the thread count (3.2 GB on 2 threads).
"""


def threads_within_budget(*, resolution: int, n_faces: int, n_vertices: int,
                          capacity: int, features: bool = False) -> int:
    """Threads whose buffers (with ``features``, the silhouette masks too) fit
    :data:`FRAME_BUDGET_BYTES`: at least 1, at most numba's.

    The result depends only on the sizes and the thread count, never on the
    views, and every view is drawn the same way on any thread, so the counts
    and statistics are identical whatever it returns.
    """
    per_thread = (8 * resolution * resolution + 16 * resolution + 8 * (n_faces + 1)
                  + 4 * (capacity + 1) + 24 * n_vertices)
    if features:
        per_thread += (resolution + 2) ** 2
    return int(max(1, min(numba.get_num_threads(), FRAME_BUDGET_BYTES // max(per_thread, 1))))


def morton_order(centres: NDArray[np.float64]) -> NDArray[np.int64]:
    """Indices that sort ``(n, 3)`` positions along a Morton (Z-order) curve.

    Each coordinate is scaled from the positions' bounding box to an integer
    grid of 1024 cells per axis and the bits interleaved (x lowest); equal
    codes keep their input order.
    """
    low = centres.min(axis=0)
    extent = np.maximum(centres.max(axis=0) - low, 1e-300)
    grid = ((centres - low) / extent * 1023.0).astype(np.uint64)
    code = np.zeros(len(centres), dtype=np.uint64)
    for bit in range(10):
        for axis in range(3):
            code |= ((grid[:, axis] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit + axis)
    return np.argsort(code, kind="stable")


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
    face_order = morton_order(vertices[faces].mean(axis=1))
    flat = faces[face_order].ravel()
    first_use = np.full(len(vertices), len(flat))
    np.minimum.at(first_use, flat, np.arange(len(flat)))
    used = np.flatnonzero(first_use < len(flat))
    vertex_order = used[np.argsort(first_use[used], kind="stable")]
    renumber = np.zeros(len(vertices), dtype=np.int64)
    renumber[vertex_order] = np.arange(len(vertex_order))
    local_faces = renumber[flat].reshape(-1, 3).astype(np.int32)
    return face_order, vertex_order, local_faces


def histogram_capacity(resolution: int, n_faces: int) -> int:
    """Most distinct faces one view can show: one per pixel, at most all faces."""
    return int(min(resolution * resolution, n_faces))
