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
* ``C`` is zlib's raw deflate at level 9 (no header or checksum, which
  would add the same bytes to every size), not bzip2 through 7-Zip;
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
from typing import Final

import numpy as np
from numpy.typing import NDArray

from vptoolkit.measures.catalog._stability import both_seen, neighbour_pairs
from vptoolkit.measures.data import ViewData
from vptoolkit.measures.registry import Measure

NEIGHBOURS: Final = 12
"""Nearest views each view is compared with."""

THRESHOLD: Final = 0.87
"""Two depth images with an NCD below this are similar (quoniam's value)."""


def compressed_size(image: NDArray[np.uint8]) -> int:
    """``C(x)``: bytes of the image's raw deflate stream at level 9, rows in order."""
    packer = zlib.compressobj(level=9, wbits=-15)
    return len(packer.compress(np.ascontiguousarray(image).tobytes()) + packer.flush())


def _compute(data: ViewData) -> NDArray[np.float64]:
    thumbnails = data.features.depth_thumbnail
    pairs, slots = neighbour_pairs(data, NEIGHBOURS)
    valid = both_seen(data, pairs)
    sizes = np.zeros(data.n_views)
    for view in np.flatnonzero(data.seen):
        sizes[view] = compressed_size(thumbnails[view])
    similar = np.zeros(len(pairs), dtype=np.bool_)
    for row in np.flatnonzero(valid):
        first, second = pairs[row]
        joined = compressed_size(np.hstack([thumbnails[first], thumbnails[second]]))
        low, high = sorted((sizes[first], sizes[second]))
        similar[row] = (joined - low) / high < THRESHOLD
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
    rank=1,
)
