"""The viewpoint network: a Monte Carlo point-cloud encoder and one head per measure.

A compact, CPU-friendly take on the paper's MCCNN network (Schelling et al.
2021, section 4.3; Hermosilla et al. 2018), in plain PyTorch.

Preprocessing (inside the network)
    Points are centred on their bounding-box centre and scaled to a unit
    bounding-box diagonal (:func:`normalize_points`). Translation and uniform
    scaling leave directions unchanged, so predictions come back in the
    input's own frame.

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

Encoder (:class:`PointEncoder`), default :class:`ModelConfig`

    =====  ===========================  =============================  ========  ==========
    level  points                       neighbourhood (max points)     channels  parameters
    =====  ===========================  =============================  ========  ==========
    0      the input (4096)             --                             3 (xyz)   --
    1      cell barycentres, side 1/16  own cell, offsets / 1/16 (32)  64        3,472
    2      cell barycentres, side 1/8   ball of radius 1/8 (32)        128       131,536
    3      cell barycentres, side 1/4   ball of radius 1/4 (32)        256       524,880
    4      the bounding-box centre      all of level 3, radius 1/2     512       1,049,288
    =====  ===========================  =============================  ========  ==========

    Lengths are in units of the bounding-box diagonal; a 4096-point sample
    of a typical model gives about 250-800, 70-150 and 15-60 points on
    levels 1 to 3. Each level is one :class:`MonteCarloConv` (kernel MLP
    3-16-16, 3-16-8 on level 4) followed by batch norm and ReLU; the
    encoder has 1,711,096 parameters. Level 1 integrates over grid cells rather than balls because
    a ball query on the 4096 input points costs about ten times the rest of
    the hierarchy; its overlap comes back on level 2, whose balls span two
    level-1 cells. The paper's network has four levels too, with conv radii
    0.05, 0.2, 0.3 and sqrt(3) and 128, 256, 1024 and 2048 channels.

Heads, one per measure (4), on the 512-vector
    - ``"direction"`` (SL, ML, GL, ML+GL): MLP 512-256-64-3 with batch norm,
      ReLU and dropout 0.5 after each hidden layer (148,611 parameters),
      normalised to unit length (the paper: 2048-1024-256-3).
    - ``"sr"`` (spherical regression): two such MLPs, one giving absolute
      values through the spherical exponential, one 8 sign-category logits.
    - ``"dldl"`` (distribution learning): a 2D decoder to a 32 x 32 octahedral
      sphere map (the paper's appendix: 4 x 4 deconvolution, two residual
      blocks, 4 x 4 stride-4 deconvolution, two residual blocks, 2 x 2
      stride-2 deconvolution) with 64 and 16 channels instead of 1024 and 256.

Parameter counts of the default configuration (checked by the tests)

    ==========  ==========
    head        parameters
    ==========  ==========
    direction   2,305,540
    sr          2,901,284
    dldl        4,503,932
    ==========  ==========

Checkpoints
    :func:`save_model` writes the weights as ``safetensors`` and the
    configuration as JSON beside them; :func:`load_model` reads both back and
    never unpickles anything.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final, NamedTuple

from vptoolkit.conventions import MEASURES
from vptoolkit.errors import InputError, VerificationError
from vptoolkit.files import write_bytes_atomic
from vptoolkit.learn.frame import INPUT_FRAMES, canonical_frame, from_frame, to_frame
from vptoolkit.learn.labels import (
    decode_spherical_regression,
    decode_sphere_maps,
    spherical_exponential,
)
from vptoolkit.optional import require

if TYPE_CHECKING:
    import torch
    from torch import Tensor, nn
else:
    torch = require("torch", extra="learn")
    nn = torch.nn
    Tensor = torch.Tensor

__all__ = [
    "HEADS",
    "CODE_BITS",
    "DEFAULT_LEVELS",
    "MODEL_FORMAT",
    "LevelConfig",
    "ModelConfig",
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
    "GeneratorDropout",
    "MonteCarloConv",
    "PointEncoder",
    "DirectionHead",
    "SphereMapDecoder",
    "ViewpointNet",
    "count_parameters",
    "torch_threads",
    "resolve_device",
    "checkpoint_paths",
    "DEFAULT_MODEL",
    "PRETRAINED",
    "save_model",
    "load_model",
    "read_json",
    "read_safetensors",
    "write_json_atomic",
    "write_safetensors_atomic",
]

HEADS: Final = ("direction", "sr", "dldl")
"""Network heads: unit directions, spherical regression, sphere maps."""

CODE_BITS: Final = 21
"""Bits per axis of the Morton codes (cells down to ``2^-21`` of the diagonal)."""

MODEL_FORMAT: Final = "vptoolkit-viewpoint-model"

DEFAULT_MODEL: Final = "default"
"""Name that stands for the bundled pretrained checkpoint wherever a checkpoint path is taken."""

PRETRAINED: Final = Path(__file__).parent / "pretrained"
"""Folder of the bundled pretrained checkpoint (``model.safetensors``, float16, and
``model.json`` with the command that trained it); see ``docs/results.md``."""
"""``format`` entry of a checkpoint's JSON configuration."""

_MAX_LEVEL = 16  # finest grid level used: (batch << 3k) | cell fits 63 bits for batches up to 2^15
_NEIGHBOUR_CELLS: Final = [(dx, dy, dz) for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)]


# ====================================================================== configuration


