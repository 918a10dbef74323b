"""Predict best viewpoints with a trained network.

:func:`predict` takes mesh files, point files or a dataset split and returns
:class:`Predictions`: one unit direction per model and measure, pointing from
the model's bounding-box centre towards the camera, in the input's own
coordinates.

Inputs become network inputs the way the training data did (Schelling et
al. 2021, section 5.1):

mesh files (``.off``, ``.obj``, ``.ply``, ``.stl``, ``.glb``, ``.gltf``)
    :func:`vptoolkit.io.load_mesh`, then 20000 surface points by
    :func:`vptoolkit.points.sample_surface` (seed ``seed``);
point files (``.npy``)
    an ``(N, 3)`` or ``(N, 6)`` float array, ``x y z`` first (as ``vptool
    sample`` writes);
dataset stores or folders
    the stored surface points of every model of ``split``.

Then :func:`vptoolkit.points.network_input` picks the checkpoint's input
size (4096 points, 1024 of them by farthest point sampling) with a
generator seeded from ``seed`` and the model's name, so a model gets the
same input wherever it appears. Nothing is rotated.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.conventions import MEASURES
from vptoolkit.errors import InputError
from vptoolkit.files import atomic_write
from vptoolkit.learn.model import DEFAULT_MODEL, ViewpointNet, load_model, torch_threads
from vptoolkit.mesh import Mesh
from vptoolkit.optional import require

if TYPE_CHECKING:
    import torch

    from vptoolkit.data import ViewpointDataset
else:
    torch = require("torch", extra="learn")

__all__ = ["MeshPredictor", "Predictions", "predict", "predict_directions", "network_points"]

_SURFACE_POINTS = 20_000
_SEED_INPUT = 3


@dataclass(frozen=True)
class Predictions:
    """Predicted view directions of several models.

    Attributes
    ----------
    names : tuple of str
        Model names (file stems, or dataset names), unique.
    directions : (n_models, n_measures, 3) float64
        Unit directions from the bounding-box centre towards the camera.
    measures : tuple of str
        The measure of each direction, in ``MEASURES`` order.
    """

    names: tuple[str, ...]
    directions: NDArray[np.float64]
    measures: tuple[str, ...] = MEASURES

    def __post_init__(self) -> None:
        directions = np.asarray(self.directions, dtype=np.float64)
        if directions.shape != (len(self.names), len(self.measures), 3):
            raise InputError(
                f"directions: expected shape ({len(self.names)}, {len(self.measures)}, 3), got {directions.shape}"
            )
        if len(set(self.names)) != len(self.names):
            raise InputError("names: model names must be unique")
        object.__setattr__(self, "names", tuple(str(name) for name in self.names))
        object.__setattr__(self, "measures", tuple(str(name) for name in self.measures))
        object.__setattr__(self, "directions", directions)

    def __len__(self) -> int:
        return len(self.names)

    def save_npz(self, path: str | os.PathLike[str]) -> Path:
        """Write ``names``, ``directions`` and ``measures`` to an ``.npz`` file, atomically.

        The arrays are ``names (n_models,) unicode``, ``directions
        (n_models, n_measures, 3) float64`` and ``measures (n_measures,)
        unicode``; nothing is pickled (read back with ``np.load(path,
        allow_pickle=False)`` or :meth:`load_npz`).

        Returns
        -------
        path : Path
            The written file.

        Raises
        ------
        InputError
            If ``path`` does not end in ``.npz`` or its folder does not exist.
        """
        path = Path(path)
        if path.suffix.lower() != ".npz":
            raise InputError(f"{path.name}: predictions must be saved as .npz")
        if not path.parent.is_dir():
            raise InputError(f"{path}: folder {path.parent} does not exist")
        with atomic_write(path) as handle:
            np.savez(
                handle,
                names=np.array(self.names, dtype=str) if self.names else np.zeros(0, dtype="<U1"),
                directions=self.directions,
                measures=np.array(self.measures, dtype=str),
            )
        return path

    @classmethod
    def load_npz(cls, path: str | os.PathLike[str]) -> Predictions:
        """Read predictions written by :meth:`save_npz` (``allow_pickle=False``).

        Raises
        ------
        InputError
            If the file is missing, unreadable or lacks an array.
        """
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as archive:
                names = [str(name) for name in archive["names"]]
                directions = np.asarray(archive["directions"], dtype=np.float64)
                measures = [str(name) for name in archive["measures"]]
        except (OSError, ValueError, KeyError) as err:
            raise InputError(f"{path.name}: cannot read predictions ({err})") from err
        return cls(tuple(names), directions, tuple(measures))


def network_points(points: NDArray[np.floating[Any]], *, n_points: int, n_fps: int,
                   seed: int, name: str) -> NDArray[np.float32]:
    """One network input from a sampled surface, seeded from ``seed`` and ``name``.

    Parameters
    ----------
    points : (n, 3) float
        Surface points.
    n_points, n_fps : int
        Input size and its farthest-point part (``n_fps`` is capped at ``n``).
    seed : int
        Base seed.
    name : str
        Model name; the generator is ``SeedSequence([seed, 3, model_key(name)])``.

    Returns
    -------
    input_points : (n_points, 3) float32
    """
    from vptoolkit.data.torch import model_key
    from vptoolkit.points import network_input

    rng = np.random.default_rng(np.random.SeedSequence([int(seed), _SEED_INPUT, model_key(name)]))
    chosen = network_input(points, n_points, min(n_fps, len(points)), rng=rng)
    return chosen.astype(np.float32)


def predict_directions(model: ViewpointNet, points: NDArray[np.floating[Any]] | torch.Tensor, *,
                       batch_size: int = 64) -> NDArray[np.float64]:
    """Run a network in evaluation mode on prepared inputs.

    Parameters
    ----------
    model : ViewpointNet
        The network (switched to evaluation mode).
    points : (n_models, n_points, 3) float
        Network inputs.
    batch_size : int
        Models per forward pass (default: 64).

    Returns
    -------
    directions : (n_models, n_measures, 3) float64
        Unit directions.
    """
    if isinstance(batch_size, bool) or not isinstance(batch_size, int) or batch_size < 1:
        raise InputError(f"batch_size: expected a positive integer, got {batch_size!r}")
    inputs = torch.as_tensor(np.asarray(points, dtype=np.float32) if not isinstance(points, torch.Tensor)
                             else points.to(torch.float32))
    if inputs.ndim != 3 or inputs.shape[-1] != 3:
        raise InputError(f"points: expected shape (n_models, n_points, 3), got {tuple(inputs.shape)}")
    model.eval()
    parts = []
    with torch.inference_mode():
        for start in range(0, len(inputs), batch_size):
            parts.append(model(inputs[start : start + batch_size])["directions"].to(torch.float64))
    if not parts:
        return np.zeros((0, model.config.n_measures, 3))
    directions = torch.cat(parts).numpy()
    return directions / np.linalg.norm(directions, axis=-1, keepdims=True)


def _is_dataset(path: Path) -> bool:
    from vptoolkit.dataset.store import store_kind

    if path.is_dir():
        return True
    try:
        store_kind(path)
    except InputError:
        return False
    return True


def _point_file(path: Path) -> NDArray[np.float64]:
    try:
        table = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as err:
        raise InputError(f"{path.name}: cannot read a numpy array ({err})") from err
    if table.ndim != 2 or table.shape[1] not in (3, 6) or table.shape[0] < 1:
        raise InputError(f"{path.name}: expected an (N, 3) or (N, 6) point array, got shape {table.shape}")
    if not np.issubdtype(table.dtype, np.floating):
        raise InputError(f"{path.name}: expected float columns, got {table.dtype}")
    points = np.asarray(table[:, :3], dtype=np.float64)
    if not np.isfinite(points).all():
        raise InputError(f"{path.name}: contains NaN or infinite coordinates")
    return points


def _mesh_points(path: Path, seed: int) -> NDArray[np.float64]:
    from vptoolkit.io import load_mesh
    from vptoolkit.points import sample_surface

    return sample_surface(load_mesh(path), _SURFACE_POINTS, seed=seed).points


def _sources(inputs: Any, split: str | None, seed: int) -> Iterator[tuple[str, Callable[[], NDArray[Any]]]]:
    """(name, loader of surface points) for every model of the inputs, in order."""
    from vptoolkit.data import ViewpointDataset, open_dataset
    from vptoolkit.io import SUPPORTED_SUFFIXES

    if isinstance(inputs, (str, os.PathLike, ViewpointDataset)):
        inputs = [inputs]
    for source in inputs:
        if isinstance(source, ViewpointDataset):
            yield from _dataset_sources(source, split)
            continue
        if not isinstance(source, (str, os.PathLike)):
            raise InputError(f"inputs: expected paths or a ViewpointDataset, got {type(source).__name__}")
        path = Path(source)
        suffix = path.suffix.lower()
        if suffix == ".npy":
            if not path.is_file():
                raise InputError(f"{path}: no such point file")
            yield path.stem, (lambda path=path: _point_file(path))
        elif suffix in SUPPORTED_SUFFIXES:
            if not path.is_file():
                raise InputError(f"{path}: no such mesh file")
            yield path.stem, (lambda path=path: _mesh_points(path, seed))
        elif _is_dataset(path):
            dataset = open_dataset(path)
            try:
                yield from _dataset_sources(dataset, split)
            finally:
                dataset.close()
        else:
            raise InputError(
                f"{path.name}: not a mesh ({', '.join(SUPPORTED_SUFFIXES)}), point file (.npy) or dataset"
            )


def _dataset_sources(dataset: ViewpointDataset, split: str | None) -> Iterator[tuple[str, Callable[[], NDArray[Any]]]]:
    subset = dataset.split(split) if split is not None else dataset
    for position, name in enumerate(subset.names):
        yield name, (lambda position=position: np.asarray(subset[position]["points"], dtype=np.float64))


def _input_sizes(config: dict[str, Any], n_points: int | None, n_fps: int | None) -> tuple[int, int]:
    """Input size and farthest-point part: the given values, else the checkpoint's training values."""
    trained = config.get("input", {})
    n_points = int(trained.get("n_points", 4096)) if n_points is None else n_points
    n_fps = int(trained.get("n_fps", 1024)) if n_fps is None else n_fps
    for value, what in ((n_points, "n_points"), (n_fps, "n_fps")):
        if isinstance(value, bool) or not isinstance(value, int) or value < (1 if what == "n_points" else 0):
            raise InputError(f"{what}: expected a {'positive' if what == 'n_points' else 'non-negative'} integer, "
                             f"got {value!r}")
    if n_fps > n_points:
        raise InputError(f"n_fps: {n_fps} exceeds n_points={n_points}")
    return n_points, n_fps


