"""Triangle-ID z-buffer rasteriser on the CPU (numba), the default backend.

The front-facing triangles of each view are drawn into one 64-bit key per
pixel: the high bits hold the quantised inverse depth ``1/z`` (affine in
screen space, so interpolating it is perspective-correct; larger is
nearer), the low 32 bits hold ``face + 1``. A depth test and an ID write are
then a single integer maximum, and the visible face of a pixel is the one
with the largest key (ties in depth go to the higher face index). The
maximum does not depend on the order the faces are drawn in.

Coverage is exact: vertices are snapped to a fixed-point grid of
``2**-SUBPIXEL_BITS`` pixels (:func:`_project_vertices`) and integer edge
functions are evaluated at pixel centres with a top-left tie rule, so a
pixel centre on an edge shared by two triangles is counted exactly once.

The inverse depth of pixel ``k`` of a row is, by definition, the row's start
value (at the bounding box's left edge) plus ``k`` float additions of the x
step (the walk of :func:`_walk_row`). The kernel gets the same doubles
without the chain of additions wherever they form an exact integer
progression (:func:`_exact_steps`), which is almost everywhere. Each face
takes one of three paths in :func:`_rasterize_view`, all giving the pixels of
that definition:

* one pixel centre in its bounding box: that pixel's test, no steps;
* a box at most ``_SMALL_BOX`` pixels wide and high: every pixel centre
  tested with no branch, walking the depth;
* bigger: the covered run of each row, the offsets ``k`` where all three edge
  functions ``e + k * sx`` are >= 0, from quotients and remainders stepped
  from row to row (no division per row), drawn by :func:`_draw_row` (in a
  box narrower than ``_BOX_WIDTH``, over the whole row with no branch).

Frame indices are unsigned, so numba emits no negative-index wrap-around
in the pixel loops. The per-face histogram of each view is taken while
clearing the frame, only over the span of each row that was written, so the
full frame is never scanned; it is counted pixel by pixel or run by run of
equal IDs, whichever the thread's previous view suggests (the same counts).
Views are split over the threads; each thread owns its buffers
(:class:`._workspace.RasterWorkspace`), so there are no atomics, and faces are
put in an order that keeps those buffers in cache
(:func:`._workspace.locality_order`).

Asked for, the depth and silhouette statistics of a view
(:mod:`.features`) are taken from its frame after drawing and before
counting, by :func:`view_features`, which the ``"raycast"`` backend calls
too on an image of the same keys. Over the written spans it bins the
normalised depth of each covered pixel, keeps the nearest depth of each
thumbnail block and copies the covered pixels into a mask with a
background border, on which :func:`_trace_silhouette` follows every border
as Suzuki and Abe's algorithm does in OpenCV's ``findContours`` (the same
pixel chains, so the same lengths and turns).

``tests/visibility/test_raster.py`` checks the paths against a numpy rasteriser
of this definition and whole views against frozen per-face counts, bit for
bit; ``tests/visibility/test_features.py`` checks the statistics against OpenCV
and against values known by hand; ``tools/bench_measures.py --baseline DIR``
times the kernel against the one of another checkout.

Size
    About 890 lines for one concept, the scan conversion of a view and what
    is counted on it (the buffers and face order are :mod:`._workspace`).
    They stay in one file because numba's on-disk cache checks only
    the source file of the function it caches: a kernel compiled with code
    inlined from another module would be reloaded stale after that module
    changed (``tests/visibility/test_raster.py`` checks that no cached kernel
    imports another module's).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange, uint64
from numpy.typing import NDArray

from vptoolkit._numba import numba  # noqa: F401  (OpenMP before TBB, see vptoolkit._numba)

SUBPIXEL_BITS = 12
_DEPTH_LEVELS = float(1 << 30)
_ID_MASK = np.int64(0xFFFFFFFF)


@njit(cache=True, nogil=True, error_model="numpy")
def _project_vertices(
    vertices: NDArray[np.float64],
    eye: NDArray[np.float64],
    right: NDArray[np.float64],
    up: NDArray[np.float64],
    forward: NDArray[np.float64],
    focal: float,
    half: float,
    near: float,
    far: float,
    screen_x: NDArray[np.int64],
    screen_y: NDArray[np.int64],
    inverse_depth: NDArray[np.float64],
) -> None:
    scale = float(1 << SUBPIXEL_BITS)
    inv_near = 1.0 / near
    inv_far = 1.0 / far
    depth_span = inv_near - inv_far
    for i in range(vertices.shape[0]):
        dx = vertices[i, 0] - eye[0]
        dy = vertices[i, 1] - eye[1]
        dz = vertices[i, 2] - eye[2]
        p_r = dx * right[0] + dy * right[1] + dz * right[2]
        p_u = dx * up[0] + dy * up[1] + dz * up[2]
        p_f = dx * forward[0] + dy * forward[1] + dz * forward[2]
        inv_f = 1.0 / p_f
        screen_x[i] = np.int64(np.round((half + focal * p_r * inv_f) * scale))
        screen_y[i] = np.int64(np.round((half - focal * p_u * inv_f) * scale))
        q = (inv_f - inv_far) / depth_span
        inverse_depth[i] = min(max(q, 0.0), 1.0)


@njit(cache=True, nogil=True, error_model="numpy")
def _owns_edge(dx: np.int64, dy: np.int64) -> np.bool_:
    # Top-left rule for the orientation used below (positive doubled area):
    # the two triangles sharing an edge traverse it in opposite directions,
    # so exactly one of them owns the pixel centres lying on it.
    return dy < 0 or (dy == 0 and dx > 0)


_LOWER, _UPPER, _ROW = 0, 1, 2  # how an edge bounds the covered run of a row


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _edge_stepper(edge: np.int64, step_x: np.int64, step_y: np.int64
                  ) -> tuple[int, np.int64, np.int64, np.int64, np.int64, np.int64]:
    """Set up the exact row-by-row bound of ``edge + k * step_x >= 0`` on ``k``.

    With ``d = |step_x|``, row ``j`` of the edge function ``e_j = edge + j * step_y``
    bounds the offset by ``k >= -floor(e_j / d)`` when ``step_x > 0`` (a lower
    bound) and by ``k <= floor(e_j / d)`` when ``step_x < 0`` (an upper bound);
    when ``step_x == 0`` the row is empty exactly where ``e_j < 0``. The
    quotient ``floor(e_j / d)`` and its remainder are stepped from row to row
    (:func:`_next_row`), so a row costs additions instead of divisions.

    Returns
    -------
    kind, quotient, remainder, quotient_step, remainder_step, divisor
        ``_LOWER``, ``_UPPER`` or ``_ROW``; ``floor(edge / d)`` and
        ``edge mod d``; ``floor(step_y / d)`` and ``step_y mod d``; ``d``.
    """
    if step_x > 0:
        kind, divisor = _LOWER, step_x
    elif step_x < 0:
        kind, divisor = _UPPER, -step_x
    else:
        kind, divisor = _ROW, np.int64(1)
    quotient, remainder = _floor_divmod(edge, divisor)
    quotient_step, remainder_step = _floor_divmod(step_y, divisor)
    return kind, quotient, remainder, quotient_step, remainder_step, divisor


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _floor_divmod(a: np.int64, d: np.int64) -> tuple[np.int64, np.int64]:
    """``(a // d, a % d)`` for ``d > 0``: a float quotient corrected to the exact one.

    Cheaper than integer division here; the float estimate is off by at most
    one for the quotients of edge functions (below ``2**50`` in magnitude).
    """
    quotient = np.int64(math.floor(a / d))
    remainder = a - quotient * d
    while remainder < 0:
        quotient -= 1
        remainder += d
    while remainder >= d:
        quotient += 1
        remainder -= d
    return quotient, remainder


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _next_row(quotient: np.int64, remainder: np.int64, quotient_step: np.int64,
              remainder_step: np.int64, divisor: np.int64) -> tuple[np.int64, np.int64]:
    """``floor(e / d)`` and ``e mod d`` of the next row from those of this one."""
    remainder += remainder_step
    carry = np.int64(remainder >= divisor)  # data-dependent: no branch
    return quotient + quotient_step + carry, remainder - carry * divisor


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _stepped_span(kind: int, quotient: np.int64, k_low: np.int64,
                  k_high: np.int64) -> tuple[np.int64, np.int64]:
    """Narrow ``[k_low, k_high]`` by one edge, from its row quotient (:func:`_edge_stepper`)."""
    if kind == _LOWER:
        return max(k_low, -quotient), k_high
    if kind == _UPPER:
        return k_low, min(k_high, quotient)
    if quotient < 0:
        return np.int64(1), np.int64(0)
    return k_low, k_high


_UNIT_LOW = np.int64(1 << 52)
_UNIT_HIGH = np.int64((1 << 53) - 1)
_UNIT_STEP_LIMIT = np.int64(1 << 48)
_SMALL_BOX = 8  # boxes of at most this many pixel columns and rows are tested pixel by pixel
_BOX_WIDTH = 16  # in narrower boxes a row's run is drawn by a loop over the whole row


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _exact_steps(q: float, dq: float) -> tuple[bool | np.bool_, float, np.int64, np.int64]:
    """Whether the float sums ``q + dq + dq + ...`` in ``q``'s binade form an exact progression.

    Let ``q`` lie in the binade ``[2**(e-1), 2**e)``, where the doubles are the
    multiples of ``u = 2**(e-53)``. Adding ``dq`` to any of them rounds to
    adding ``r``, the multiple of ``u`` nearest to ``dq``, as long as the exact
    sum stays inside the binade and ``dq`` is not exactly halfway between two
    multiples (a tie goes to the even result, which depends on the addend).
    ``r`` is read off one rounded sum; ``dq - r`` is then exact (Sterbenz) and
    tells a tie. A sum ``v`` in units of ``u`` (``v = x / u``) is safe when the
    rounded result lies in ``[2**52 + 1, 2**53 - 1]``: the exact sum is then
    within ``u / 2`` of it, inside the binade.

    Returns
    -------
    exact, scale, shift, unit_step
        ``scale = 1 / u = 2**shift``, and ``r / u``. ``exact`` is False when
        ``q`` is outside ``[1, 2**52)``, ``dq`` is a tie, the sum leaves the
        binade or ``|r / u| >= 2**48`` (then ``dq`` changes ``q`` by over 3 %
        per pixel); then the sums must be taken one by one.
    """
    if not (1.0 <= q < 4503599627370496.0):
        return False, 1.0, np.int64(0), np.int64(0)
    shift = np.int64(53 - math.frexp(q)[1])  # 1 <= shift <= 52
    scale = float(np.int64(1) << shift)
    q_next = q + dq
    next_units = q_next * scale
    if not (_UNIT_LOW + 1 <= next_units <= _UNIT_HIGH) or abs(dq - (q_next - q)) * scale == 0.5:
        return False, scale, shift, np.int64(0)
    unit_step = np.int64(next_units) - np.int64(q * scale)
    # k * unit_step must not overflow for any pixel offset k < 2**14.
    return abs(unit_step) < _UNIT_STEP_LIMIT, scale, shift, unit_step


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _walk_row(q: float, dq: float, k_low: np.int64, k_high: np.int64, face_id: np.int64,
              frame: NDArray[np.int64], start: np.int64) -> None:
    """Depth-test pixels ``start + k_low .. start + k_high`` of a row, walking from ``start``.

    The inverse depth of pixel ``start + k`` is ``q`` plus ``k`` float additions
    of ``dq``: this walk defines it, :func:`_draw_row` reproduces it.
    """
    for _ in range(k_low):
        q += dq
    for k in range(k_low, k_high + 1):
        i = uint64(start + k)
        frame[i] = max(frame[i], (np.int64(q) << 32) | face_id)
        q += dq


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _draw_row(q: float, dq: float, exact: bool | np.bool_, scale: float, shift: np.int64,
              unit_step: np.int64, k_low: np.int64, k_high: np.int64, face_id: np.int64,
              frame: NDArray[np.int64], start: np.int64, width: np.int64) -> None:
    """:func:`_walk_row` with integer arithmetic where :func:`_exact_steps` allows it.

    When ``q`` lies in the binade of ``scale`` and every sum up to pixel
    ``k_high`` stays safely inside it, the ``k``-th sum is exactly
    ``(units + k * unit_step) / scale`` with ``units = q * scale``: its integer
    part is a shift, and there is no chain of dependent float additions,
    neither to reach ``k_low`` nor along the run. For a box narrower than
    ``_BOX_WIDTH``, all pixels ``0 .. width`` of the row are then visited with
    no branch, those outside the run taking the maximum with 0 (no change):
    the loop has the same length on every row of the face, so its end is
    predicted, where a run's length changes from row to row.
    """
    if exact:
        q_units = q * scale
        if _UNIT_LOW <= q_units <= _UNIT_HIGH:
            units = np.int64(q_units)
            near = units + unit_step
            far = units + k_high * unit_step
            if (_UNIT_LOW + 1 <= near <= _UNIT_HIGH and _UNIT_LOW + 1 <= far <= _UNIT_HIGH):
                if width < _BOX_WIDTH:
                    for k in range(width + 1):
                        key = (((units + k * unit_step) >> shift) << 32) | face_id
                        inside = (k >= k_low) & (k <= k_high)
                        i = uint64(start + k)
                        frame[i] = max(frame[i], key if inside else np.int64(0))
                    return
                for k in range(k_low, k_high + 1):
                    i = uint64(start + k)
                    frame[i] = max(frame[i], (((units + k * unit_step) >> shift) << 32) | face_id)
                return
    _walk_row(q, dq, k_low, k_high, face_id, frame, start)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _faces_viewer(face_normals: NDArray[np.float64], face_offsets: NDArray[np.float64], f: int,
                  eye: NDArray[np.float64]) -> bool:
    """Whether face ``f``'s plane ``n . x = offset`` has ``eye`` on its front side."""
    side = face_normals[f, 0] * eye[0] + face_normals[f, 1] * eye[1] + face_normals[f, 2] * eye[2]
    return side > face_offsets[f]


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _pixel_box(ax: np.int64, ay: np.int64, bx: np.int64, by: np.int64, cx: np.int64,
               cy: np.int64, resolution: int) -> tuple[np.int64, np.int64, np.int64, np.int64]:
    """``x0, x1, y0, y1``: the pixel columns and rows whose centres lie in the
    triangle's bounding box, clipped to the frame; empty when ``x0 > x1`` or
    ``y0 > y1`` (most faces of a fine mesh at a low resolution)."""
    step = np.int64(1 << SUBPIXEL_BITS)
    half_step = step // 2
    x0 = max((min(ax, bx, cx) - half_step + step - 1) // step, 0)
    x1 = min((max(ax, bx, cx) - half_step) // step, resolution - 1)
    y0 = max((min(ay, by, cy) - half_step + step - 1) // step, 0)
    y1 = min((max(ay, by, cy) - half_step) // step, resolution - 1)
    # typeshed's min and max of a numpy and a Python integer lose the numpy type
    return x0, x1, y0, y1  # type: ignore[return-value]


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _edge_setup(ax: np.int64, ay: np.int64, bx: np.int64, by: np.int64, cx: np.int64,
                cy: np.int64, qa: float, qb: float, qc: float, area2: np.int64, x0: np.int64,
                y0: np.int64) -> tuple[np.int64, np.int64, np.int64, np.int64, np.int64, np.int64,
                                       np.int64, np.int64, np.int64, float, float, float]:
    """Edge functions and inverse depth of a triangle at the pixel centre ``(x0, y0)``.

    ``area2`` is the signed doubled area (non-zero); the orientation is made
    positive by swapping ``b`` and ``c``. With ``E_ab(p) = (b - a) x (p - a)``,
    positive inside, the weights are ``w_c = E_ab``, ``w_a = E_bc`` and
    ``w_b = E_ca`` (barycentric weights times the area). Each edge value
    carries the top-left rule's bias: ``-1`` on edges the triangle does not
    own, so a pixel centre exactly on them fails ``>= 0``.

    Returns
    -------
    row_ab, row_bc, row_ca, sx_ab, sy_ab, sx_bc, sy_bc, sx_ca, sy_ca, q_row, dq_dx, dq_dy
        Biased edge values at ``(x0, y0)``, their steps per pixel along x and
        y, and the inverse depth (in units of ``1 / _DEPTH_LEVELS``) there with
        its steps.
    """
    step = np.int64(1 << SUBPIXEL_BITS)
    half_step = step // 2
    if area2 < 0:
        bx, cx = cx, bx
        by, cy = cy, by
        qb, qc = qc, qb
        area2 = -area2
    bias_ab = 0 if _owns_edge(bx - ax, by - ay) else -1
    bias_bc = 0 if _owns_edge(cx - bx, cy - by) else -1
    bias_ca = 0 if _owns_edge(ax - cx, ay - cy) else -1
    px = x0 * step + half_step
    py = y0 * step + half_step
    row_ab = (bx - ax) * (py - ay) - (by - ay) * (px - ax) + bias_ab
    row_bc = (cx - bx) * (py - by) - (cy - by) * (px - bx) + bias_bc
    row_ca = (ax - cx) * (py - cy) - (ay - cy) * (px - cx) + bias_ca
    sx_ab, sy_ab = -(by - ay) * step, (bx - ax) * step
    sx_bc, sy_bc = -(cy - by) * step, (cx - bx) * step
    sx_ca, sy_ca = -(ay - cy) * step, (ax - cx) * step
    inv_area = _DEPTH_LEVELS / area2
    dq_dx = (sx_bc * qa + sx_ca * qb + sx_ab * qc) * inv_area
    dq_dy = (sy_bc * qa + sy_ca * qb + sy_ab * qc) * inv_area
    q_row = ((row_bc - bias_bc) * qa + (row_ca - bias_ca) * qb + (row_ab - bias_ab) * qc) * inv_area
    return (row_ab, row_bc, row_ca, sx_ab, sy_ab, sx_bc, sy_bc, sx_ca, sy_ca, q_row, dq_dx,
            dq_dy)


@njit(cache=True, nogil=True, error_model="numpy")
def _rasterize_view(
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
    """Draw one view's faces into ``frame`` (row-major keys, ``resolution`` squared).

    ``row_low[y]`` and ``row_high[y]`` are widened to the written span of
    each row; the caller clears the frame and resets them.
    """
    for f in range(faces.shape[0]):
        if not is_drawable[f]:
            continue
        if cull_back_faces and not _faces_viewer(face_normals, face_offsets, f, eye):
            continue
        a = uint64(faces[f, 0])
        b = uint64(faces[f, 1])
        c = uint64(faces[f, 2])
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
        width = x1 - x0
        if width == 0 and y1 == y0:
            # One pixel centre: its test alone.
            if (row_ab | row_bc | row_ca) >= 0:
                i = uint64(y0 * resolution + x0)
                frame[i] = max(frame[i], (np.int64(q_row) << 32) | face_id)
                row = uint64(y0)
                row_low[row] = min(row_low[row], x0)
                row_high[row] = max(row_high[row], x0)
            continue
        if width < _SMALL_BOX and y1 - y0 < _SMALL_BOX:
            # A small box: every pixel centre tested, cheaper than any set-up.
            for y in range(y0, y1 + 1):
                e_ab, e_bc, e_ca, q = row_ab, row_bc, row_ca, q_row
                base = y * resolution
                low: int | np.int64 = x1 + 1
                high: int | np.int64 = x0 - 1
                for x in range(x0, x1 + 1):
                    inside = (e_ab | e_bc | e_ca) >= 0
                    i = uint64(base + x)
                    key = (np.int64(q) << 32) | face_id
                    frame[i] = max(frame[i], key if inside else np.int64(0))
                    low = min(low, x if inside else x1 + 1)
                    high = max(high, x if inside else x0 - 1)
                    e_ab += sx_ab
                    e_bc += sx_bc
                    e_ca += sx_ca
                    q += dq_dx
                if low <= high:
                    row = uint64(y)
                    row_low[row] = min(row_low[row], low)
                    row_high[row] = max(row_high[row], high)
                row_ab += sy_ab
                row_bc += sy_bc
                row_ca += sy_ca
                q_row += dq_dy
            continue
        exact, scale, shift, unit_step = _exact_steps(q_row, dq_dx)
        # A bigger box: the covered run of each row, solved for from the edges.
        kind_ab, quot_ab, rem_ab, dquot_ab, drem_ab, div_ab = _edge_stepper(row_ab, sx_ab, sy_ab)
        kind_bc, quot_bc, rem_bc, dquot_bc, drem_bc, div_bc = _edge_stepper(row_bc, sx_bc, sy_bc)
        kind_ca, quot_ca, rem_ca, dquot_ca, drem_ca, div_ca = _edge_stepper(row_ca, sx_ca, sy_ca)
        for y in range(y0, y1 + 1):
            k_low = np.int64(0)
            k_high = width
            k_low, k_high = _stepped_span(kind_ab, quot_ab, k_low, k_high)
            k_low, k_high = _stepped_span(kind_bc, quot_bc, k_low, k_high)
            k_low, k_high = _stepped_span(kind_ca, quot_ca, k_low, k_high)
            quot_ab, rem_ab = _next_row(quot_ab, rem_ab, dquot_ab, drem_ab, div_ab)
            quot_bc, rem_bc = _next_row(quot_bc, rem_bc, dquot_bc, drem_bc, div_bc)
            quot_ca, rem_ca = _next_row(quot_ca, rem_ca, dquot_ca, drem_ca, div_ca)
            if k_low <= k_high:
                _draw_row(q_row, dq_dx, exact, scale, shift, unit_step, k_low, k_high, face_id,
                          frame, y * resolution + x0, width)
                row = uint64(y)
                row_low[row] = min(row_low[row], x0 + k_low)
                row_high[row] = max(row_high[row], x0 + k_high)
            q_row += dq_dy


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


_FOREGROUND, _VISITED, _RIGHT_BOUND = 1, 2, 3
"""Values of a silhouette mask pixel (0 is background): covered and not yet on a traced
border, on a traced border, on a traced border whose right neighbour (background) the
tracing examined (Suzuki and Abe's ``NBD`` and ``-NBD``)."""
_STEP_X = np.array([1, 1, 0, -1, -1, -1, 0, 1], dtype=np.int64)
_STEP_Y = np.array([0, -1, -1, -1, 0, 1, 1, 1], dtype=np.int64)
"""Pixel offset of chain code ``s``: 0 right, then counter-clockwise on screen (y is down)."""
_TURN_BIN = np.array([4, 3, 2, 1, 8, 7, 6, 5], dtype=np.int64)
"""Turning-angle bin of the code change ``(s_out - s_in) mod 8``: the angle is
``-45 * change`` in (-180, 180] (glm's oriented angle of the two steps, y down),
the bin ``(angle + 180) // 45``."""


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _normalised_depth(q: np.int64, q_step: float, inverse_far: float, near: float,
                      inverse_range: float) -> float:
    """Normalised depth ``(z - near) / (far - near)`` in [0, 1] of the quantised inverse
    depth ``q`` of a key: ``1 / z = q * q_step + 1 / far``."""
    depth = (1.0 / (q * q_step + inverse_far) - near) * inverse_range
    return min(max(depth, 0.0), 1.0)


@njit(cache=True, nogil=True, error_model="numpy")
def _follow_border(mask: NDArray[np.uint8], start: int | np.int64, width: int | np.int64,
                   is_hole: bool, turning: NDArray[np.int64]) -> tuple[np.int64, np.int64]:
    """Follow one border of the padded ``mask`` from pixel ``start``, as Suzuki and Abe.

    The border is an outer one (background to the left of ``start``) or a
    hole's (background to the right). The neighbour search turns clockwise
    from the background side for the first pixel, then counter-clockwise from
    the previous pixel for each next one; each pixel left is marked
    ``_RIGHT_BOUND`` when the search passed its right neighbour, else
    ``_VISITED`` if it was unmarked. The chain is the sequence of pixels left
    (OpenCV's ``CHAIN_APPROX_NONE`` points), closed when the walk is back at
    ``start`` coming from the first pixel found. Its turns (one per chain
    pixel: the change from the step into it to the step out of it) are added
    to ``turning``; an isolated pixel is one turn of 0.

    Returns
    -------
    axis_steps, diagonal_steps
        Steps of the closed chain along an axis and along a diagonal.
    """
    s = np.int64(0) if is_hole else np.int64(4)
    s_end = s
    while True:
        s = (s - 1) & 7
        last = start + _STEP_X[s] + _STEP_Y[s] * width
        if mask[uint64(last)] != 0 or s == s_end:
            break
    if s == s_end:
        mask[uint64(start)] = _RIGHT_BOUND
        turning[4] += 1
        return np.int64(0), np.int64(0)
    axis_steps = np.int64(0)
    diagonal_steps = np.int64(0)
    first = np.int64(-1)
    previous = np.int64(-1)
    here = start
    while True:
        s_end = s
        after = here
        for _ in range(8):
            s += 1
            after = here + _STEP_X[s & 7] + _STEP_Y[s & 7] * width
            if mask[uint64(after)] != 0:
                break
        s &= 7
        if 1 <= s <= s_end:
            mask[uint64(here)] = _RIGHT_BOUND
        elif mask[uint64(here)] == _FOREGROUND:
            mask[uint64(here)] = _VISITED
        diagonal_steps += s & 1
        axis_steps += 1 - (s & 1)
        if previous >= 0:
            turning[_TURN_BIN[(s - previous) & 7]] += 1
        else:
            first = s
        previous = s
        if after == start and here == last:
            break
        here = after
        s = (s + 4) & 7
    turning[_TURN_BIN[(first - previous) & 7]] += 1
    return axis_steps, diagonal_steps


@njit(cache=True, nogil=True, error_model="numpy")
def _trace_silhouette(mask: NDArray[np.uint8], resolution: int, row_low: NDArray[np.int64],
                      row_high: NDArray[np.int64], turning: NDArray[np.int64]) -> float:
    """Trace every border of the covered pixels, as OpenCV's ``findContours(RETR_LIST,
    CHAIN_APPROX_NONE)``; the summed chain length, turns added to ``turning``.

    ``mask`` is the ``(resolution + 2)`` square image, row-major, of
    :func:`view_features` (a background border around the frame). A raster
    scan over the written span of each row and the pixel after it starts an
    outer border at an unmarked covered pixel with background on its left,
    and a hole's border at a covered pixel not marked ``_RIGHT_BOUND`` with
    background on its right (Suzuki and Abe's border following, 8-connected
    covered pixels). A closed chain is 1 per axis step and ``sqrt(2)`` per
    diagonal step long (``cv::arcLength(contour, true)``).
    """
    width = np.int64(resolution + 2)
    axis_steps = np.int64(0)
    diagonal_steps = np.int64(0)
    for y in range(resolution):
        low = row_low[y]
        high = row_high[y]
        if low > high:
            continue
        base = (y + 1) * width + 1
        previous = mask[uint64(base + low - 1)]
        for i in range(base + low, base + high + 2):
            pixel = mask[uint64(i)]
            if pixel == previous:
                continue
            if previous == 0 and pixel == _FOREGROUND:
                axis, diagonal = _follow_border(mask, i, width, False, turning)
                pixel = mask[uint64(i)]
            elif pixel == 0 and previous != _RIGHT_BOUND:
                axis, diagonal = _follow_border(mask, i - 1, width, True, turning)
            else:
                axis, diagonal = np.int64(0), np.int64(0)
            axis_steps += axis
            diagonal_steps += diagonal
            previous = pixel
    return axis_steps + math.sqrt(2.0) * diagonal_steps


_HISTOGRAM_LANES = 4
"""Copies of the depth histogram that consecutive pixels add to in turn, so that
an increment need not wait for the one before (neighbours mostly share a bin)."""


@njit(cache=True, nogil=True, error_model="numpy")
def _thumbnail_blocks(resolution: int, thumbnail_side: int
                      ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """How the image's pixels are gathered into the thumbnail.

    The image is split into ``side x side`` blocks, ``side = min(resolution,
    thumbnail_side)``: block ``k`` spans the pixel rows (and columns)
    ``floor(k * resolution / side) .. floor((k + 1) * resolution / side) - 1``,
    one pixel each when the image is smaller than the thumbnail. Thumbnail
    pixel ``i`` shows block ``floor((i + 1/2) * side / thumbnail_side)``:
    block ``i`` itself for an image at least as big as the thumbnail,
    otherwise the pixel nearest to its centre.

    Returns
    -------
    block_of : (resolution,) int64
        Block of each pixel row (and column).
    edges : (side + 1,) int64
        First pixel of each block, then ``resolution``.
    source : (thumbnail_side,) int64
        Block shown by each thumbnail row (and column).
    """
    side = min(resolution, thumbnail_side)
    edges = np.empty(side + 1, dtype=np.int64)
    block_of = np.empty(resolution, dtype=np.int64)
    for k in range(side + 1):
        edges[k] = k * resolution // side
    for k in range(side):
        block_of[edges[k]:edges[k + 1]] = k
    source = np.empty(thumbnail_side, dtype=np.int64)
    for i in range(thumbnail_side):
        source[i] = (2 * i + 1) * side // (2 * thumbnail_side)
    return block_of, edges, source


@njit(cache=True, nogil=True, error_model="numpy")
def view_features(
    frame: NDArray[np.int64],
    resolution: int,
    row_low: NDArray[np.int64],
    row_high: NDArray[np.int64],
    near: float,
    far: float,
    mask: NDArray[np.uint8],
    depth_histogram: NDArray[np.int64],
    turning_histogram: NDArray[np.int64],
    thumbnail: NDArray[np.uint8],
) -> tuple[float, float]:
    """Depth and silhouette statistics of one drawn view (:mod:`.features`).

    Reads the keys of ``frame`` (row-major, as :func:`_rasterize_view` writes
    them: covered where non-zero, quantised inverse depth ``q`` in the high
    32 bits) over the written span ``row_low[y]..row_high[y]`` of each row,
    and changes none of them. A covered pixel is at the distance ``z = 1 /
    (q (1/near - 1/far) / 2**30 + 1/far)`` along the camera axis, of
    normalised depth ``(z - near) / (far - near)`` clipped to [0, 1], which
    falls in bin ``floor(depth * n_bins)`` (the last bin closed) of
    ``depth_histogram``. Each thumbnail pixel shows the nearest covered pixel
    of its block (:func:`_thumbnail_blocks`) as ``1 + round(254 (1 -
    depth))``, 0 where the block sees nothing. The silhouette is traced on
    ``mask``, the covered pixels with a background border of one pixel
    (:func:`_trace_silhouette`), which must be all zero and is left so.

    The histograms and the thumbnail are overwritten.

    Returns
    -------
    max_depth, silhouette_length
        Largest normalised depth of a covered pixel (NaN if none) and the
        length of all contours.
    """
    n_bins = depth_histogram.shape[0]
    block_of, block_edges, block_shown = _thumbnail_blocks(resolution, thumbnail.shape[0])
    depth_blocks = np.full((len(block_edges) - 1, len(block_edges) - 1), -1, dtype=np.int64)
    bins = np.empty(resolution, dtype=np.int64)
    lanes = np.zeros((_HISTOGRAM_LANES, n_bins + 1), dtype=np.int64)  # bin n_bins: background
    inverse_far = 1.0 / far
    q_step = (1.0 / near - inverse_far) / _DEPTH_LEVELS
    inverse_range = 1.0 / (far - near)
    width = resolution + 2
    nothing = np.int64(1) << 62
    q_min = nothing
    for y in range(resolution):
        low = row_low[y]
        high = row_high[y]
        if low > high:
            continue
        base = y * resolution
        mask_base = (y + 1) * width + 1
        # no branch per pixel: the background gets the spare bin and neutral extremes
        for x in range(low, high + 1):
            key = frame[uint64(base + x)]
            is_covered = key != 0
            q = key >> 32
            mask[uint64(mask_base + x)] = np.uint8(is_covered)
            q_min = min(q_min, q if is_covered else nothing)
            depth = _normalised_depth(q, q_step, inverse_far, near, inverse_range)
            bins[x] = min(np.int64(depth * n_bins), n_bins - 1) if is_covered else n_bins
        for x in range(low, high + 1):
            lanes[x % _HISTOGRAM_LANES, bins[x]] += 1
        blocks = depth_blocks[block_of[y]]
        block = block_of[low]
        x = low
        while x <= high:
            stop = min(block_edges[block + 1] - 1, high)
            nearest = blocks[block]
            for k in range(x, stop + 1):
                key = frame[uint64(base + k)]
                nearest = max(nearest, key >> 32 if key != 0 else np.int64(-1))
            blocks[block] = nearest
            block += 1
            x = stop + 1
    for b in range(n_bins):
        depth_histogram[b] = lanes[:, b].sum()
    turning_histogram[:] = 0
    length = _trace_silhouette(mask, resolution, row_low, row_high, turning_histogram)
    for y in range(resolution):
        if row_low[y] <= row_high[y]:
            mask_base = (y + 1) * width + 1
            mask[mask_base + row_low[y]: mask_base + row_high[y] + 1] = 0
    for i in range(thumbnail.shape[0]):
        for j in range(thumbnail.shape[1]):
            q = depth_blocks[block_shown[i], block_shown[j]]
            if q < 0:
                thumbnail[i, j] = 0
            else:
                depth = _normalised_depth(q, q_step, inverse_far, near, inverse_range)
                thumbnail[i, j] = np.uint8(1 + round(254.0 * (1.0 - depth)))
    if q_min == nothing:
        return np.nan, length
    return _normalised_depth(q_min, q_step, inverse_far, near, inverse_range), length


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
    features: bool,
    masks: NDArray[np.uint8],
    depth_histograms: NDArray[np.int64],
    max_depths: NDArray[np.float64],
    silhouette_lengths: NDArray[np.float64],
    turning_histograms: NDArray[np.int64],
    thumbnails: NDArray[np.uint8],
) -> None:
    """Per-face pixel histograms of a batch of views, and with ``features`` their image statistics.

    ``face_normals`` and ``face_offsets`` are the unnormalised face planes
    ``n . x = offset``; a face is front-facing from ``eye`` when
    ``n . eye > offset``. ``is_drawable`` is False for faces never drawn
    (zero area). Results of view ``i`` go to ``out_ids[i, :out_lengths[i]]``
    and ``out_counts[i, :out_lengths[i]]``; with ``features``, the statistics
    of :func:`view_features` to row ``i`` of the last five arrays, taken from
    the frame after drawing and before counting (on the thread's ``masks``).
    Without, those arrays may be empty.
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
            if features:
                max_depths[view], silhouette_lengths[view] = view_features(
                    frames[thread], resolution, row_low[thread], row_high[thread], near, far,
                    masks[thread], depth_histograms[view], turning_histograms[view],
                    thumbnails[view],
                )
            n_seen, n_pixels = _collect_histogram(
                resolution, frames[thread], row_low[thread], row_high[thread],
                id_counts[thread], touched[thread], out_ids[view], out_counts[view], count_runs,
            )
            out_lengths[view] = n_seen
            count_runs = n_pixels > _RUN_PIXELS * n_seen
