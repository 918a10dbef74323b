"""DVS, depth-based visual stability.

``DVS(v) = |{v' in N(v) : NCD(D_v, D_v') < 0.87}|``, the number of
neighbouring views whose depth image is similar to the view's, similarity
being the normalised compression distance of the two depth images::

    NCD(x, y) = (C(xy) - min(C(x), C(y))) / max(C(x), C(y))

with ``C`` the compressed size in bytes and ``xy`` the two images side by
side (each row of ``x`` followed by the same row of ``y``), as quoniam (the
survey authors' framework) joins them. Higher is better: a view that looks
like many of the views around it is stable.

Ours differs from quoniam's in three ways, each for its cost:

* the images are the views' 64 x 64 depth thumbnails
  (:attr:`~vptoolkit.visibility.features.ViewFeatures.depth_thumbnail`:
  0 background, nearer is brighter), not the full depth images;
* ``C`` is zlib's raw deflate at its default level 6 (no header or
  checksum, which would add the same bytes to every size), not bzip2
  through 7-Zip. Level 9 compresses these images by under 1 % more at
  about seven times the cost; the count is sensitive to the compressor all
  the same, because many NCDs lie near the threshold (on the bundled
  torus at 1024 px, level 9 changes the count of 599 of 1000 views, mean
  5.4 against 4.5, with a rank correlation of 0.89 to level 6);
* ``N(v)`` is the :data:`NEIGHBOURS` nearest views by angle, not every
  other view. Comparing all pairs of 1000 views is about 500 000
  compressions; views far apart on the sphere show different depth images
  and hardly ever pass the threshold, so the count is decided near the
  view, and 12 neighbours (about two rings of the Fibonacci sphere, within
  some 13 degrees of the view for 1000 views) cost about 6 100
  compressions, each unordered pair once. A fixed count rather than a
  fixed angle keeps the cost linear in the views and the range 0 to 12
  whatever their number; the radius in degrees grows as the views thin
  out, so with fewer views each neighbour lies farther away and fewer
  pass.

The compressions run on as many threads as numba may use in the calling
thread (one in a worker process of a build), :data:`CHUNK` images a task:
zlib releases the GIL while it compresses. The sizes do not depend on it.

The threshold 0.87 is quoniam's. Small deflated thumbnails give larger
distances than bzip2 on full images: on the bundled bunny at 256 px the
median NCD of a view and one of its 12 nearest views is about 0.91 with
1000 views (DVS from 0 to 6) and 0.94 with 200 views (DVS almost always
0), so the count separates views only with dense sampling.

A view that sees nothing: NaN (normalised to the worst), and a neighbour
that sees nothing never counts as similar (two empty images compress
together to almost nothing, which would make the empty views the most
stable). Quoniam compares every view, empty or not.

Source: Vázquez, "Automatic view selection through depth-based view stability
analysis" (2009); survey of Bonaventura et al. (2018).
"""

import zlib
from concurrent.futures import ThreadPoolExecutor
from contextlib import nullcontext
from typing import Final

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog._stability import both_seen, neighbour_pairs
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.measure import Measure

NEIGHBOURS: Final = 12
"""Nearest views each view is compared with."""

THRESHOLD: Final = 0.87
"""Two depth images with an NCD below this are similar (quoniam's value)."""


LEVEL: Final = 6
"""zlib's compression level of ``C`` (its default)."""

CHUNK: Final = 256
"""Images one task of the thread pool compresses."""


def compressed_size(image: NDArray[np.uint8]) -> int:
    """``C(x)``: bytes of the image's raw deflate stream at :data:`LEVEL`, rows in order."""
    return len(zlib.compress(np.ascontiguousarray(image).tobytes(), LEVEL, -15))


def compressed_sizes(thumbnails: NDArray[np.uint8], pairs: NDArray[np.int64],
                     pool: ThreadPoolExecutor | None) -> NDArray[np.float64]:
    """:func:`compressed_size` of each row of ``pairs``: its thumbnails side by side.

    Parameters
    ----------
    thumbnails : (n_views, h, w) uint8
        The depth thumbnails.
    pairs : (n, k) int64
        The views of each image: one (``k = 1``, the thumbnail itself) or
        two (``k = 2``, each row of the first followed by the same row of the
        second).
    pool : ThreadPoolExecutor or None
        Threads that compress :data:`CHUNK` images per task (zlib releases
        the GIL while it compresses); None compresses here.

    Returns
    -------
    sizes : (n,) float64
        ``C`` of each image, in bytes.
    """
    def chunk_sizes(start: int) -> list[int]:
        chunk = pairs[start:start + CHUNK]
        images = np.concatenate([thumbnails[chunk[:, k]] for k in range(pairs.shape[1])], axis=2)
        return [compressed_size(image) for image in images]

    starts = range(0, len(pairs), CHUNK)
    parts = map(chunk_sizes, starts) if pool is None else pool.map(chunk_sizes, starts)
    return np.array([size for part in parts for size in part], dtype=np.float64)


def _compute(data: ViewData) -> NDArray[np.float64]:
    from vptoolkit._numba import numba

    thumbnails = data.features.depth_thumbnail
    pairs, slots = neighbour_pairs(data, NEIGHBOURS)
    valid = np.flatnonzero(both_seen(data, pairs))
    seen = np.flatnonzero(data.seen)
    sizes = np.zeros(data.n_views)
    workers = min(numba.get_num_threads(), (len(valid) + CHUNK - 1) // CHUNK)
    with ThreadPoolExecutor(workers) if workers > 1 else nullcontext() as pool:
        sizes[seen] = compressed_sizes(thumbnails, seen[:, None], pool)
        joined = compressed_sizes(thumbnails, pairs[valid], pool)
    first, second = sizes[pairs[valid, 0]], sizes[pairs[valid, 1]]
    low, high = np.minimum(first, second), np.maximum(first, second)
    similar = np.zeros(len(pairs), dtype=np.bool_)
    similar[valid] = (joined - low) / high < THRESHOLD
    values = np.full(data.n_views, np.nan)
    values[data.seen] = similar[slots].sum(axis=1)[data.seen]
    return values


MEASURE = Measure(
    name="DVS",
    title="depth-based visual stability",
    family="stability",
    higher_is_better=True,
    needs=frozenset({"depth", "neighbours"}),
    compute=_compute,
    source="Vázquez (2009)",
)
