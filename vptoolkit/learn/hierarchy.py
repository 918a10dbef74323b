"""The point hierarchy of the viewpoint network: grid levels, neighbourhoods and densities.

No learned parameters; everything here is a function of the points.

Point hierarchy (:func:`build_hierarchy`, no learned parameters)
    Every normalised point gets a 63-bit Morton (Z-order) code (21 bits per
    axis) and the points of each model are sorted by it once. The cells of a
    regular grid of side ``2^-g`` are then contiguous runs of that order, so

    - *subsampling* to level ``g`` replaces the points of every occupied cell
      by their barycentre (a grid version of the paper's Poisson-disk levels);
    - a *cell neighbourhood* is the run of points of one cell
      (:func:`cell_neighbourhood`, linear time; used on the dense input);
    - a *ball query* of radius ``r`` looks up the cells of side ``2^-k >= r``
      around each centre with :func:`torch.searchsorted` and keeps the
      candidates within ``r`` (:func:`ball_query`);
    - the *point density* of a source point is the number of points in its
      cell one level finer than the neighbourhood search (a histogram
      density estimate, :func:`point_density`).

    Neighbourhoods with more than ``max_neighbours`` points keep an evenly
    strided subset (in code order). Everything is vectorised over the batch;
    the only sort is the first one, and the result depends on the set of
    points, not on their order.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Final, NamedTuple

from vptoolkit.errors import InputError
from vptoolkit.learn.config import MAX_GRID_LEVEL, ModelConfig, ball_level
from vptoolkit.optional import require

if TYPE_CHECKING:
    import torch
    from torch import Tensor, nn
else:
    torch = require("torch", extra="learn")
    nn = torch.nn
    Tensor = torch.Tensor

__all__ = [
    "CODE_BITS",
    "GLOBAL_RADIUS",
    "PointLevel",
    "Neighbourhood",
    "Hierarchy",
    "normalize_points",
    "morton_codes",
    "input_level",
    "grid_subsample",
    "ball_query",
    "whole_model_neighbourhood",
    "point_density",
    "cell_neighbourhood",
    "build_hierarchy",
    "check_clouds",
    "gather_rows",
]

CODE_BITS: Final = 21
"""Bits per axis of the Morton codes (cells down to ``2^-21`` of the diagonal)."""

GLOBAL_RADIUS: Final = 0.5
"""Radius of the last, global convolution.

