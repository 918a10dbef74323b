"""The options of a training run as one value: :class:`TrainOptions`.

A :class:`TrainOptions` holds everything that defines a run's result: the
label method, the optimisation (epochs, batch size, learning rate and its
schedule), the seed, the models (validation split, ``max_models``,
categories), the inputs (points, farthest-point picks, rotation, the
farthest-point pool), the validation rotations, the measures the heads learn
and the architecture. It is
checked once, when it is made; :meth:`TrainOptions.to_dict` is what a run
records (in ``model.json`` and its resumable state) and
:meth:`TrainOptions.from_dict` reads it back, so resuming compares two
values (:meth:`TrainOptions.resume_conflicts`).

How a run uses the machine (device, threads, data-loading workers, how often
it saves, progress bars) does not change what it learns, so those are
keywords of :func:`vptoolkit.learn.train.train_model`, not options.

Importing this module loads no torch (the command line reads its defaults);
making options does, to check the label method and the architecture.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields, replace
from typing import TYPE_CHECKING, Any, Final

from vptoolkit.checks import (
    changed_values,
    check_bool,
    check_float,
    check_int,
    check_keys,
    short_repr,
)
from vptoolkit.conventions import SEED, SPLITS
from vptoolkit.dataset.store.schema import published_split
from vptoolkit.errors import InputError
from vptoolkit.learn.schedule import (
    PAPER_BATCH_SIZE,
    PAPER_EPOCHS,
    PAPER_LR,
    PAPER_LR_DECAY,
    scaled_lr_step,
)
from vptoolkit.points import N_FPS_POINTS, N_NETWORK_POINTS

if TYPE_CHECKING:
    from vptoolkit.learn.config import ModelConfig

__all__ = [
    "DEFAULT_LABELS",
    "DEFAULT_VAL_SPLIT",
    "DEFAULT_FPS_POOL",
    "DEFAULT_VAL_ROTATIONS",
    "DEFAULT_POINT_FEATURES",
    "TrainOptions",
]

DEFAULT_LABELS: Final = "ml+gl"
"""The paper's label method: multiple labels, then Gaussian labels."""

DEFAULT_VAL_SPLIT: Final = "validation"
"""The split whose score picks the best checkpoint."""

DEFAULT_FPS_POOL: Final = 8
"""Farthest-point subsets kept per model (0: sample anew for every input)."""

DEFAULT_VAL_ROTATIONS: Final = 3
"""Fixed rotations per validation model (0: the stored orientation only)."""

DEFAULT_POINT_FEATURES: Final = ("face_area",)
"""Point features of a network made from no architecture: the relative area of the
face under each point, which lifts VE and VMI on real meshes (``docs/results.md``)."""

_POSITIVE = "a positive finite number"


