"""The rasteriser gives exactly the pixels of its definition.

Three levels: whole views of two sample meshes through the driver, against
per-face pixel counts frozen in ``tests/assets/raster_counts.npz`` (any change
of a pixel fails; the file is rewritten, by running this module, only for a
deliberate change of what the kernel draws); screen-space triangles put on
the fixed-point grid by hand (shared edges through pixel centres, slivers,
frame borders, boxes of every path's size, depth ties) against
:func:`_draw_by_definition`, a per-pixel test of the three edge functions
with the inverse depth walked by one float addition per pixel in numpy; and
the inverse-depth runs, also over whole narrow rows, against that walk, at
binade edges and ties.
"""


import numpy as np
import pytest

from fixtures.paths import ASSETS
from vptoolkit.camera import Camera
from vptoolkit.io import load_mesh
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere
from vptoolkit.visibility import face_id_images, iter_view_histograms
from vptoolkit.visibility._raster import (
    SUBPIXEL_BITS,
    _collect_histogram,
    _draw_row,
    _edge_setup,
    _exact_steps,
    _rasterize_view,
    _walk_row,
)

STEP = 1 << SUBPIXEL_BITS
FROZEN_COUNTS = ASSETS / "raster_counts.npz"
FROZEN_MESHES = ("suzanne.ply", "Duck.glb")
FROZEN_VIEWS = {7: 12, 64: 12, 257: 12, 1024: 3}  # resolution: number of views


def _histograms(mesh, views, resolution, camera):
    settings = MeasureSettings(resolution=resolution, camera=camera)
    runs = list(iter_view_histograms(mesh, settings, view_directions=views))
    return [np.concatenate([getattr(run, name) for run in runs])
            for name in ("face_ids", "pixel_counts")], [run.offsets for run in runs]


def _frozen_case(name, resolution, culled):
    """The arrays of one view list in the layout of ``raster_counts.npz``."""
    mesh = load_mesh(sample_path(name))
    views = fibonacci_sphere(FROZEN_VIEWS[resolution])
    (face_ids, pixel_counts), offsets = _histograms(
        mesh, views, resolution, Camera(cull_back_faces=culled))
    key = f"{name}/{resolution}/{'culled' if culled else 'two-sided'}"
    lengths = np.concatenate([np.diff(run) for run in offsets])
    return {f"{key}/face_ids": face_ids, f"{key}/pixel_counts": pixel_counts,
            f"{key}/lengths": lengths}


FROZEN_CASES = [(name, resolution, culled) for name in FROZEN_MESHES for resolution in FROZEN_VIEWS
                for culled in (True, False)]
FROZEN_IDS = [f"{name}-{resolution}-{'culled' if culled else 'two-sided'}"
              for name, resolution, culled in FROZEN_CASES]


@pytest.mark.parametrize("name,resolution,culled", FROZEN_CASES, ids=FROZEN_IDS)
def test_kernel_counts_equal_the_frozen_counts_bit_for_bit(name, resolution, culled):
    with np.load(FROZEN_COUNTS, allow_pickle=False) as frozen:
        for key, got in _frozen_case(name, resolution, culled).items():
            np.testing.assert_array_equal(got, frozen[key], err_msg=key)


def test_histograms_count_the_pixels_of_the_id_images(bunny):
    views = fibonacci_sphere(5)
    images = face_id_images(bunny, MeasureSettings(resolution=200), view_directions=views)
    (face_ids, pixel_counts), offsets = _histograms(bunny, views, 200, Camera())
    for view, (start, stop) in enumerate(zip(offsets[0][:-1], offsets[0][1:])):
        ids = images[view][images[view] >= 0]
        # in the order of each face's first pixel, row by row
        _, first = np.unique(ids, return_index=True)
        np.testing.assert_array_equal(face_ids[start:stop], ids[np.sort(first)])
        np.testing.assert_array_equal(pixel_counts[start:stop],
                                      np.bincount(ids)[face_ids[start:stop]])


def _covered(xs, ys, resolution):
    """Pixel centres inside the fixed-point triangle, one edge-function test per pixel."""
    (ax, bx, cx), (ay, by, cy) = [int(v) for v in xs], [int(v) for v in ys]
    area2 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    if area2 < 0:
        bx, cx, by, cy = cx, bx, cy, by
    centres = np.arange(resolution, dtype=np.int64) * STEP + STEP // 2
    px, py = centres[None, :], centres[:, None]
    inside = np.full((resolution, resolution), area2 != 0)
    for (x0, y0), (x1, y1) in (((ax, ay), (bx, by)), ((bx, by), (cx, cy)), ((cx, cy), (ax, ay))):
        owned = y1 - y0 < 0 or (y1 == y0 and x1 - x0 > 0)  # top-left rule
        inside &= (x1 - x0) * (py - y0) - (y1 - y0) * (px - x0) + (0 if owned else -1) >= 0
    return inside


