"""The architecture of a viewpoint network: levels, widths, heads, measures and input frame.

:class:`ModelConfig` is stored in every checkpoint's JSON and rebuilt from it;
:class:`LevelConfig` describes one level of the point hierarchy
(:mod:`vptoolkit.learn.hierarchy`) and its convolution
(:mod:`vptoolkit.learn.layers`). Needs no torch.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any, Final

from vptoolkit.checks import check_float, check_int, check_keys, short_repr
from vptoolkit.errors import InputError
from vptoolkit.learn.frame import INPUT_FRAMES
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.point_features import check_feature_names, feature_width

__all__ = ["HEADS", "MAX_GRID_LEVEL", "MAX_CHANNELS", "MAX_INPUT_POINTS", "MAX_KERNEL",
           "MAX_LAYERS", "MAX_NEIGHBOURS", "MAX_PARAMETERS", "DEFAULT_LEVELS", "LevelConfig",
           "ModelConfig",
           "ball_level", "check_input_sizes", "check_measure_names", "check_positive_int"]

HEADS: Final = ("direction", "sr", "dldl")
"""Network heads: unit directions, spherical regression, sphere maps."""

MAX_GRID_LEVEL: Final = 16
"""Finest grid level used: ``(batch << 3k) | cell`` fits 63 bits for batches up to 2^15."""

# Bounds of a configuration, so that a checkpoint's JSON cannot ask for more memory than a
# machine has (the defaults are 64 to 512 channels, kernels of 8 and 16, 32 neighbours,
# three levels, 2.3 million parameters and inputs of 4096 points).
MAX_CHANNELS: Final = 4096
"""Widest level, latent vector, head or decoder layer."""

MAX_KERNEL: Final = 256
"""Largest ``kernel_size``, ``global_kernel_size`` and ``kernel_hidden``."""

MAX_INPUT_POINTS: Final = 1 << 16
"""Most points of one network input (``n_points``)."""

MAX_NEIGHBOURS: Final = 1024
"""Most neighbours per point of one level (each level's neighbourhoods take that many slots)."""

MAX_LAYERS: Final = 16
"""Most levels, and most hidden layers of a head."""

MAX_PARAMETERS: Final = 1 << 27
"""Most parameters of a network (134 million, 512 MiB in float32)."""

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
        """Level ``k`` of the cells searched by the ball query.

        The finest level with ``2^-k >= radius``.
        """
        return ball_level(self.radius)

    @property
    def search_level(self) -> int:
        """Grid level of the neighbourhood search.

        It is :attr:`ball_level`, or :attr:`grid_level` for cells.
        """
        return self.grid_level if self.neighbourhood == "cell" else self.ball_level


def ball_level(radius: float) -> int:
    """Level ``k`` of the grid cells a ball of ``radius`` is searched in.

    The finest level with ``2^-k >= radius``.
    """
    return max(0, min(MAX_GRID_LEVEL, math.floor(-math.log2(radius) + 1e-9)))


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
    measures : tuple of str
        The measure each head predicts, in head order: distinct names of the
        registry (:func:`vptoolkit.measures.registry.resolve_measures`), any
        number of them, the paper's four among them in their order, as
        :class:`~vptoolkit.predictions.Predictions` carry them (default:
        ``PAPER_MEASURES``, the paper's four). A sequence is kept as a tuple.
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
        own frame. Default: "pca".
    point_features : tuple of str
        Features each input point carries after its coordinates, in order,
        names of :data:`vptoolkit.point_features.POINT_FEATURES` (default: none,
        coordinates alone). ``("face_area",)`` tells the network the size of the
        face under each point, which the tessellation-weighted measures (VE,
        VMI) depend on and uniform points do not show; ``"normal"`` adds its
        normal, a vector that turns with the canonical frame.
    """

    head: str = "direction"
    measures: tuple[str, ...] = PAPER_MEASURES
    levels: tuple[LevelConfig, ...] = DEFAULT_LEVELS
    latent_channels: int = 512
    kernel_size: int = 16
    global_kernel_size: int = 8
    kernel_hidden: int = 16
    head_channels: tuple[int, ...] = (256, 64)
    dropout: float = 0.5
    decoder_channels: tuple[int, int] = field(default=(64, 16))
    input_frame: str = "pca"
    point_features: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "point_features", check_feature_names(self.point_features))
        if self.input_frame not in INPUT_FRAMES:
            raise InputError(f"input_frame: expected one of {list(INPUT_FRAMES)}, "
                             f"got {self.input_frame!r}")
        if self.head not in HEADS:
            raise InputError(f"head: unknown head {self.head!r}, expected one of {list(HEADS)}")
        object.__setattr__(self, "measures", check_measure_names(self.measures, predicted=True))
        check_positive_int(self.latent_channels, "latent_channels", maximum=MAX_CHANNELS)
        for name in ("kernel_size", "global_kernel_size", "kernel_hidden"):
            check_positive_int(getattr(self, name), name, maximum=MAX_KERNEL)
        if not self.levels:
            raise InputError("levels: expected at least one level")
        if len(self.levels) > MAX_LAYERS:
            raise InputError(f"levels: expected at most {MAX_LAYERS} levels, "
                             f"got {len(self.levels)}")
        source_level = MAX_GRID_LEVEL
        for position, level in enumerate(self.levels):
            if not isinstance(level, LevelConfig):
                raise InputError(f"levels[{position}]: expected a LevelConfig, "
                                 f"got {type(level).__name__}")
            check_positive_int(level.max_neighbours, f"levels[{position}].max_neighbours",
                               maximum=MAX_NEIGHBOURS)
            check_positive_int(level.channels, f"levels[{position}].channels", maximum=MAX_CHANNELS)
            check_int(level.grid_level, f"levels[{position}].grid_level", minimum=1,
                      maximum=source_level, numpy=False,
                      expected=f"an integer in [1, {source_level}] (no finer than the level "
                               "before)")
            check_float(level.radius, f"levels[{position}].radius",
                        minimum=2.0**-MAX_GRID_LEVEL, maximum=1.0,
                        expected="a number in [2^-16, 1]")
            if level.neighbourhood not in ("ball", "cell"):
                raise InputError(
                    f"levels[{position}].neighbourhood: expected 'ball' or 'cell', "
                    f"got {level.neighbourhood!r}"
                )
            if level.neighbourhood == "ball" and level.ball_level > source_level:
                raise InputError(
                    f"levels[{position}].radius: {level.radius} needs cells of side "
                    f"2^-{level.ball_level}, "
                    f"finer than the previous level's 2^-{source_level}"
                )
            source_level = level.grid_level
        if len(self.head_channels) > MAX_LAYERS:
            raise InputError(f"head_channels: expected at most {MAX_LAYERS} layers, "
                             f"got {len(self.head_channels)}")
        for position, width in enumerate(self.head_channels):
            check_positive_int(width, f"head_channels[{position}]", maximum=MAX_CHANNELS)
        if len(self.decoder_channels) != 2:
            raise InputError("decoder_channels: expected two widths, "
                             f"got {self.decoder_channels!r}")
        for position, width in enumerate(self.decoder_channels):
            check_positive_int(width, f"decoder_channels[{position}]", maximum=MAX_CHANNELS)
        check_float(self.dropout, "dropout", minimum=0.0, below=1.0, expected="a rate in [0, 1)")

    @property
    def input_channels(self) -> int:
        """Channels of one input point: 3 coordinates and the point features' columns
        (:func:`vptoolkit.point_features.feature_width`)."""
        return 3 + feature_width(self.point_features)

    @property
    def n_measures(self) -> int:
        """Heads: one per measure, ``len(measures)``."""
        return len(self.measures)

    def to_dict(self) -> dict[str, Any]:
        """The configuration as JSON types."""
        result = asdict(self)
        result["measures"] = list(self.measures)
        result["levels"] = [asdict(level) for level in self.levels]
        result["head_channels"] = list(self.head_channels)
        result["decoder_channels"] = list(self.decoder_channels)
        result["point_features"] = list(self.point_features)
        return result

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> ModelConfig:
        """Rebuild a configuration from :meth:`to_dict`'s output.

        Raises
        ------
        InputError
            On unknown keys, invalid values or sizes beyond the bounds above
            (``MAX_CHANNELS``, ``MAX_KERNEL``, ``MAX_NEIGHBOURS``, ``MAX_LAYERS``),
            naming the field.
        """
        kwargs = check_keys(values, tuple(cls.__dataclass_fields__), "architecture",
                            missing_ok=True)
        if "levels" in kwargs:
            levels = kwargs["levels"]
            if not isinstance(levels, (list, tuple)) or not all(isinstance(level, Mapping)
                                                                for level in levels):
                raise InputError("levels: expected a list of level objects, "
                                 f"got {short_repr(levels)}")
            if len(levels) > MAX_LAYERS:
                raise InputError(f"levels: expected at most {MAX_LAYERS} levels, got {len(levels)}")
            try:
                kwargs["levels"] = tuple(LevelConfig(**dict(level)) for level in levels)
            except TypeError as err:
                raise InputError(f"architecture: bad level description ({err})") from err
        for key in ("head_channels", "decoder_channels"):
            if key in kwargs:
                if not isinstance(kwargs[key], (list, tuple)):
                    raise InputError(f"{key}: expected a list of widths, "
                                     f"got {short_repr(kwargs[key])}")
                kwargs[key] = tuple(kwargs[key])
        return cls(**kwargs)


def check_measure_names(names: Any, *, text: bool = False,
                        predicted: bool = False) -> tuple[str, ...]:
    """Return ``names`` as a tuple of distinct registered measure names, or raise.

    Parameters
    ----------
    names : sequence of str
        Measure names, in order.
    text : bool
        Also take one string as :func:`~vptoolkit.measures.registry.resolve_measures`
        reads it: comma-separated names, ``"all"`` or ``"paper"`` (default: False).
    predicted : bool
        Also require names that a network's answers can carry as
        :class:`~vptoolkit.predictions.Predictions`
        (:func:`~vptoolkit.predictions.check_prediction_measures`: the
        paper's four in their order among themselves), as the heads of a
        network must be (default: False).

    Raises
    ------
    InputError
        ``measures: ...`` for something other than a sequence of strings, an
        empty one, an unknown name (:func:`~vptoolkit.measures.registry.get_measure`),
        a repeated one, or, with ``predicted``, names out of that order.
    """
    from vptoolkit.measures.registry import resolve_measures
    from vptoolkit.predictions import check_prediction_measures

    if not (text and isinstance(names, str)) and (
            isinstance(names, str) or not isinstance(names, (list, tuple))
            or not all(isinstance(name, str) for name in names)):
        raise InputError(f"measures: expected a list of measure names, got {short_repr(names)}")
    try:
        resolved = resolve_measures(names)
        return check_prediction_measures(resolved) if predicted else resolved
    except InputError as err:
        message = str(err)
        raise InputError(message if message.startswith("measures:")
                         else f"measures: {message}") from err


def check_positive_int(value: Any, name: str, *, maximum: int | None = None) -> None:
    """Raise :class:`InputError` naming ``name`` unless ``value`` is an int in ``[1, maximum]``."""
    value = check_int(value, name, minimum=1, numpy=False, expected="a positive integer")
    if maximum is not None and value > maximum:
        raise InputError(f"{name}: expected at most {maximum}, got {value}")


def check_input_sizes(n_points: Any, n_fps: Any, *, prefix: str = "") -> tuple[int, int]:
    """Return a network input's size and farthest-point part, or raise naming the bad one.

    ``1 <= n_points <= MAX_INPUT_POINTS`` and ``1 <= n_fps <= n_points``: a
    network's input starts with farthest-point picks, as in the paper. The
    message names ``{prefix}n_points`` or ``{prefix}n_fps``.
    """
    n_points = check_int(n_points, f"{prefix}n_points", minimum=1, maximum=MAX_INPUT_POINTS)
    n_fps = check_int(n_fps, f"{prefix}n_fps", minimum=1)
    if n_fps > n_points:
        raise InputError(f"{prefix}n_fps: {n_fps} exceeds n_points={n_points}")
    return n_points, n_fps