Half the diagonal: the whole bounding box around its centre.
"""

_GLOBAL_BALL_LEVEL = 1  # cells of side 1/2
_NEIGHBOUR_CELLS: Final = [(dx, dy, dz)
                            for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)]

class PointLevel(NamedTuple):
    """The points of one hierarchy level, for a whole batch, flat.

    Attributes
    ----------
    points : (P, 3) float
        Normalised coordinates (bounding-box centre at 0, unit diagonal).
    batch : (P,) int64
        Model of each point, non-decreasing.
    codes : (P,) int64
        Morton code of each point (of its cell on subsampled levels), non-decreasing
        within each model.
    n_models : int
        Batch size ``B``.
    """

    points: Tensor
    batch: Tensor
    codes: Tensor
    n_models: int


class Neighbourhood(NamedTuple):
    """Fixed-width neighbour lists of the centres of one convolution.

    Attributes
    ----------
    index : (M, K) int64
        Rows of the source level; padding slots hold 0.
    mask : (M, K) bool
        Which slots are neighbours.
    count : (M,) int64
        Neighbours per centre (``mask.sum(1)``), at least 0.
    """

    # Fields named like tuple's index and count methods: reading them gives the field.
    index: Tensor  # type: ignore[assignment]
    mask: Tensor
    count: Tensor  # type: ignore[assignment]


class Hierarchy(NamedTuple):
    """Everything the encoder needs besides its weights (:func:`build_hierarchy`).

    Attributes
    ----------
    levels : list of PointLevel
        Level 0 (the input) to the last subsampled level.
    order : (B, N) int64
        Level 0 holds the input points ``points[b, order[b]]`` of each model ``b``.
    neighbourhoods : list of Neighbourhood
        One per convolution: from level ``i`` to level ``i + 1``, then the
        global one from the last level to the bounding-box centre.
    densities : list of Tensor
        ``(P_i,) float``, the relative density of the source points of each
        convolution.
    """

    levels: list[PointLevel]
    order: Tensor
    neighbourhoods: list[Neighbourhood]
    densities: list[Tensor]


def normalize_points(points: Tensor) -> Tensor:
    """Centre point clouds on their bounding-box centre and scale them to unit diagonal.

    Parameters
    ----------
    points : (B, N, 3) float
        Point clouds, any position and size.

    Returns
    -------
    normalised : (B, N, 3) float
        Bounding box centred at the origin with diagonal 1 (a cloud of one
        repeated point stays at the origin), in the dtype of ``points``.
        Directions from the centre are unchanged by this map.

    Notes
    -----
    Computed in float64, so that a float32 cloud of any size float32 holds
    (``1e-38`` to ``1e38``) maps to the same normalised cloud: the squared
    extent of a large float32 cloud would overflow and a tiny one underflow.
    """
    check_clouds(points)
    values = points.to(torch.float64)
    low = values.amin(dim=1, keepdim=True)
    high = values.amax(dim=1, keepdim=True)
    diagonal = (high - low).norm(dim=-1, keepdim=True)
    diagonal = torch.where(diagonal > 0, diagonal, torch.ones_like(diagonal))
    return ((values - (low + high) / 2.0) / diagonal).to(points.dtype)


def check_clouds(points: Tensor, channels: int = 3) -> None:
    """Raise :class:`InputError` unless ``points`` is a floating ``(B, N, channels)`` tensor.

    ``B`` and ``N`` must be at least 1; ``channels`` is 3 for coordinates
    alone, more with point features after them.
    """
    if not isinstance(points, torch.Tensor):
        raise InputError(f"points: expected a torch.Tensor, got {type(points).__name__}")
    if (points.ndim != 3 or points.shape[-1] != channels or points.shape[0] < 1
            or points.shape[1] < 1):
        raise InputError(f"points: expected shape (B, N, {channels}) with B, N >= 1, "
                         f"got {tuple(points.shape)}")
    if not points.is_floating_point():
        raise InputError(f"points: expected a floating dtype, got {points.dtype}")


def _spread_low_bits(values: Tensor) -> Tensor:
    """Insert two zero bits after every bit of integers below ``2^11`` (by shifts and masks)."""
    x = (values | (values << 16)) & 0x1F0000FF0000FF
    x = (x | (x << 8)) & 0x100F00F00F00F00F
    x = (x | (x << 4)) & 0x10C30C30C30C30C3
    return (x | (x << 2)) & 0x1249249249249249


def _spread_bits(values: Tensor) -> Tensor:
    """Insert two zero bits after every bit of 21-bit integers.

    Two look-ups in a table of the 2048 spread 11-bit values: bits 0-10 spread
    to bits 0-30, bits 11-20 to bits 33-60 (elementwise integer shifts are
    slow on the CPU, gathers are not).
    """
    table = _spread_low_bits(torch.arange(1 << 11, dtype=torch.int64, device=values.device))
    low = torch.take(table, values & 0x7FF)
    high = torch.take(table, (values >> 11) & 0x3FF)
    return low | (high << 33)


def _grid_coordinates(points: Tensor, level: int = CODE_BITS) -> Tensor:
    """Integer cell coordinates ``(..., 3)`` of normalised points, grid of side ``2^-level``."""
    scaled = torch.floor((points.to(torch.float64) + 0.5) * float(1 << level))
    return scaled.clamp(0, (1 << level) - 1).to(torch.int64)


def _interleave(cells: Tensor) -> Tensor:
    return ((_spread_bits(cells[..., 0]) << 2) | (_spread_bits(cells[..., 1]) << 1)
            | _spread_bits(cells[..., 2]))


def morton_codes(points: Tensor) -> Tensor:
    """Morton (Z-order) codes of normalised points.

    Parameters
    ----------
    points : (..., 3) float
        Coordinates in ``[-0.5, 0.5]`` (as :func:`normalize_points` gives);
        values outside are clamped to the border cells.

    Returns
    -------
    codes : (...) int64
        63-bit codes, 21 bits per axis interleaved ``x y z`` from the most
        significant bit. The points of a cell of side ``2^-k`` share the top
        ``3k`` bits, so sorting by code makes every such cell a contiguous run.
    """
    return _interleave(_grid_coordinates(points))


def input_level(points: Tensor) -> tuple[PointLevel, Tensor]:
    """Level 0: the normalised input points of every model, sorted by Morton code.

    Parameters
    ----------
    points : (B, N, 3) float
        Raw point clouds (they are normalised here).

    Returns
    -------
    level : PointLevel
        ``B * N`` points, model by model, each model's sorted by code (stable,
        so only points closer than ``2^-21`` diagonals can swap places).
    order : (B, N) int64
        The sort: model ``b``'s points are ``points[b, order[b]]``, normalised.
    """
    normalised = normalize_points(points)
    n_models, n_points, _ = normalised.shape
    codes = morton_codes(normalised)
    order = torch.argsort(codes, dim=1, stable=True)
    sorted_points = torch.gather(normalised, 1, order.unsqueeze(-1).expand(-1, -1, 3))
    batch = torch.arange(n_models, device=points.device).repeat_interleave(n_points)
    level = PointLevel(
        sorted_points.reshape(-1, 3), batch, torch.gather(codes, 1, order).reshape(-1), n_models
    )
    return level, order


def _cell_keys(level: PointLevel, grid_level: int) -> Tensor:
    """Non-decreasing keys ``(batch, cell)`` of the cells of side ``2^-grid_level``."""
    shift = 3 * (CODE_BITS - grid_level)
    return (level.batch << (3 * grid_level)) | (level.codes >> shift)


def grid_subsample(level: PointLevel, grid_level: int) -> PointLevel:
    """Replace the points of every occupied grid cell by their barycentre.

    Parameters
    ----------
    level : PointLevel
        Source points; ``grid_level`` must not be finer than the cells its
        codes describe.
    grid_level : int
        Cells have side ``2^-grid_level`` diagonals.

    Returns
    -------
    PointLevel
        One point per occupied cell, in code order; its code is the cell's
        (the low bits zero), so coarser cells stay contiguous runs.
    """
    keys = _cell_keys(level, grid_level)
    cells, inverse, counts = torch.unique_consecutive(keys, return_inverse=True, return_counts=True)
    sums = torch.zeros(len(cells), 3, dtype=level.points.dtype,
                       device=level.points.device).index_add_(0, inverse, level.points)
    points = sums / counts.unsqueeze(-1).to(sums.dtype)
    batch = cells >> (3 * grid_level)
    codes = (cells & ((1 << (3 * grid_level)) - 1)) << (3 * (CODE_BITS - grid_level))
    return PointLevel(points, batch, codes, level.n_models)


def gather_rows(values: Tensor, index: Tensor) -> Tensor:
    """``values[index]`` along the first axis for an index of any shape (index_select is faster)."""
    return torch.index_select(values, 0, index.reshape(-1)).reshape(*index.shape, *values.shape[1:])


def _pad_ragged(first: Tensor, count: Tensor, width: int) -> tuple[Tensor, Tensor]:
    """Slots ``(M, width)`` into ragged runs ``first[m] .. first[m] + count[m]``.

    Runs longer than ``width`` are subsampled evenly: slot ``s`` takes element
    ``floor((s + 1/2) count / width)``.
    """
    slots = torch.arange(width, device=first.device).unsqueeze(0)
    count_column = count.unsqueeze(-1)
    strided = torch.div((2 * slots + 1) * count_column, 2 * width, rounding_mode="floor")
    offset = torch.where(count_column > width, strided, slots)
    mask = slots < count_column
    return torch.where(mask, first.unsqueeze(-1) + offset, torch.zeros_like(offset)), mask


def ball_query(source: PointLevel, centres: PointLevel, radius: float,
               max_neighbours: int) -> Neighbourhood:
    """The source points within ``radius`` of each centre, through the Morton grid.

    The 27 cells of side ``2^-k >= radius`` (the finest such ``k``) around a
    centre's cell hold every point of its ball; those within reach of the
    ball (about 21 of them on average) have runs in the sorted
    source level are found with :func:`torch.searchsorted`, gathered,
    filtered by distance and, where more than ``max_neighbours`` remain,
    thinned to an evenly strided subset (in code order within each cell).

    Parameters
    ----------
    source : PointLevel
        Points to search; their codes must resolve cells of side ``2^-k``.
    centres : PointLevel
        Query points of the same batch.
    radius : float
        Ball radius in bounding-box diagonals.
    max_neighbours : int
        Width of the neighbour lists.

    Returns
    -------
    Neighbourhood
        ``(M, max_neighbours)`` rows of ``source`` per centre, with mask and count.
    """
    k = ball_level(radius)
    source_keys = _cell_keys(source, k)
    cells = _grid_coordinates(centres.points, k)  # (M, 3)
    offsets = torch.tensor(_NEIGHBOUR_CELLS, dtype=torch.int64, device=centres.points.device)
    neighbours = cells.unsqueeze(1) + offsets  # (M, 27, 3)
    # Skip cells outside the grid and cells whose nearest corner is beyond the radius.
    fraction = ((centres.points.to(torch.float64) + 0.5) * float(1 << k)
                - cells).unsqueeze(1)  # (M, 1, 3)
    gap = torch.where(offsets < 0, fraction,
                      torch.where(offsets > 0, 1.0 - fraction, 0.0)).clamp_min(0.0)
    reach = (radius * (1 << k)) ** 2 * (1.0 + 1e-9)
    is_inside = (((neighbours >= 0) & (neighbours < (1 << k))).all(dim=-1)
                 & (gap.square().sum(dim=-1) <= reach))
    # Codes of the 27 cells from the spread coordinates of 3 cells per axis: (M, 3 axes, 3 steps).
    steps = torch.arange(-1, 2, device=cells.device)
    spread = _spread_bits((cells.unsqueeze(-1) + steps).clamp(0, (1 << k) - 1))
    spread = spread << torch.tensor([[2], [1], [0]], device=cells.device)
    step = offsets + 1  # (27, 3): the step of each neighbour cell along each axis
    codes = spread[:, 0, step[:, 0]] | spread[:, 1, step[:, 1]] | spread[:, 2, step[:, 2]]
    keys = (centres.batch.unsqueeze(-1) << (3 * k)) | codes
    start = torch.searchsorted(source_keys, keys, side="left")
    stop = torch.searchsorted(source_keys, keys, side="right")
    run_length = torch.where(is_inside, stop - start, torch.zeros_like(start)).reshape(-1)
    # Expand the 27 runs of every centre into one flat candidate list, centre by centre.
    run = torch.repeat_interleave(torch.arange(len(run_length), device=run_length.device),
                                  run_length)
    run_shift = start.reshape(-1) - (torch.cumsum(run_length, 0) - run_length)
    candidate = gather_rows(run_shift, run) + torch.arange(len(run), device=run.device)
    centre = torch.div(run, len(_NEIGHBOUR_CELLS), rounding_mode="floor")
    distance2 = (gather_rows(source.points, candidate)
                 - gather_rows(centres.points, centre)).square().sum(dim=-1)
    near = torch.nonzero(distance2 <= radius * radius).squeeze(-1)
    candidate, centre = gather_rows(candidate, near), gather_rows(centre, near)
    count = torch.bincount(centre, minlength=len(centres.points))
    first = torch.cumsum(count, 0) - count
    slots, mask = _pad_ragged(first, count, max_neighbours)
    index = gather_rows(candidate, slots) if len(candidate) else torch.zeros_like(slots)
    return Neighbourhood(torch.where(mask, index, torch.zeros_like(index)), mask, mask.sum(dim=1))


def whole_model_neighbourhood(source: PointLevel) -> Neighbourhood:
    """Every point of each model as the neighbours of one centre per model.

    Returns
    -------
    Neighbourhood
        ``(B, max points per model)`` lists, in source order.
    """
    count = torch.bincount(source.batch, minlength=source.n_models)
    first = torch.cumsum(count, 0) - count
    width = max(int(count.max()), 1)
    slots, mask = _pad_ragged(first, count, width)
    return Neighbourhood(slots, mask, count)


def point_density(level: PointLevel, grid_level: int) -> Tensor:
    """Histogram estimate of the point density, up to a constant factor.

    Parameters
    ----------
    level : PointLevel
        Points whose density is wanted.
    grid_level : int
        Cells have side ``2^-grid_level`` diagonals.

    Returns
    -------
    density : (P,) float
        Number of points in each point's cell (at least 1). Only ratios
        matter: :class:`MonteCarloConv` normalises its weights.
    """
    keys = _cell_keys(level, grid_level)
    _, inverse, counts = torch.unique_consecutive(keys, return_inverse=True, return_counts=True)
    return gather_rows(counts, inverse).to(level.points.dtype)


def cell_neighbourhood(source: PointLevel, grid_level: int, max_neighbours: int) -> Neighbourhood:
    """The source points of each occupied grid cell, as the neighbours of its barycentre.

    Centres are the points :func:`grid_subsample` gives for the same
    ``grid_level``, in the same order.

    Parameters
    ----------
    source : PointLevel
        Points to group.
    grid_level : int
        Cells have side ``2^-grid_level`` diagonals.
    max_neighbours : int
        Width of the neighbour lists (cells with more points are thinned to
        an evenly strided subset in code order).

    Returns
    -------
    Neighbourhood
        One row per occupied cell.
    """
    keys = _cell_keys(source, grid_level)
    _, counts = torch.unique_consecutive(keys, return_counts=True)
    first = torch.cumsum(counts, 0) - counts
    slots, mask = _pad_ragged(first, counts, max_neighbours)
    return Neighbourhood(slots, mask, mask.sum(dim=1))


def build_hierarchy(points: Tensor, config: ModelConfig) -> Hierarchy:
    """All point levels, neighbourhoods and densities of a batch (no gradients).

    Parameters
    ----------
    points : (B, N, 3) float
        Raw point clouds.
    config : ModelConfig
        The levels to build.

    Returns
    -------
    Hierarchy
    """
    with torch.no_grad():
        first, order = input_level(points)
        levels = [first]
        neighbourhoods = []
        densities = []
        source_level = MAX_GRID_LEVEL
        for spec in config.levels:
            source = levels[-1]
            target = grid_subsample(source, spec.grid_level)
            if spec.neighbourhood == "cell":
                neighbourhoods.append(
                    cell_neighbourhood(source, spec.grid_level, spec.max_neighbours))
            else:
                neighbourhoods.append(ball_query(source, target, spec.radius, spec.max_neighbours))
            densities.append(point_density(source, min(spec.search_level + 1, source_level)))
            levels.append(target)
            source_level = spec.grid_level
        neighbourhoods.append(whole_model_neighbourhood(levels[-1]))
        densities.append(point_density(levels[-1], min(_GLOBAL_BALL_LEVEL + 1, source_level)))
    return Hierarchy(levels, order, neighbourhoods, densities)