class MeshPredictor:
    """A checkpoint loaded once, called on meshes: ``predictor(mesh) -> (n_measures, 3)``.

    The hook behind ``vptool render --model`` and ``vptool thumbnails
    --model`` (a :data:`vptoolkit.render.DirectionSource`). A mesh becomes
    a network input as in :func:`predict`: 20000 surface points (seed
    ``seed``), then the checkpoint's input size chosen with a generator
    seeded from ``seed`` and the mesh's name.

    Parameters
    ----------
    model_path : path-like
        A checkpoint, or ``"default"`` for the bundled pretrained one.
    seed : int
        Seed of the sampling (default: 0).
    threads : int, optional
        Torch threads during each call (default: torch's setting).

    Examples
    --------
    >>> predictor = MeshPredictor("default")          # doctest: +SKIP
    >>> predictor(load_mesh("chair.off")).shape        # doctest: +SKIP
    (4, 3)
    """

    def __init__(self, model_path: str | os.PathLike[str] = DEFAULT_MODEL, *, seed: int = 0,
                 threads: int | None = None) -> None:
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise InputError(f"seed: expected a non-negative integer, got {seed!r}")
        self.model, self.config = load_model(model_path)
        self.n_points, self.n_fps = _input_sizes(self.config, None, None)
        self.measures = tuple(self.config.get("measures", MEASURES[: self.model.config.n_measures]))
        self.seed = seed
        self.threads = threads

    def __call__(self, mesh: Mesh) -> NDArray[np.float64]:
        """Unit directions, one per measure, from the mesh centre towards the camera."""
        from vptoolkit.points import sample_surface

        surface = sample_surface(mesh, _SURFACE_POINTS, seed=self.seed).points
        points = network_points(surface, n_points=self.n_points, n_fps=self.n_fps,
                                seed=self.seed, name=mesh.name)
        with torch_threads(self.threads):
            return predict_directions(self.model, points[None])[0]