@dataclass(frozen=True)
class LevelConfig:
    """One level of the point hierarchy and its convolution.

    Attributes
    ----------
    grid_level : int
        The level's points are the barycentres of the occupied cells of side
        ``2^-grid_level`` (in bounding-box diagonals), ``1 .. 16``, no finer
        than the previous level's.
    radius : float
        Radius of the convolution's ball around each of the level's points,
        in bounding-box diagonals, ``2^-16 <= radius <= 1``; the kernel sees
        offsets divided by it.
    max_neighbours : int
        At most this many points of the previous level per neighbourhood (an
        evenly strided subset when more are inside).
    channels : int
        Output channels.
    neighbourhood : {"ball", "cell"}
        ``"ball"``: the previous level's points within ``radius``
        (:func:`ball_query`); ``"cell"``: those in the point's own grid cell
        (:func:`cell_neighbourhood`, much cheaper on the dense input level)
        (default: "ball").
    """

    grid_level: int
    radius: float
    max_neighbours: int
    channels: int
    neighbourhood: str = "ball"

    @property
    def ball_level(self) -> int:
        """Level ``k`` of the cells searched by the ball query: the finest with ``2^-k >= radius``."""
        return _ball_level(self.radius)

    @property
    def search_level(self) -> int:
        """Grid level of the neighbourhood search: :attr:`ball_level` or, for cells, :attr:`grid_level`."""
        return self.grid_level if self.neighbourhood == "cell" else self.ball_level


def _ball_level(radius: float) -> int:
    return max(0, min(_MAX_LEVEL, math.floor(-math.log2(radius) + 1e-9)))


DEFAULT_LEVELS: Final = (
    LevelConfig(grid_level=4, radius=1 / 16, max_neighbours=32, channels=64, neighbourhood="cell"),
    LevelConfig(grid_level=3, radius=1 / 8, max_neighbours=32, channels=128),
    LevelConfig(grid_level=2, radius=1 / 4, max_neighbours=32, channels=256),
)
"""The default hierarchy (see the module docstring)."""


@dataclass(frozen=True)
class ModelConfig:
    """Architecture of a :class:`ViewpointNet`; stored in every checkpoint.

    Attributes
    ----------
    head : {"direction", "sr", "dldl"}
        Output head (default: "direction").
    n_measures : int
        Heads, one per measure (default: 4, ``MEASURES``).
    levels : tuple of LevelConfig
        The hierarchy below the global level (default: :data:`DEFAULT_LEVELS`).
    latent_channels : int
        Channels of the global level, the latent vector (default: 512).
    kernel_size : int
        Outputs of each level's kernel MLP (default: 16).
    global_kernel_size : int
        Outputs of the global level's kernel MLP (default: 8).
    kernel_hidden : int
        Hidden units of every kernel MLP (default: 16).
    head_channels : tuple of int
        Hidden layers of each head MLP (default: (256, 64)).
    dropout : float
        Dropout rate in the head MLPs (default: 0.5).
    decoder_channels : tuple of int
        Channels of the DLDL decoder at 4 x 4 and 16 x 16 (default: (64, 16)).
    input_frame : {"pca", "none"}
        ``"pca"``: the network sees each input in its canonical principal-axis
        frame and rotates its predictions back (:mod:`vptoolkit.learn.frame`),
        so a rotated input gets a rotated prediction; ``"none"``: the input's
        own frame (:func:`load_model` gives it to checkpoints older than this
        option). Default: "pca".
    """

    head: str = "direction"
    n_measures: int = len(MEASURES)
    levels: tuple[LevelConfig, ...] = DEFAULT_LEVELS
    latent_channels: int = 512
    kernel_size: int = 16
    global_kernel_size: int = 8
    kernel_hidden: int = 16
    head_channels: tuple[int, ...] = (256, 64)
    dropout: float = 0.5
    decoder_channels: tuple[int, int] = field(default=(64, 16))
    input_frame: str = "pca"

    def __post_init__(self) -> None:
        if self.input_frame not in INPUT_FRAMES:
            raise InputError(f"input_frame: expected one of {list(INPUT_FRAMES)}, got {self.input_frame!r}")
        if self.head not in HEADS:
            raise InputError(f"head: unknown head {self.head!r}, expected one of {list(HEADS)}")
        for name in ("n_measures", "latent_channels", "kernel_size", "global_kernel_size", "kernel_hidden"):
            _check_positive_int(getattr(self, name), name)
        if not self.levels:
            raise InputError("levels: expected at least one level")
        source_level = _MAX_LEVEL
        for position, level in enumerate(self.levels):
            if not isinstance(level, LevelConfig):
                raise InputError(f"levels[{position}]: expected a LevelConfig, got {type(level).__name__}")
            _check_positive_int(level.max_neighbours, f"levels[{position}].max_neighbours")
            _check_positive_int(level.channels, f"levels[{position}].channels")
            if not (isinstance(level.grid_level, int) and 1 <= level.grid_level <= source_level):
                raise InputError(
                    f"levels[{position}].grid_level: expected an integer in [1, {source_level}] "
                    f"(no finer than the level before), got {level.grid_level!r}"
                )
            if not (isinstance(level.radius, (int, float)) and 2.0**-_MAX_LEVEL <= level.radius <= 1.0):
                raise InputError(f"levels[{position}].radius: expected a number in [2^-16, 1], got {level.radius!r}")
            if level.neighbourhood not in ("ball", "cell"):
                raise InputError(
                    f"levels[{position}].neighbourhood: expected 'ball' or 'cell', got {level.neighbourhood!r}"
                )
            if level.neighbourhood == "ball" and level.ball_level > source_level:
                raise InputError(
                    f"levels[{position}].radius: {level.radius} needs cells of side 2^-{level.ball_level}, "
                    f"finer than the previous level's 2^-{source_level}"
                )
            source_level = level.grid_level
        for position, width in enumerate(self.head_channels):
            _check_positive_int(width, f"head_channels[{position}]")
        if len(self.decoder_channels) != 2:
            raise InputError(f"decoder_channels: expected two widths, got {self.decoder_channels!r}")
        for position, width in enumerate(self.decoder_channels):
            _check_positive_int(width, f"decoder_channels[{position}]")
        if not (isinstance(self.dropout, (int, float)) and 0.0 <= self.dropout < 1.0):
            raise InputError(f"dropout: expected a rate in [0, 1), got {self.dropout!r}")

    def to_dict(self) -> dict[str, Any]:
        """The configuration as JSON types."""
        result = asdict(self)
        result["levels"] = [asdict(level) for level in self.levels]
        result["head_channels"] = list(self.head_channels)
        result["decoder_channels"] = list(self.decoder_channels)
        return result

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> ModelConfig:
        """Rebuild a configuration from :meth:`to_dict`'s output.

        Raises
        ------
        InputError
            On unknown keys or invalid values.
        """
        if not isinstance(values, Mapping):
            raise InputError(f"architecture: expected a mapping, got {type(values).__name__}")
        known = set(cls.__dataclass_fields__)
        unknown = sorted(set(values) - known)
        if unknown:
            raise InputError(f"architecture: unknown keys {unknown}")
        kwargs = dict(values)
        if "levels" in kwargs:
            try:
                kwargs["levels"] = tuple(LevelConfig(**dict(level)) for level in kwargs["levels"])
            except TypeError as err:
                raise InputError(f"architecture: bad level description ({err})") from err
        for key in ("head_channels", "decoder_channels"):
            if key in kwargs:
                kwargs[key] = tuple(kwargs[key])
        return cls(**kwargs)