def _draw(xs, ys, faces, resolution, depth=None):
    """The kernel's frame and written row spans for screen-space triangles."""
    n = len(xs)
    frame = np.zeros(resolution * resolution, dtype=np.int64)
    row_low = np.full(resolution, resolution, dtype=np.int64)
    row_high = np.full(resolution, -1, dtype=np.int64)
    _rasterize_view(
        np.asarray(faces, dtype=np.int32), np.zeros((len(faces), 3)), np.zeros(len(faces)),
        np.ones(len(faces), dtype=bool), False, np.zeros(3), np.asarray(xs, dtype=np.int64),
        np.asarray(ys, dtype=np.int64),
        np.full(n, 0.5) if depth is None else np.asarray(depth, dtype=np.float64),
        resolution, frame, row_low, row_high,
    )
    return frame.reshape(resolution, resolution), row_low, row_high


def _draw_by_definition(xs, ys, faces, resolution, depth=None):
    """:func:`_draw` in numpy, pixel by pixel from the definition of the kernel's docstring.

    A pixel centre of a face's clipped bounding box is covered where all three
    biased edge functions are >= 0; its key is the integer part of the row's
    inverse depth at the box's left edge plus one float addition of the x step
    per pixel (``np.add.accumulate`` adds in order), shifted over ``face + 1``;
    the frame keeps the largest key. Only the edge set-up is the kernel's.
    """
    depth = np.full(len(xs), 0.5) if depth is None else np.asarray(depth, dtype=np.float64)
    frame = np.zeros((resolution, resolution), dtype=np.int64)
    written = np.zeros((resolution, resolution), dtype=bool)
    for face, (a, b, c) in enumerate(np.asarray(faces, dtype=np.int64)):
        ax, ay, bx, by, cx, cy = (np.int64(v) for v in (xs[a], ys[a], xs[b], ys[b], xs[c], ys[c]))
        x0 = max((min(ax, bx, cx) - STEP // 2 + STEP - 1) // STEP, 0)
        x1 = min((max(ax, bx, cx) - STEP // 2) // STEP, resolution - 1)
        y0 = max((min(ay, by, cy) - STEP // 2 + STEP - 1) // STEP, 0)
        y1 = min((max(ay, by, cy) - STEP // 2) // STEP, resolution - 1)
        area2 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
        if x0 > x1 or y0 > y1 or area2 == 0:
            continue
        (row_ab, row_bc, row_ca, sx_ab, sy_ab, sx_bc, sy_bc, sx_ca, sy_ca, q_row, dq_dx,
         dq_dy) = _edge_setup(ax, ay, bx, by, cx, cy, depth[a], depth[b], depth[c], area2,
                              np.int64(x0), np.int64(y0))
        k = np.arange(x1 - x0 + 1, dtype=np.int64)[None, :]
        j = np.arange(y1 - y0 + 1, dtype=np.int64)[:, None]
        inside = ((row_ab + k * sx_ab + j * sy_ab >= 0) & (row_bc + k * sx_bc + j * sy_bc >= 0)
                  & (row_ca + k * sx_ca + j * sy_ca >= 0))
        row_starts = np.add.accumulate(np.r_[q_row, np.full(y1 - y0, dq_dy)])
        steps = np.full((len(row_starts), x1 - x0 + 1), dq_dx)
        steps[:, 0] = row_starts
        keys = (np.add.accumulate(steps, axis=1).astype(np.int64) << 32) | (face + 1)
        box = frame[y0:y1 + 1, x0:x1 + 1]
        box[inside] = np.maximum(box[inside], keys[inside])
        written[y0:y1 + 1, x0:x1 + 1] |= inside
    rows = written.any(axis=1)
    row_low = np.where(rows, written.argmax(axis=1), resolution)
    row_high = np.where(rows, resolution - 1 - written[:, ::-1].argmax(axis=1), -1)
    return frame, row_low, row_high


def _fan(resolution, rng, *, n_spokes, centre, radius, on_centres):
    """A polygon split into triangles around ``centre``: shared edges, many slivers.

    Drawn again until snapping to the grid flips no triangle, so that the
    triangles tile the polygon.
    """
    faces = np.array([[0, 1 + i, 1 + (i + 1) % n_spokes] for i in range(n_spokes)])
    while True:
        angles = np.sort(rng.uniform(0, 2 * np.pi, n_spokes))
        points = centre + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        points = np.vstack([centre, points])
        if on_centres:  # every vertex on a pixel centre: edges run through pixel centres
            fixed = (np.round(points - 0.5) * STEP + STEP // 2).astype(np.int64)
        else:
            fixed = np.round(points * STEP).astype(np.int64)
        ab, ac = fixed[faces[:, 1]] - fixed[faces[:, 0]], fixed[faces[:, 2]] - fixed[faces[:, 0]]
        if (ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0] >= 0).all():
            return fixed[:, 0], fixed[:, 1], faces


@pytest.mark.parametrize("resolution", [1, 2, 9, 64, 130])
@pytest.mark.parametrize("on_centres", [False, True])
def test_shared_edges_slivers_and_frame_borders_cover_each_pixel_centre_once(resolution,
                                                                             on_centres):
    rng = np.random.default_rng(resolution)
    fans = [
        # inside the frame, many thin spokes
        dict(n_spokes=97, centre=np.array([0.4, 0.55]) * resolution, radius=0.3 * resolution),
        # reaching past all four borders, the centre on the frame's corner
        dict(n_spokes=23, centre=np.array([0.0, 0.0]), radius=1.6 * resolution),
        dict(n_spokes=31, centre=np.array([0.5, 0.5]) * resolution, radius=0.9 * resolution),
    ]
    for fan in fans:
        xs, ys, faces = _fan(resolution, rng, on_centres=on_centres, **fan)
        frame, row_low, row_high = _draw(xs, ys, faces, resolution)
        ids = (frame & 0xFFFFFFFF) - 1
        want = np.full((resolution, resolution), -1)
        hits = np.zeros((resolution, resolution), dtype=int)
        for face, corners in enumerate(faces):
            inside = _covered(xs[corners], ys[corners], resolution)
            want[inside] = face
            hits += inside
        assert hits.max() <= 1  # the top-left rule gives a shared edge's pixels to one face
        np.testing.assert_array_equal(ids, want)
        hit_rows = hits.any(axis=1)
        np.testing.assert_array_equal(
            row_low, np.where(hit_rows, hits.argmax(axis=1), resolution))
        np.testing.assert_array_equal(
            row_high, np.where(hit_rows, resolution - 1 - hits[:, ::-1].argmax(axis=1), -1))
        defined = _draw_by_definition(xs, ys, faces, resolution)
        for got, want_defined in zip((frame, row_low, row_high), defined):
            np.testing.assert_array_equal(got, want_defined)


@pytest.mark.parametrize("resolution", [16, pytest.param(333, marks=pytest.mark.slow)])
def test_overlapping_random_triangles_keep_the_defined_depths(resolution):
    # Depth ties, binade edges of the inverse depth (2**29 = depth 0.5) and tiny,
    # huge or degenerate triangles, all drawn over each other.
    rng = np.random.default_rng(7)
    n = 600
    xs = rng.integers(-resolution * STEP // 2, resolution * STEP * 3 // 2, n)
    ys = rng.integers(-resolution * STEP // 2, resolution * STEP * 3 // 2, n)
    depth = rng.choice([0.5, 0.25, 1.0, 0.0, 0.5 - 2.0**-40, 0.5 + 2.0**-40], n)
    depth[::3] = rng.uniform(0, 1, len(depth[::3]))
    faces = rng.integers(0, n, (3000, 3))
    slivers = np.column_stack([faces[:, 0], faces[:, 0] + 1, faces[:, 0] + 2]) % n
    xs[1::3] = xs[::3][: len(xs[1::3])] + rng.integers(-2, 3, len(xs[1::3]))
    faces = np.vstack([faces, slivers])
    fast = _draw(xs, ys, faces, resolution, depth=depth)
    defined = _draw_by_definition(xs, ys, faces, resolution, depth=depth)
    for got, want in zip(fast, defined):
        np.testing.assert_array_equal(got, want)


def _row(q, dq, k_low, k_high, fast, width):
    frame = np.zeros(width + 1, dtype=np.int64)
    if fast:
        _draw_row(q, dq, *_exact_steps(q, dq), k_low, k_high, np.int64(5), frame, 0, width)
    else:
        _walk_row(q, dq, k_low, k_high, np.int64(5), frame, 0)
    return frame


def test_depth_runs_equal_one_float_addition_per_pixel():
    ulp = np.spacing
    cases = []
    for q in [1.0, 1.5, 2.0**29, 2.0**29 - ulp(2.0**29), 2.0**30, 2.0**30 - 3e-7, 3.7e8,
              0.999, 0.0, 2.0**52 - 1.0, 123456.789]:
        for dq in [0.0, 1e-300, ulp(q) / 2, -ulp(q) / 2, 3 * ulp(q) / 2, ulp(q), -ulp(q),
                   ulp(q) / 3, 1e-3, -1e-3, 0.1, -7.25, 1e6, -1e6, ulp(q) * 2.0**20]:
            cases.append((q, dq))
    for binade in (1, 10, 29):
        # Just below an integer with an odd last bit: adding a tie (half a unit, or
        # one and a half) rounds to even and stalls where exact steps would cross it.
        unit = ulp(2.0**binade)
        for q in (2.0**binade + 1 - 3 * unit, 2.0**binade + 1 - 1001 * unit):
            cases += [(q, unit / 2), (q, 3 * unit / 2)]
    rng = np.random.default_rng(3)
    cases += list(zip(rng.uniform(0, 2.0**30, 300), rng.normal(0, 1e4, 300)))
    for q, dq in cases:
        # runs in wide boxes, and in narrow ones, whose whole row is visited
        for k_low, k_high, width in [(0, 0, 0), (0, 40, 40), (13, 700, 700), (0, 0, 15),
                                     (2, 9, 12), (0, 15, 15), (15, 15, 15), (5, 4, 9)]:
            fast = _row(q, dq, k_low, k_high, True, width)
            walked = _row(q, dq, k_low, k_high, False, width)
            np.testing.assert_array_equal(fast, walked, err_msg=f"q={q!r} dq={dq!r}")


@pytest.mark.parametrize("resolution", [16, 333])
def test_histograms_counted_by_runs_or_by_pixels_are_the_same(resolution):
    rng = np.random.default_rng(5)
    n = 300
    xs = rng.integers(-resolution * STEP // 2, resolution * STEP * 3 // 2, n)
    ys = rng.integers(-resolution * STEP // 2, resolution * STEP * 3 // 2, n)
    faces = rng.integers(0, n, (400, 3))
    frame, row_low, row_high = _draw(xs, ys, faces, resolution, depth=rng.uniform(0, 1, n))
    results = []
    for count_runs in (False, True):
        cleared = frame.ravel().copy(), row_low.copy(), row_high.copy()
        out_ids = np.zeros(len(faces), dtype=np.int32)
        out_counts = np.zeros(len(faces), dtype=np.int32)
        n_seen, n_pixels = _collect_histogram(
            resolution, *cleared, np.zeros(len(faces) + 1, dtype=np.int64),
            np.zeros(len(faces) + 1, dtype=np.int32), out_ids, out_counts, count_runs)
        assert not cleared[0].any() and (cleared[1] == resolution).all()
        results.append((out_ids[:n_seen], out_counts[:n_seen], n_pixels))
    ids = (frame & 0xFFFFFFFF) - 1
    assert results[0][2] == results[1][2] == (row_high - row_low + 1).clip(0).sum()
    np.testing.assert_array_equal(results[0][1], np.bincount(ids[ids >= 0])[results[0][0]])
    for got, want in zip(results[1], results[0]):
        np.testing.assert_array_equal(got, want)


def test_cached_kernels_inline_no_other_modules_code():
    # numba's on-disk cache checks only the source file of the cached function:
    # one that inlines another module's njit code would be reloaded stale after
    # that module changed. Modules that cache must not import njit code.
    import ast
    import pathlib

    import vptoolkit

    root = pathlib.Path(vptoolkit.__file__).parent
    cached = {path for path in root.rglob("*.py") if "cache=True" in path.read_text()}
    assert cached, "no module caches compiled code"
    for path in cached:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("vptoolkit"):
                module = root.parent / (node.module.replace(".", "/") + ".py")
                assert not module.exists() or "@njit" not in module.read_text(), (
                    f"{path.relative_to(root)} caches numba code and imports {node.module}")


if __name__ == "__main__":  # rewrite the frozen counts from the current kernel
    arrays = {}
    for case in FROZEN_CASES:
        arrays.update(_frozen_case(*case))
    np.savez_compressed(FROZEN_COUNTS, **arrays)