def predict(
    model_path: str | os.PathLike[str],
    inputs: str | os.PathLike[str] | ViewpointDataset | Sequence[str | os.PathLike[str] | ViewpointDataset],
    *,
    split: str | None = "test",
    batch_size: int = 64,
    seed: int = 0,
    n_points: int | None = None,
    n_fps: int | None = None,
    progress: bool = False,
    threads: int | None = None,
) -> Predictions:
    """Predict the best view of every input model for each measure.

    Parameters
    ----------
    model_path : path-like
        A checkpoint (folder, ``*.safetensors`` or ``*.json``) written by
        :func:`vptoolkit.learn.train.train_model` or
        :func:`vptoolkit.learn.model.save_model`.
    inputs : path-like, ViewpointDataset or a sequence of them
        Mesh files, ``.npy`` point files and dataset stores or folders, in
        any mix (see the module docstring).
    split : str, optional
        Split of dataset inputs: ``"train"``, ``"val"``, ``"test"`` or None
        for every model (default: "test").
    batch_size : int
        Models per forward pass (default: 64).
    seed : int
        Seed of the surface sampling of meshes and of the input point
        selection (default: 0).
    n_points, n_fps : int, optional
        Input size and its farthest-point part (default: the checkpoint's
        training values, else 4096 and 1024).
    progress : bool
        Show a progress bar while preparing inputs (default: False).
    threads : int, optional
        Torch threads during the call, restored afterwards (default: None,
        leave torch's setting).

    Returns
    -------
    Predictions
        In input order; names are file stems or dataset model names.

    Raises
    ------
    InputError
        On a missing or unreadable input, an unknown file type, an unknown
        split, duplicate model names or an invalid option.
    VerificationError
        If the checkpoint's weights do not match its architecture.
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed: expected a non-negative integer, got {seed!r}")
    model, config = load_model(model_path)
    n_points, n_fps = _input_sizes(config, n_points, n_fps)
    tqdm = require("tqdm").tqdm
    names: list[str] = []
    prepared: list[NDArray[np.float32]] = []
    for name, load in tqdm(_sources(inputs, split, seed), disable=not progress, desc="inputs", unit="model"):
        if name in names:
            raise InputError(f"inputs: two models are named {name!r}; model names must be unique")
        names.append(name)
        prepared.append(network_points(load(), n_points=n_points, n_fps=n_fps, seed=seed, name=name))
    points = np.stack(prepared) if prepared else np.zeros((0, n_points, 3), dtype=np.float32)
    with torch_threads(threads):
        directions = predict_directions(model, points, batch_size=batch_size)
    measures = tuple(config.get("measures", MEASURES[: model.config.n_measures]))
    return Predictions(tuple(names), directions, measures)