def _check_positive_int(value: Any, name: str) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise InputError(f"{name}: expected a positive integer, got {value!r}")


# ====================================================================== point hierarchy


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

    index: Tensor
    mask: Tensor
    count: Tensor


class Hierarchy(NamedTuple):
    """Everything the encoder needs besides its weights (:func:`build_hierarchy`).

    Attributes
    ----------
    levels : list of PointLevel
        Level 0 (the input) to the last subsampled level.
    neighbourhoods : list of Neighbourhood
        One per convolution: from level ``i`` to level ``i + 1``, then the
        global one from the last level to the bounding-box centre.
    densities : list of Tensor
        ``(P_i,) float``, the relative density of the source points of each
        convolution.
    """

    levels: list[PointLevel]
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
        repeated point stays at the origin). Directions from the centre are
        unchanged by this map.
    """
    _check_points(points)
    low = points.amin(dim=1, keepdim=True)
    high = points.amax(dim=1, keepdim=True)
    diagonal = (high - low).norm(dim=-1, keepdim=True).clamp_min(1e-12)
    return (points - (low + high) / 2.0) / diagonal


def _check_points(points: Tensor) -> None:
    if not isinstance(points, torch.Tensor):
        raise InputError(f"points: expected a torch.Tensor, got {type(points).__name__}")
    if points.ndim != 3 or points.shape[-1] != 3 or points.shape[0] < 1 or points.shape[1] < 1:
        raise InputError(f"points: expected shape (B, N, 3) with B, N >= 1, got {tuple(points.shape)}")
    if not points.is_floating_point():
        raise InputError(f"points: expected a floating dtype, got {points.dtype}")


def _spread_bits(values: Tensor) -> Tensor:
    """Insert two zero bits after every bit of 21-bit integers."""
    x = values & 0x1FFFFF
    x = (x | (x << 32)) & 0x1F00000000FFFF
    x = (x | (x << 16)) & 0x1F0000FF0000FF
    x = (x | (x << 8)) & 0x100F00F00F00F00F
    x = (x | (x << 4)) & 0x10C30C30C30C30C3
    x = (x | (x << 2)) & 0x1249249249249249
    return x


def _grid_coordinates(points: Tensor, level: int = CODE_BITS) -> Tensor:
    """Integer cell coordinates ``(..., 3)`` of normalised points on the grid of side ``2^-level``."""
    scaled = torch.floor((points.to(torch.float64) + 0.5) * float(1 << level))
    return scaled.clamp(0, (1 << level) - 1).to(torch.int64)


def _interleave(cells: Tensor) -> Tensor:
    return (_spread_bits(cells[..., 0]) << 2) | (_spread_bits(cells[..., 1]) << 1) | _spread_bits(cells[..., 2])


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


def input_level(points: Tensor) -> PointLevel:
    """Level 0: the normalised input points of every model, sorted by Morton code.

    Parameters
    ----------
    points : (B, N, 3) float
        Raw point clouds (they are normalised here).

    Returns
    -------
    PointLevel
        ``B * N`` points, model by model, each model's sorted by code (stable,
        so only points closer than ``2^-21`` diagonals can swap places).
    """
    normalised = normalize_points(points)
    n_models, n_points, _ = normalised.shape
    codes = morton_codes(normalised)
    order = torch.argsort(codes, dim=1, stable=True)
    sorted_points = torch.gather(normalised, 1, order.unsqueeze(-1).expand(-1, -1, 3))
    batch = torch.arange(n_models, device=points.device).repeat_interleave(n_points)
    return PointLevel(
        sorted_points.reshape(-1, 3), batch, torch.gather(codes, 1, order).reshape(-1), n_models
    )


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
    sums = torch.zeros(len(cells), 3, dtype=level.points.dtype, device=level.points.device).index_add_(
        0, inverse, level.points)
    points = sums / counts.unsqueeze(-1).to(sums.dtype)
    batch = cells >> (3 * grid_level)
    codes = (cells & ((1 << (3 * grid_level)) - 1)) << (3 * (CODE_BITS - grid_level))
    return PointLevel(points, batch, codes, level.n_models)


def _take(values: Tensor, index: Tensor) -> Tensor:
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


def ball_query(source: PointLevel, centres: PointLevel, radius: float, max_neighbours: int) -> Neighbourhood:
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
    k = _ball_level(radius)
    source_keys = _cell_keys(source, k)
    cells = _grid_coordinates(centres.points, k)  # (M, 3)
    offsets = torch.tensor(_NEIGHBOUR_CELLS, dtype=torch.int64, device=centres.points.device)
    neighbours = cells.unsqueeze(1) + offsets  # (M, 27, 3)
    # Skip cells outside the grid and cells whose nearest corner is beyond the radius.
    fraction = ((centres.points.to(torch.float64) + 0.5) * float(1 << k) - cells).unsqueeze(1)  # (M, 1, 3)
    gap = torch.where(offsets < 0, fraction, torch.where(offsets > 0, 1.0 - fraction, 0.0)).clamp_min(0.0)
    reach = (radius * (1 << k)) ** 2 * (1.0 + 1e-9)
    is_inside = ((neighbours >= 0) & (neighbours < (1 << k))).all(dim=-1) & (gap.square().sum(dim=-1) <= reach)
    keys = (centres.batch.unsqueeze(-1) << (3 * k)) | _interleave(neighbours.clamp(0, (1 << k) - 1))
    start = torch.searchsorted(source_keys, keys, side="left")
    stop = torch.searchsorted(source_keys, keys, side="right")
    run_length = torch.where(is_inside, stop - start, torch.zeros_like(start)).reshape(-1)
    # Expand the 27 runs of every centre into one flat candidate list, centre by centre.
    run = torch.repeat_interleave(torch.arange(len(run_length), device=run_length.device), run_length)
    run_shift = start.reshape(-1) - (torch.cumsum(run_length, 0) - run_length)
    candidate = _take(run_shift, run) + torch.arange(len(run), device=run.device)
    centre = torch.div(run, len(_NEIGHBOUR_CELLS), rounding_mode="floor")
    distance2 = (_take(source.points, candidate) - _take(centres.points, centre)).square().sum(dim=-1)
    near = torch.nonzero(distance2 <= radius * radius).squeeze(-1)
    candidate, centre = _take(candidate, near), _take(centre, near)
    count = torch.bincount(centre, minlength=len(centres.points))
    first = torch.cumsum(count, 0) - count
    slots, mask = _pad_ragged(first, count, max_neighbours)
    index = _take(candidate, slots) if len(candidate) else torch.zeros_like(slots)
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
    return _take(counts, inverse).to(level.points.dtype)


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
        levels = [input_level(points)]
        neighbourhoods = []
        densities = []
        source_level = _MAX_LEVEL
        for spec in config.levels:
            source = levels[-1]
            target = grid_subsample(source, spec.grid_level)
            if spec.neighbourhood == "cell":
                neighbourhoods.append(cell_neighbourhood(source, spec.grid_level, spec.max_neighbours))
            else:
                neighbourhoods.append(ball_query(source, target, spec.radius, spec.max_neighbours))
            densities.append(point_density(source, min(spec.search_level + 1, source_level)))
            levels.append(target)
            source_level = spec.grid_level
        neighbourhoods.append(whole_model_neighbourhood(levels[-1]))
        densities.append(point_density(levels[-1], min(_GLOBAL_BALL_LEVEL + 1, source_level)))
    return Hierarchy(levels, neighbourhoods, densities)


_GLOBAL_RADIUS = 0.5  # half the diagonal: the whole bounding box around its centre
_GLOBAL_BALL_LEVEL = 1  # cells of side 1/2


# ====================================================================== layers


class GeneratorDropout(nn.Module):
    """Dropout whose masks come from a :class:`torch.Generator`.

    Identical to :class:`torch.nn.Dropout` except that the random masks are
    drawn from ``self.generator`` (set by :meth:`ViewpointNet.set_generator`)
    rather than the global random state; without one, a generator seeded
    with 0 is created on first use.

    Args:
        p (float): Probability of zeroing an element. (default: 0.5)

    Shapes:
        - **input:** :math:`(*)`
        - **output:** :math:`(*)`, same shape
    """

    def __init__(self, p: float = 0.5) -> None:
        super().__init__()
        self.p = float(p)
        self.generator: torch.Generator | None = None

    def forward(self, x: Tensor) -> Tensor:
        if not self.training or self.p == 0.0:
            return x
        if self.generator is None:
            self.generator = torch.Generator(device=x.device).manual_seed(0)
        keep = torch.rand(x.shape, generator=self.generator, dtype=x.dtype, device=x.device) >= self.p
        return x * keep / (1.0 - self.p)

    def extra_repr(self) -> str:
        return f"p={self.p}"


class MonteCarloConv(nn.Module):
    r"""The Monte Carlo convolution of Hermosilla et al. (2018).

    A continuous convolution over the points of a neighbourhood, estimated
    by Monte Carlo integration with importance weights: each neighbour
    counts in inverse proportion to the point density there, so the result
    estimates the kernel-weighted mean over the *surface* in the
    neighbourhood whatever the sampling density. The kernel is an MLP of
    the scaled offset with ``K`` outputs, combined with the features through
    a linear map (the efficient form of PointConv, Wu et al. 2019):

    .. math::
        \mathbf{x}'_i = \mathbf{W} \operatorname{vec}\left(
        \sum_{j \in \mathcal{N}(i)} w_{ij}\,
        g_{\Theta}\!\left(\frac{\mathbf{y}_j - \mathbf{c}_i}{r}\right)
        \mathbf{x}_j^{\top} \right) + \mathbf{b},
        \qquad
        w_{ij} = \frac{\hat p(\mathbf{y}_j)^{-1}}
                      {\sum_{k \in \mathcal{N}(i)} \hat p(\mathbf{y}_k)^{-1}}

    with centres :math:`\mathbf{c}_i`, neighbours :math:`\mathbf{y}_j`,
    their features :math:`\mathbf{x}_j`, density estimates :math:`\hat p`
    (:func:`point_density`), scale :math:`r` and the kernel MLP
    :math:`g_{\Theta}: \mathbb{R}^3 \to \mathbb{R}^K` (3 - hidden - K,
    ReLU). The weights are self-normalised, so :math:`\hat p` is needed up
    to a constant only; MCCNN divides by :math:`|\mathcal{N}(i)|` instead,
    which equals this for uniform sampling.

    Args:
        in_channels (int): Input feature size :math:`C_{in}`.
        out_channels (int): Output feature size :math:`C_{out}`.
        radius (float): Scale :math:`r` of the offsets (the ball radius).
        kernel_size (int): Kernel MLP outputs :math:`K`. (default: 16)
        kernel_hidden (int): Kernel MLP hidden units. (default: 16)

    Shapes:
        - **input:**
          source points :math:`(P, 3)`, source features :math:`(P, C_{in})`,
          densities :math:`(P)`, centres :math:`(M, 3)`,
          a :class:`Neighbourhood` of width :math:`S` (:math:`(M, S)`)
        - **output:** :math:`(M, C_{out})`
    """

    def __init__(self, in_channels: int, out_channels: int, *, radius: float,
                 kernel_size: int = 16, kernel_hidden: int = 16) -> None:
        super().__init__()
        self.in_channels = in_channels
        self.out_channels = out_channels
        self.radius = float(radius)
        self.kernel_size = kernel_size
        self.kernel = nn.Sequential(nn.Linear(3, kernel_hidden), nn.ReLU(), nn.Linear(kernel_hidden, kernel_size))
        self.linear = nn.Linear(kernel_size * in_channels, out_channels)

    def forward(self, source_points: Tensor, source_features: Tensor, density: Tensor,
                centre_points: Tensor, neighbourhood: Neighbourhood) -> Tensor:
        index, mask, count = neighbourhood
        offsets = (_take(source_points, index) - centre_points.unsqueeze(1)) / self.radius  # (M, S, 3)
        inverse_density = mask.to(offsets.dtype) / _take(density, index)
        weights = inverse_density / inverse_density.sum(dim=1, keepdim=True).clamp_min(1e-12)
        kernel = self.kernel(offsets) * weights.unsqueeze(-1)  # (M, S, K)
        aggregated = kernel.transpose(1, 2) @ _take(source_features, index)  # (M, K, C_in)
        return self.linear(aggregated.flatten(start_dim=1))

    def extra_repr(self) -> str:
        return f"{self.in_channels}, {self.out_channels}, radius={self.radius:g}, kernel_size={self.kernel_size}"


class PointEncoder(nn.Module):
    """Point clouds to one latent vector: Monte Carlo convolutions over a point hierarchy.

    Each level is :class:`MonteCarloConv`, batch norm and ReLU, from the
    points of the previous level to the cell barycentres of the next
    (:func:`build_hierarchy`); the last one integrates the whole model around
    its bounding-box centre. The input features are the normalised
    coordinates. See the module docstring for the default sizes.

    Args:
        config (ModelConfig): The architecture.

    Shapes:
        - **input:** points :math:`(B, N, 3)`
        - **output:** :math:`(B, C_{latent})`
    """

    def __init__(self, config: ModelConfig) -> None:
        super().__init__()
        self.config = config
        convs = []
        norms = []
        in_channels = 3
        for spec in config.levels:
            convs.append(MonteCarloConv(in_channels, spec.channels, radius=spec.radius,
                                        kernel_size=config.kernel_size, kernel_hidden=config.kernel_hidden))
            norms.append(nn.BatchNorm1d(spec.channels))
            in_channels = spec.channels
        convs.append(MonteCarloConv(in_channels, config.latent_channels, radius=_GLOBAL_RADIUS,
                                    kernel_size=config.global_kernel_size, kernel_hidden=config.kernel_hidden))
        norms.append(nn.BatchNorm1d(config.latent_channels))
        self.convs = nn.ModuleList(convs)
        self.norms = nn.ModuleList(norms)

    def forward(self, points: Tensor) -> Tensor:
        _check_points(points)
        dtype = self.convs[0].linear.weight.dtype
        hierarchy = build_hierarchy(points.to(dtype), self.config)
        levels = hierarchy.levels
        features = levels[0].points
        n_models = levels[0].n_models
        centre = torch.zeros(n_models, 3, dtype=features.dtype, device=features.device)
        targets = [level.points for level in levels[1:]] + [centre]
        for i, (conv, norm) in enumerate(zip(self.convs, self.norms)):
            source = levels[i]
            features = torch.relu(norm(conv(source.points, features, hierarchy.densities[i],
                                            targets[i], hierarchy.neighbourhoods[i])))
        return features


class DirectionHead(nn.Module):
    """MLP from the latent vector to one output vector, for one measure.

    ``Linear - BatchNorm - ReLU - Dropout`` for every hidden width, then a
    final ``Linear``.

    Args:
        in_channels (int): Latent size.
        hidden (sequence of int): Hidden widths.
        out_channels (int): Output size (3 for a direction, 8 for sign logits).
        dropout (float): Dropout rate. (default: 0.5)

    Shapes:
        - **input:** :math:`(B, C_{in})`
        - **output:** :math:`(B, C_{out})`
    """

    def __init__(self, in_channels: int, hidden: Sequence[int], out_channels: int, dropout: float = 0.5) -> None:
        super().__init__()
        layers: list[nn.Module] = []
        width = in_channels
        for size in hidden:
            layers += [nn.Linear(width, size), nn.BatchNorm1d(size), nn.ReLU(), GeneratorDropout(dropout)]
            width = size
        layers.append(nn.Linear(width, out_channels))
        self.mlp = nn.Sequential(*layers)

    def forward(self, latent: Tensor) -> Tensor:
        return self.mlp(latent)


class _ResidualBlock(nn.Module):
    """Two 3 x 3 convolutions with batch norm and ReLU, plus the identity."""

    def __init__(self, channels: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(channels, channels, 3, padding=1, bias=False)
        self.norm1 = nn.BatchNorm2d(channels)
        self.conv2 = nn.Conv2d(channels, channels, 3, padding=1, bias=False)
        self.norm2 = nn.BatchNorm2d(channels)

    def forward(self, x: Tensor) -> Tensor:
        y = torch.relu(self.norm1(self.conv1(x)))
        return torch.relu(x + self.norm2(self.conv2(y)))


class SphereMapDecoder(nn.Module):
    """2D decoder from the latent vector to a 32 x 32 sphere map (DLDL head).

    After the paper's appendix "Distribution Learning": a 4 x 4
    deconvolution (1 -> 4 cells a side), two residual blocks, a 4 x 4
    stride-4 deconvolution (-> 16), two residual blocks and a 2 x 2 stride-2
    deconvolution (-> 32) to one channel, with batch norm and ReLU between
    the layers. Cells follow the octahedral map of
    :func:`vptoolkit.learn.labels.sphere_map_directions`.

    Args:
        in_channels (int): Latent size.
        channels (tuple of int): Widths at 4 x 4 and 16 x 16. (default: (64, 16))

    Shapes:
        - **input:** :math:`(B, C_{in})`
        - **output:** :math:`(B, 32, 32)`
    """

    def __init__(self, in_channels: int, channels: Sequence[int] = (64, 16)) -> None:
        super().__init__()
        wide, narrow = channels
        self.layers = nn.Sequential(
            nn.ConvTranspose2d(in_channels, wide, 4, stride=1, bias=False),
            nn.BatchNorm2d(wide),
            nn.ReLU(),
            _ResidualBlock(wide),
            _ResidualBlock(wide),
            nn.ConvTranspose2d(wide, narrow, 4, stride=4, bias=False),
            nn.BatchNorm2d(narrow),
            nn.ReLU(),
            _ResidualBlock(narrow),
            _ResidualBlock(narrow),
            nn.ConvTranspose2d(narrow, 1, 2, stride=2),
        )

    def forward(self, latent: Tensor) -> Tensor:
        return self.layers(latent[:, :, None, None])[:, 0]


class ViewpointNet(nn.Module):
    """The viewpoint network: :class:`PointEncoder` and one head per measure.

    Parameters are initialised from a :class:`torch.Generator` seeded with
    ``seed`` (uniform in ``+-1/sqrt(fan_in)``, PyTorch's default bounds; batch
    norm at identity), never from the global random state.

    Args:
        config (ModelConfig, optional): The architecture. (default: ``ModelConfig()``)
        seed (int): Seed of the initial weights. (default: 0)

    Shapes:
        - **input:** points :math:`(B, N, 3)`, any position and scale,
          :math:`B \\ge 2` in training mode (batch norm)
        - **output:** a dict with

          - ``"directions"``: :math:`(B, M, 3)` unit predictions, in the
            input's frame, one per measure (always)
          - ``"abs_directions"``: :math:`(B, M, 3)` and ``"sign_logits"``:
            :math:`(B, M, 8)` (``head="sr"``)
          - ``"maps"``: :math:`(B, M, 32, 32)` predicted quality maps (``head="dldl"``)
          - ``"frame"``: :math:`(B, 3, 3)` the canonical frame ``C`` of each
            input (``input_frame="pca"``); ``abs_directions``, ``sign_logits``
            and ``maps`` are in that frame, ``directions`` are mapped back
            with ``d C``
    """

    def __init__(self, config: ModelConfig | None = None, *, seed: int = 0) -> None:
        super().__init__()
        config = ModelConfig() if config is None else config
        if not isinstance(config, ModelConfig):
            raise InputError(f"config: expected a ModelConfig, got {type(config).__name__}")
        self.config = config
        with torch.device("meta"):
            self.encoder = PointEncoder(config)
            latent = config.latent_channels
            width = config.head_channels
            if config.head == "direction":
                self.heads = nn.ModuleList(
                    DirectionHead(latent, width, 3, config.dropout) for _ in range(config.n_measures))
            elif config.head == "sr":
                self.heads = nn.ModuleList(
                    DirectionHead(latent, width, 3, config.dropout) for _ in range(config.n_measures))
                self.sign_heads = nn.ModuleList(
                    DirectionHead(latent, width, 8, config.dropout) for _ in range(config.n_measures))
            else:
                self.heads = nn.ModuleList(
                    SphereMapDecoder(latent, config.decoder_channels) for _ in range(config.n_measures))
        self.to_empty(device="cpu")
        self.reset_parameters(seed=seed)
        self._generator: torch.Generator | None = None

    def reset_parameters(self, *, seed: int = 0) -> None:
        """Initialise every weight from a generator seeded with ``seed``.

        Linear and convolution weights and biases are uniform in
        ``+-1/sqrt(fan_in)``; batch norm has weight 1, bias 0 and fresh
        running statistics.
        """
        generator = torch.Generator().manual_seed(int(seed))
        with torch.no_grad():
            for module in self.modules():
                if isinstance(module, (nn.Linear, nn.Conv2d, nn.ConvTranspose2d)):
                    bound = 1.0 / math.sqrt(module.weight[0].numel())
                    module.weight.uniform_(-bound, bound, generator=generator)
                    if module.bias is not None:
                        module.bias.uniform_(-bound, bound, generator=generator)
                elif isinstance(module, (nn.BatchNorm1d, nn.BatchNorm2d)):
                    module.reset_parameters()

    def set_generator(self, generator: torch.Generator | None) -> None:
        """Draw dropout masks and, in training, ambiguous frame signs from ``generator``."""
        self._generator = generator
        for module in self.modules():
            if isinstance(module, GeneratorDropout):
                module.generator = generator

    def forward(self, points: Tensor) -> dict[str, Tensor]:
        frame = None
        if self.config.input_frame == "pca":
            _check_points(points)
            frame, centre = canonical_frame(points, generator=self._generator if self.training else None)
            points = to_frame(points, frame, centre)
        outputs = self._heads(self.encoder(points))
        if frame is not None:
            outputs["directions"] = from_frame(outputs["directions"], frame)
            outputs["frame"] = frame
        return outputs

    def _heads(self, latent: Tensor) -> dict[str, Tensor]:
        """Head outputs in the frame the encoder saw."""
        head = self.config.head
        if head == "direction":
            raw = torch.stack([mlp(latent) for mlp in self.heads], dim=1)
            return {"directions": raw / raw.norm(dim=-1, keepdim=True).clamp_min(1e-12)}
        if head == "sr":
            abs_directions = spherical_exponential(torch.stack([mlp(latent) for mlp in self.heads], dim=1))
            sign_logits = torch.stack([mlp(latent) for mlp in self.sign_heads], dim=1)
            return {
                "directions": decode_spherical_regression(abs_directions.detach(), sign_logits.detach()),
                "abs_directions": abs_directions,
                "sign_logits": sign_logits,
            }
        maps = torch.stack([decoder(latent) for decoder in self.heads], dim=1)
        return {"directions": decode_sphere_maps(maps.detach()), "maps": maps}


def count_parameters(model: nn.Module) -> int:
    """Number of learned parameters (batch-norm running statistics excluded)."""
    return sum(parameter.numel() for parameter in model.parameters())


@contextlib.contextmanager
def torch_threads(threads: int | None) -> Iterator[None]:
    """Set torch's intra-op thread count for a block and restore it afterwards.

    Parameters
    ----------
    threads : int or None
        Threads to use, at least 1; None leaves torch's setting alone.

    Raises
    ------
    InputError
        If ``threads`` is not a positive integer or None.
    """
    if threads is None:
        yield
        return
    _check_positive_int(threads, "threads")
    previous = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


def resolve_device(device: str) -> torch.device:
    """``"auto"`` (CUDA when available, else the CPU), ``"cpu"`` or ``"cuda"`` / ``"cuda:N"``.

    Raises
    ------
    InputError
        For another name, or CUDA asked for where torch sees no CUDA device.
    """
    if device == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if device == "cpu":
        return torch.device("cpu")
    if isinstance(device, str) and (device == "cuda" or device.startswith("cuda:")):
        if not torch.cuda.is_available():
            raise InputError(f"device: {device!r} asked for, but torch {torch.__version__} sees no CUDA device")
        return torch.device(device)
    raise InputError(f"device: expected 'auto', 'cpu' or 'cuda', got {device!r}")


# ====================================================================== checkpoint files


def checkpoint_paths(path: str | os.PathLike[str]) -> tuple[Path, Path]:
    """The weights and configuration files of a checkpoint.

    Parameters
    ----------
    path : path-like
        A folder (``model.safetensors`` and ``model.json`` inside it), a
        ``*.safetensors`` file or its ``*.json`` configuration, or
        ``"default"`` for the pretrained checkpoint bundled with the package
        (:data:`PRETRAINED`; a file or folder named ``default`` in the
        working directory takes precedence).

    Returns
    -------
    weights, config : Path
        ``<stem>.safetensors`` and ``<stem>.json`` side by side.
    """
    if str(path) == DEFAULT_MODEL and not Path(path).exists():
        path = PRETRAINED
    path = Path(path)
    if path.suffix == ".safetensors":
        return path, path.with_suffix(".json")
    if path.suffix == ".json":
        return path.with_suffix(".safetensors"), path
    return path / "model.safetensors", path / "model.json"




def write_json_atomic(path: Path, values: Mapping[str, Any]) -> None:
    """Write JSON (sorted keys, indented) atomically."""
    write_bytes_atomic(path, (json.dumps(values, indent=2, sort_keys=True) + "\n").encode("utf-8"))


def write_safetensors_atomic(path: Path, tensors: Mapping[str, Tensor], metadata: Mapping[str, str] | None = None) -> None:
    """Write tensors as one safetensors file, atomically."""
    safetensors_torch = require("safetensors.torch", extra="learn")
    contiguous = {name: tensor.detach().contiguous().cpu() for name, tensor in tensors.items()}
    write_bytes_atomic(path, safetensors_torch.save(contiguous, metadata=dict(metadata or {})))


def read_json(path: Path, what: str) -> dict[str, Any]:
    """Read a JSON object, raising :class:`InputError` naming ``path``."""
    if not path.is_file():
        raise InputError(f"{path}: {what} not found")
    try:
        values = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise InputError(f"{path.name}: cannot read {what} ({err})") from err
    if not isinstance(values, dict):
        raise InputError(f"{path.name}: {what} is not a JSON object")
    return values


def read_safetensors(path: Path) -> dict[str, Tensor]:
    """Read every tensor of a safetensors file (no pickle involved)."""
    safetensors_torch = require("safetensors.torch", extra="learn")
    if not path.is_file():
        raise InputError(f"{path}: weights file not found")
    try:
        return dict(safetensors_torch.load_file(str(path), device="cpu"))
    except Exception as err:  # safetensors raises its own SafetensorError and OSError
        raise InputError(f"{path.name}: not a readable safetensors file ({err})") from err


def save_model(model: ViewpointNet, path: str | os.PathLike[str], *,
               metadata: Mapping[str, Any] | None = None, half: bool = False) -> tuple[Path, Path]:
    """Save a network as ``safetensors`` weights plus a JSON configuration.

    Parameters
    ----------
    model : ViewpointNet
        The network; its ``state_dict`` (weights and batch-norm statistics)
        is saved.
    path : path-like
        Folder or ``*.safetensors`` file (:func:`checkpoint_paths`); the
        folder is created.
    metadata : mapping, optional
        More JSON entries for the configuration (label method, training
        arguments, scores, ...). ``format``, ``architecture``, ``measures``,
        ``n_parameters`` and ``weights_dtype`` are always written by this
        function.
    half : bool
        Store floating-point tensors as float16 (half the file size; they
        are loaded back into the float32 network). Default: False.

    Returns
    -------
    weights, config : Path
    """
    if not isinstance(model, ViewpointNet):
        raise InputError(f"model: expected a ViewpointNet, got {type(model).__name__}")
    weights_path, config_path = checkpoint_paths(path)
    weights_path.parent.mkdir(parents=True, exist_ok=True)
    config = dict(metadata or {})
    config.update({
        "format": MODEL_FORMAT,
        "format_version": 1,
        "architecture": model.config.to_dict(),
        "measures": list(MEASURES[: model.config.n_measures]),
        "n_parameters": count_parameters(model),
        "weights_dtype": "float16" if half else "float32",
    })
    state = model.state_dict()
    if half:
        state = {name: tensor.half() if tensor.is_floating_point() else tensor
                 for name, tensor in state.items()}
    write_safetensors_atomic(weights_path, state, {"format": MODEL_FORMAT})
    write_json_atomic(config_path, config)
    return weights_path, config_path


def load_model(path: str | os.PathLike[str]) -> tuple[ViewpointNet, dict[str, Any]]:
    """Load a network saved by :func:`save_model` (or by training), in eval mode.

    Parameters
    ----------
    path : path-like
        Folder, ``*.safetensors`` or ``*.json`` of the checkpoint.

    Returns
    -------
    model : ViewpointNet
        In evaluation mode.
    config : dict
        The JSON configuration (architecture, label method, measures,
        training arguments, best score, toolkit version, ...).

    Raises
    ------
    InputError
        If a file is missing or unreadable, or the configuration is not a
        vptoolkit model.
    VerificationError
        If the weights do not match the architecture.
    """
    weights_path, config_path = checkpoint_paths(path)
    config = read_json(config_path, "model configuration")
    if config.get("format") != MODEL_FORMAT:
        raise InputError(f"{config_path.name}: not a vptoolkit model configuration (format {config.get('format')!r})")
    if list(config.get("measures", [])) != list(MEASURES[: len(config.get("measures", []))]):
        raise VerificationError(f"{config_path.name}: measure order {config.get('measures')} differs from {list(MEASURES)}")
    architecture = dict(config.get("architecture", {}))
    architecture.setdefault("input_frame", "none")  # checkpoints written before the option saw raw inputs
    model = ViewpointNet(ModelConfig.from_dict(architecture))
    state = read_safetensors(weights_path)  # float16 weights are cast on loading
    try:
        model.load_state_dict(state, strict=True)
    except RuntimeError as err:
        raise VerificationError(f"{weights_path.name}: weights do not match the architecture ({err})") from err
    model.eval()
    return model, config