@dataclass(frozen=True)
class TrainOptions:
    """What defines a training run's result; checked when made.

    Attributes
    ----------
    labels : {"ml+gl", "sl", "ml", "gl", "sr", "dldl"}
        Label method, any case (default: :data:`DEFAULT_LABELS`, the paper's).
    epochs : int
        Total epochs (default: :data:`~vptoolkit.learn.schedule.PAPER_EPOCHS`);
        a resumed run continues up to this number (``ml+gl`` switches to GL
        after half of it).
    batch_size : int
        Models per step, at least 2 for batch norm
        (default: :data:`~vptoolkit.learn.schedule.PAPER_BATCH_SIZE`).
    lr, lr_decay : float
        Adam's learning rate ``lr * lr_decay ** (epoch // lr_step)``, both
        positive (defaults: the paper's 0.001 and 0.75).
    lr_step : int, optional
        Epochs per decay step; None gives
        :func:`~vptoolkit.learn.schedule.scaled_lr_step` of ``epochs``, fixed
        when the options are made (``dataclasses.replace`` with other
        ``epochs`` keeps it unless ``lr_step=None`` is given again). A run
        resumed with more epochs and the default step takes the step of
        its new length.
    seed : int
        Seed of weights, shuffling, dropout and augmentation, at least 0
        (default: :data:`~vptoolkit.conventions.SEED`).
    val_split : str
        Split that picks the best checkpoint, one of
        :data:`~vptoolkit.conventions.SPLITS` or the alias "val"
        (default: :data:`DEFAULT_VAL_SPLIT`; "train" for tiny datasets).
        Kept under its published name.
    max_models : int, optional
        Use at most this many models of each split, in store order
        (default: all).
    categories : sequence of str, optional
        Train and validate on these categories only (default: all); kept as
        a sorted tuple without repeats (a string is one category).
    n_points, n_fps : int
        Input points per model and how many of them farthest point sampling
        picks (defaults: :data:`~vptoolkit.points.N_NETWORK_POINTS` and
        :data:`~vptoolkit.points.N_FPS_POINTS`).
    rotate : bool
        Random rotation augmentation (default: True).
    fps_pool : int
        Farthest-point subsets kept per model (default:
        :data:`DEFAULT_FPS_POOL`; 0 runs farthest point sampling for every
        input, the slow way).
    val_rotations : int
        Fixed rotations per validation model (default:
        :data:`DEFAULT_VAL_ROTATIONS`; 0 validates in the stored orientation).
    measures : sequence of str or str, optional
        The measures the network learns, one head each, in head order: names
        the dataset records (its ``measures`` attribute), as a sequence or one
        comma-separated string (:func:`vptoolkit.measures.registry.resolve_measures`),
        the paper's four among them in their order; kept as a tuple. None
        (default): every measure the dataset records, which
        :func:`~vptoolkit.learn.train.train_model` fills in when the run
        starts (its record keeps None; the architecture names the heads).
    architecture : ModelConfig, optional
        Network configuration; None gives ``ModelConfig(head=...,
        point_features=DEFAULT_POINT_FEATURES)`` for the label method (each
        point carries the relative area of its face), and a mapping is read with
        :meth:`ModelConfig.from_dict` (its ``head`` defaults to the method's, its
        ``point_features`` to :data:`DEFAULT_POINT_FEATURES`).
        Kept as a :class:`ModelConfig` whose head fits ``labels`` and whose
        ``measures`` are ``measures`` when those are given.

    Raises
    ------
    InputError
        Naming the first invalid field.

    Examples
    --------
    >>> options = TrainOptions(epochs=300, val_split="val")
    >>> options.lr_step, options.val_split, options.architecture.head
    (20, 'validation', 'direction')
    >>> TrainOptions.from_dict(options.to_dict()) == options
    True
    """

    labels: str = DEFAULT_LABELS
    epochs: int = PAPER_EPOCHS
    batch_size: int = PAPER_BATCH_SIZE
    lr: float = PAPER_LR
    lr_decay: float = PAPER_LR_DECAY
    lr_step: int | None = None
    seed: int = SEED
    val_split: str = DEFAULT_VAL_SPLIT
    max_models: int | None = None
    categories: Sequence[str] | None = None
    n_points: int = N_NETWORK_POINTS
    n_fps: int = N_FPS_POINTS
    rotate: bool = True
    fps_pool: int = DEFAULT_FPS_POOL
    val_rotations: int = DEFAULT_VAL_ROTATIONS
    measures: Sequence[str] | str | None = None
    architecture: ModelConfig | None = None

    def __post_init__(self) -> None:
        from vptoolkit.learn.config import check_input_sizes
        from vptoolkit.learn.labels import check_label_method

        labels = check_label_method(self.labels)
        measures = _measures(self.measures)
        epochs = check_int(self.epochs, "epochs", minimum=1)
        n_points, n_fps = check_input_sizes(self.n_points, self.n_fps)
        values = {
            "labels": labels,
            "epochs": epochs,
            "batch_size": check_int(self.batch_size, "batch_size", minimum=2),
            "lr": check_float(self.lr, "lr", above=0.0, expected=_POSITIVE),
            "lr_decay": check_float(self.lr_decay, "lr_decay", above=0.0,
                                    expected=_POSITIVE),
            "lr_step": (scaled_lr_step(epochs) if self.lr_step is None
                        else check_int(self.lr_step, "lr_step", minimum=1)),
            "seed": check_int(self.seed, "seed", minimum=0),
            "val_split": _split(self.val_split),
            "max_models": (None if self.max_models is None
                           else check_int(self.max_models, "max_models", minimum=1)),
            "categories": _categories(self.categories),
            "n_points": n_points,
            "n_fps": n_fps,
            "rotate": check_bool(self.rotate, "rotate"),
            "fps_pool": check_int(self.fps_pool, "fps_pool", minimum=0),
            "val_rotations": check_int(self.val_rotations, "val_rotations", minimum=0),
            "measures": measures,
            "architecture": _architecture(self.architecture, labels, measures),
        }
        for name, value in values.items():  # frozen: the checked values replace the given ones
            object.__setattr__(self, name, value)

    @property
    def decay_step(self) -> int:
        """Epochs per learning-rate step (``lr_step``, never None once made)."""
        assert self.lr_step is not None
        return self.lr_step

    @property
    def model_config(self) -> ModelConfig:
        """The network's configuration (``architecture``, never None once made)."""
        assert self.architecture is not None
        return self.architecture

    def to_dict(self) -> dict[str, Any]:
        """The options as JSON types: what a run records and :meth:`from_dict` reads."""
        values = {item.name: getattr(self, item.name) for item in fields(self)}
        values["categories"] = None if self.categories is None else list(self.categories)
        values["measures"] = None if self.measures is None else list(self.measures)
        values["architecture"] = self.model_config.to_dict()
        return values

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> TrainOptions:
        """Rebuild options from :meth:`to_dict`'s output (missing keys take their defaults).

        Raises
        ------
        InputError
            On unknown keys or invalid values, naming the key.
        """
        return cls(**check_keys(values, [item.name for item in fields(cls)],
                                "training options", missing_ok=True))

    def resume_conflicts(self, recorded: TrainOptions) -> dict[str, tuple[Any, Any]]:
        """The options a run resumed with these would change: name to (recorded, these).

        Every option but ``epochs``, which may grow, must be the recorded one;
        so must ``lr_step`` unless both are the default of their ``epochs``
        (a default step grows with the run). A differing architecture is
        named by its field, e.g. ``architecture.head_channels``; differing
        measures as ``measures`` alone. Options whose ``measures`` is None
        stand for their architecture's.
        """
        conflicts = changed_values(_named(recorded).to_dict(), _named(self).to_dict())
        if "measures" in conflicts:  # the architecture's heads follow them
            conflicts.pop("architecture.measures", None)
        conflicts.pop("epochs", None)
        if _default_step(self) and _default_step(recorded):
            conflicts.pop("lr_step", None)
        return conflicts


def _named(options: TrainOptions) -> TrainOptions:
    """``options`` with ``measures`` filled in from their architecture where None."""
    if options.measures is not None:
        return options
    return replace(options, measures=options.model_config.measures)


def _default_step(options: TrainOptions) -> bool:
    """Whether ``options.lr_step`` is the default, :func:`scaled_lr_step` of its ``epochs``."""
    return options.lr_step == scaled_lr_step(options.epochs)


def _split(name: Any) -> str:
    split = published_split(name) if isinstance(name, str) else name
    if split not in SPLITS:
        raise InputError(f"val_split: unknown split {short_repr(name)}, expected one of "
                         f"{[*SPLITS, 'val']}")
    return str(split)


def _categories(categories: Any) -> tuple[str, ...] | None:
    if categories is None:
        return None
    if isinstance(categories, str):
        categories = [categories]
    if not isinstance(categories, (list, tuple, set, frozenset)) or not all(
            isinstance(name, str) for name in categories):
        raise InputError(f"categories: expected category names, got {short_repr(categories)}")
    if not categories:
        raise InputError("categories: none given (None trains on every category)")
    return tuple(sorted(set(categories)))


def _measures(measures: Any) -> tuple[str, ...] | None:
    from vptoolkit.learn.config import check_measure_names

    return None if measures is None else check_measure_names(measures, text=True,
                                                             predicted=True)


def _architecture(architecture: Any, labels: str,
                  measures: tuple[str, ...] | None) -> ModelConfig:
    from vptoolkit.learn.config import ModelConfig
    from vptoolkit.learn.labels import head_for_method

    head = head_for_method(labels)
    if architecture is None:
        config = ModelConfig(head=head, point_features=DEFAULT_POINT_FEATURES)
        return config if measures is None else replace(config, measures=measures)
    if isinstance(architecture, ModelConfig):
        config = architecture
    elif isinstance(architecture, Mapping):
        config = ModelConfig.from_dict({"head": head, "point_features": DEFAULT_POINT_FEATURES,
                                        **architecture})
    else:
        raise InputError(f"architecture: expected a ModelConfig or a mapping, got "
                         f"{short_repr(architecture)}")
    if config.head != head:
        raise InputError(f"architecture: head {config.head!r} does not fit labels {labels!r} "
                         f"(needs {head!r})")
    if measures is not None and config.measures != measures:
        config = replace(config, measures=measures)
    return config
