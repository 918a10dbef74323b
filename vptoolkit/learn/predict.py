"""Predict best viewpoints with a trained network.

:func:`predict` takes mesh files, point files or a dataset split (told apart
by :func:`vptoolkit.inputs.open_inputs`) and returns
:class:`~vptoolkit.predictions.Predictions`: one unit direction per model and measure, pointing from
the model's bounding-box centre towards the camera, in the input's own
coordinates.

Inputs become network inputs the way the training data did (Schelling et
al. 2021, section 5.1):

mesh files (``.off``, ``.obj``, ``.ply``, ``.stl``, ``.glb``, ``.gltf``)
    read by :func:`vptoolkit.io.load`, then 20000 surface points by
    :func:`vptoolkit.points.sample_surface` (seed ``seed``);
point cloud files (a PLY, OBJ or OFF without faces, and the points-only
formats of :data:`vptoolkit.io.POINT_SUFFIXES`: NPY, NPZ, XYZ, PCD, LAS, ...)
    their points as they are, e.g. an ``(N, 3)`` or ``(N, 6)`` ``.npy``
    array as ``vptool sample`` writes;
dataset stores or folders
    the stored surface points of every model of ``split``.

Then :func:`vptoolkit.learn.draws.network_indices` picks ``n_inputs`` inputs of the
checkpoint's input size (4096 points, 1024 of them by farthest point
sampling, one such subset per model) with generators seeded from ``seed``
and the points' content (:func:`vptoolkit.learn.draws.content_order`), never their name, file or
order, so the same points get the same inputs wherever they appear, and a
turned copy the same inputs turned. The network answers all of a model's
inputs in one batch (and those of several models, ``batch_size``), and the
answer per measure is their consensus (:func:`vptoolkit.learn.consensus.consensus_directions`:
the answer most of the others agree with), which does not move with the
sampling as a single input's answer does. ``n_inputs=1`` asks the network
once (:data:`N_INPUTS` = 16 by default). Nothing is rotated: networks with
the canonical input frame (:mod:`vptoolkit.learn.frame`) answer in the
input's own orientation, whatever it is.

The predictions name the network's measures (its heads, as its
``model.json`` lists them), in its order.

Per-category networks (:func:`vptoolkit.learn.train.train_per_category`, a
folder with ``categories.json``) route every dataset model to its category's
network; meshes and point files need ``category``; they must all predict the
same measures.

A network that reads point features (``ModelConfig.point_features``, such as
the bundled ``default``) gets the face features from the faces the points were
sampled on for meshes, from the stored mesh for datasets
(:meth:`vptoolkit.data.ViewpointDataset.point_features`), and the cloud
features (:data:`vptoolkit.point_features.CLOUD_FEATURES`) from the points
the inputs are drawn from. A point file carries the cloud features (and
``normal`` where it has normals); a network that reads a face feature
refuses it.

Size
    About 630 lines for one concept, a loaded network answering models: the
    three ways in (:func:`predict`, :func:`network_predictor`,
    :class:`MeshPredictor`) share the routing, the surfaces and point
    features each kind of model gives, and the refusals; the draws
    (:mod:`vptoolkit.learn.draws`) and the consensus are their own modules.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import short_repr
from vptoolkit.conventions import Split
from vptoolkit.errors import ArgumentError, InputError
from vptoolkit.files import is_inside_folder
from vptoolkit.learn.checkpoint import CLOUD_MODELS, DEFAULT_MODEL, is_bundled_model
from vptoolkit.learn.config import check_input_sizes
from vptoolkit.learn.consensus import consensus_directions
from vptoolkit.learn.draws import (
    N_INPUTS,
    check_n_inputs,
    network_inputs,
)
from vptoolkit.learn.model import ViewpointNet, load_model, resolve_device, torch_threads
from vptoolkit.mesh import Mesh, MeshLike, as_mesh
from vptoolkit.optional import require
from vptoolkit.point_cloud import MAX_POINTS, PointCloud
from vptoolkit.point_features import FEATURE_WIDTHS, turn_features
from vptoolkit.points import N_FPS_POINTS, N_NETWORK_POINTS, N_SURFACE_POINTS
from vptoolkit.predictions import Predictions

if TYPE_CHECKING:
    import torch

    from vptoolkit.data import ViewpointDataset
    from vptoolkit.inputs import ModelSource
else:
    torch = require("torch", extra="learn")

__all__ = ["MeshPredictor", "predict", "predict_directions", "mesh_surface", "cloud_surface",
           "network_predictor", "load_networks"]

CATEGORY_MODELS_FORMAT: Final = "vptoolkit-category-models"
"""``format`` entry of the ``categories.json`` index of per-category networks
(:func:`vptoolkit.learn.train.train_per_category`)."""

_MODELS_HELD = 256  # models whose inputs predict() holds before it runs the network


def predict_directions(model: ViewpointNet, points: NDArray[np.floating[Any]] | torch.Tensor, *,
                       batch_size: int = 64, device: str = "cpu",
                       checkpoint: str = "network") -> NDArray[np.float64]:
    """Run a network in evaluation mode on prepared inputs.

    Parameters
    ----------
    model : ViewpointNet
        The network (switched to evaluation mode).
    points : (n_models, n_points, 3) float
        Network inputs.
    batch_size : int
        Network inputs per forward pass (default: 64; 4 models at the default ``n_inputs``).
    device : {"cpu", "cuda", "auto"}
        Where the network runs (default: "cpu"; the model is moved there).
    checkpoint : str
        The network's checkpoint, named in errors (default: "network").

    Returns
    -------
    directions : (n_models, n_measures, 3) float64
        Unit directions.

    Raises
    ------
    InputError
        If the network answers a zero or non-finite vector for some input:
        its weights are broken (all zero, NaN, overflowing), never a direction.
    """

    if isinstance(batch_size, bool) or not isinstance(batch_size, int) or batch_size < 1:
        raise InputError(f"batch_size: expected a positive integer, got {batch_size!r}")
    inputs = torch.as_tensor(np.asarray(points, dtype=np.float32)
                             if not isinstance(points, torch.Tensor)
                             else points.to(torch.float32))
    channels = model.config.input_channels
    if inputs.ndim != 3 or inputs.shape[-1] != channels:
        raise InputError(f"points: expected shape (n_models, n_points, {channels}), "
                         f"got {tuple(inputs.shape)}")
    where = resolve_device(device)
    model.to(where).eval()
    parts = []
    with torch.inference_mode():
        for start in range(0, len(inputs), batch_size):
            outputs = model(inputs[start : start + batch_size].to(where))
            parts.append(outputs["directions"].to(torch.float64).cpu())
    if not parts:
        return np.zeros((0, len(model.measures), 3))
    directions = torch.cat(parts).numpy()
    lengths = np.linalg.norm(directions, axis=-1, keepdims=True)
    is_bad = ~(np.isfinite(lengths) & (lengths > 0.0)).all(axis=(1, 2))
    if is_bad.any():
        raise InputError(
            f"{checkpoint}: the network answers a zero or non-finite vector "
            f"for {int(is_bad.sum())} "
            f"of {len(directions)} inputs, not a direction; its weights are broken"
        )
    return directions / lengths


def load_networks(
    model_path: str | os.PathLike[str],
) -> dict[str | None, tuple[ViewpointNet, dict[str, Any]]]:
    """One checkpoint as ``{None: (model, config)}``; a per-category folder as ``{category: ...}``.

    Raises
    ------
    InputError
        If a checkpoint is missing or unreadable, ``categories.json`` is not a
        per-category index, or its networks predict different measures.
    """
    from vptoolkit.learn.checkpoint import read_json

    index = Path(model_path) / "categories.json"
    if is_bundled_model(model_path) or not index.is_file():
        return {None: load_model(model_path)}
    entries = read_json(index, "per-category index")
    if (entries.get("format") != CATEGORY_MODELS_FORMAT
            or not isinstance(entries.get("categories"), dict)):
        raise InputError(f"{index}: not a vptoolkit per-category index "
                         f"(format {entries.get('format')!r})")
    for name, folder in entries["categories"].items():
        if not isinstance(folder, str) or not is_inside_folder(folder):
            raise InputError(f"{index}: category {short_repr(name)} names {short_repr(folder)}, "
                             "not a folder inside the model folder")
    networks: dict[str | None, tuple[ViewpointNet, dict[str, Any]]] = {
        str(name): load_model(Path(model_path) / folder)
        for name, folder in sorted(entries["categories"].items())}
    heads = {name: model.measures for name, (model, _) in networks.items()}
    if len(set(heads.values())) > 1:
        listed = "; ".join(f"{name}: {', '.join(measures)}" for name, measures in heads.items())
        raise InputError(f"{index}: its networks predict different measures ({listed})")
    return networks


def _route(networks: dict[str | None, tuple[ViewpointNet, dict[str, Any]]], name: str,
           category: str | None) -> str | None:
    """The key of the network that predicts one model."""
    if None in networks:
        return None
    if category is None:
        raise ArgumentError(f"{name}: the model folder holds one network per category "
                            f"({', '.join(map(str, networks))}); "
                            "pass {argument} for meshes and point files", "category=")
    if category not in networks:
        raise InputError(f"{name}: no network for category {category!r} "
                         f"(have {', '.join(map(str, networks))})")
    return category


def _input_sizes(config: dict[str, Any], n_points: int | None,
                 n_fps: int | None) -> tuple[int, int]:
    """Input size and farthest-point part: as given, else the checkpoint's training values."""
    trained = config.get("input", {})
    n_points = trained.get("n_points", N_NETWORK_POINTS) if n_points is None else n_points
    n_fps = trained.get("n_fps", N_FPS_POINTS) if n_fps is None else n_fps
    return check_input_sizes(n_points, n_fps)


def network_predictor(
    model_path: str | os.PathLike[str], *, categories: Mapping[str, str] | None = None,
    seed: int = 0, batch_size: int = 64, device: str = "auto", n_inputs: int = N_INPUTS,
    dataset: ViewpointDataset | None = None,
) -> Callable[[Sequence[NDArray[Any]], Sequence[str]], NDArray[np.float64]]:
    """A checkpoint as a :data:`vptoolkit.evaluate.protocol.Predictor`.

    It turns surface points and names into directions.

    Each cloud becomes ``n_inputs`` network inputs as in :func:`predict` (the
    checkpoint's input size, seeded from ``seed`` and the points' content,
    :func:`vptoolkit.learn.draws.network_indices`), and the answer is their
    consensus. A network that reads the cloud features alone
    (:data:`vptoolkit.point_features.CLOUD_FEATURES`) computes them from each
    cloud given. One that reads face features
    (``ModelConfig.point_features``) takes them from ``dataset``: the clouds
    must be its models' stored points, in stored order, turned about the
    origin or not, as :func:`vptoolkit.evaluate.protocol.score_protocol`
    gives them. Vector features (``"normal"``) are turned as each cloud is,
    the turn found from the stored points by least squares.

    Parameters
    ----------
    model_path : path-like
        A checkpoint, a per-category folder or ``"default"``.
    categories : mapping of str to str, optional
        Model name to category, to route models to a per-category folder's networks.
    seed, batch_size, device, n_inputs
        As for :func:`predict`.
    dataset : ViewpointDataset, optional
        The models the clouds come from, for the point features of a network
        that reads them (:meth:`vptoolkit.data.ViewpointDataset.point_features`).

    Returns
    -------
    predictor : callable
        ``predictor(points, names) -> (n_models, n_measures, 3)`` unit directions.
    """
    n_inputs = check_n_inputs(n_inputs)
    networks = load_networks(model_path)
    lookup = dict(categories or {})
    from vptoolkit.point_features import CLOUD_FEATURES
    from vptoolkit.point_features import point_features as cloud_features_of

    reads = [name for name in _features_read(networks) if name not in CLOUD_FEATURES]
    if reads and dataset is None:
        raise InputError(f"{model_path}: the network reads point features ({', '.join(reads)}); "
                         "pass the dataset the points come from")
    # per model and features: the stored features, and the stored points where a vector turns
    cached: dict[tuple[str, tuple[str, ...]],
                 tuple[NDArray[np.float32], NDArray[Any] | None]] = {}

    def features_of(cloud: NDArray[Any], name: str,
                    wanted: tuple[str, ...]) -> NDArray[np.float32] | None:
        if not wanted:
            return None
        if set(wanted) <= set(CLOUD_FEATURES):  # from the points given, as for a point file
            return cloud_features_of(cloud, wanted)
        assert dataset is not None
        if (name, wanted) not in cached:
            turns = any(FEATURE_WIDTHS[feature] > 1 for feature in wanted)
            cached[name, wanted] = (dataset.point_features(name, wanted),
                                    dataset[name]["points"] if turns else None)
        stored, points = cached[name, wanted]
        if points is None:  # numbers alone: nothing turns
            return stored
        return turn_features(stored, wanted, stored_turn(points, cloud, name))

    def predictor(points: Sequence[NDArray[Any]], names: Sequence[str]) -> NDArray[np.float64]:
        routes = [_route(networks, name, lookup.get(name)) for name in names]
        features = [features_of(cloud, name, networks[route][0].config.point_features)
                    for cloud, name, route in zip(points, names, routes)]

        def inputs_of(position: int) -> NDArray[np.float32]:
            n_points, n_fps = _input_sizes(networks[routes[position]][1], None, None)
            return network_inputs(points[position], n_points=n_points, n_fps=n_fps, seed=seed,
                                  name=names[position], n_inputs=n_inputs,
                                  features=features[position])

        prepared = _map_threads(inputs_of, len(points))
        return _predict_routed(networks, prepared, routes, batch_size=batch_size, device=device,
                               model_path=model_path)

    return predictor


def _map_threads(function: Callable[[int], NDArray[np.float32]],
                 count: int) -> list[NDArray[np.float32]]:
    """``[function(0), ..., function(count - 1)]``, on as many threads as torch uses.

    For the input draws of several models: each is a rule of its own points
    (:func:`vptoolkit.learn.draws.network_indices`), so the answers are the
    same on any number of threads, and numpy releases the GIL in their
    farthest point sampling, which is most of their time.
    """
    workers = min(count, torch.get_num_threads())
    if workers <= 1:
        return [function(position) for position in range(count)]
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(function, range(count)))


def stored_turn(stored: NDArray[Any], cloud: NDArray[Any], name: str) -> NDArray[np.float64]:
    """The turn ``T`` with ``cloud = stored @ T``: how a model's stored points were turned.

    Least squares over the points, checked to reproduce ``cloud`` within
    1e-4 of its extent (float32 rounding passes, other points do not).

    Raises
    ------
    InputError
        If ``cloud`` is not ``stored`` turned about the origin.
    """
    source = np.asarray(stored, dtype=np.float64)
    target = np.asarray(cloud, dtype=np.float64)
    if source.shape != target.shape:
        raise InputError(f"{name}: expected the dataset's {len(source)} stored points, turned "
                         f"or not, got shape {target.shape}")
    turn = np.asarray(np.linalg.lstsq(source, target, rcond=None)[0], dtype=np.float64)
    extent = max(float(np.abs(target).max(initial=0.0)), 1e-12)
    if not np.abs(source @ turn - target).max(initial=0.0) <= 1e-4 * extent:
        raise InputError(f"{name}: the points are not the dataset's stored points turned about "
                         "the origin, so their point normals cannot be turned with them")
    return turn


def _checkpoint_name(model_path: str | os.PathLike[str], route: str | None) -> str:
    """The checkpoint of one network, for messages: the path, with the category's folder if any."""
    return str(model_path) if route is None else f"{model_path} (category {route})"


def _predict_routed(networks: dict[str | None, tuple[ViewpointNet, dict[str, Any]]],
                    prepared: Sequence[NDArray[np.float32]], routes: Sequence[str | None], *,
                    batch_size: int, device: str,
                    model_path: str | os.PathLike[str]) -> NDArray[np.float64]:
    """Each model's inputs ``(K, n_points, 3)`` through the network its route names.

    Returns the consensus of each model's ``K`` answers, ``(n_models, n_measures, 3)``.
    """
    first_model = next(iter(networks.values()))[0]
    n_inputs = len(prepared[0]) if prepared else 1
    answers = np.zeros((len(prepared), n_inputs, len(first_model.measures), 3))
    for route, (model, _) in networks.items():
        rows = [i for i, chosen in enumerate(routes) if chosen == route]
        if rows:
            stacked = np.concatenate([prepared[i] for i in rows])
            found = predict_directions(model, stacked, batch_size=batch_size, device=device,
                                       checkpoint=_checkpoint_name(model_path, route))
            answers[rows] = found.reshape(len(rows), n_inputs, *found.shape[1:])
    return consensus_directions(answers)


def mesh_surface(mesh: MeshLike, point_features: Sequence[str], *,
                 seed: int) -> tuple[NDArray[np.float64], NDArray[np.float32] | None]:
    """A mesh's 20000 surface points (:func:`vptoolkit.points.sample_surface`, ``seed``), and
    their ``point_features`` (None for no features): face features from the faces they were
    sampled on, cloud features from the points."""
    from vptoolkit.point_features import point_features as features_of
    from vptoolkit.points import sample_surface

    mesh = as_mesh(mesh)
    sample = sample_surface(mesh, N_SURFACE_POINTS, seed=seed)
    features = (features_of(sample.points, point_features, mesh=mesh,
                            face_index=sample.face_index) if point_features else None)
    return sample.points, features


def _features_read(networks: dict[str | None, tuple[ViewpointNet, dict[str, Any]]]) -> list[str]:
    """The point features any of the networks reads, sorted."""
    return sorted({name for model, _ in networks.values() for name in model.config.point_features})


def _features_refused(where: str, point_features: Sequence[str]) -> InputError:
    """The one message for a point cloud given to a network that reads point features it
    does not carry (a cloud carries the cloud features, and ``normal`` where it has normals)."""
    from vptoolkit.point_features import CLOUD_FEATURES

    missing = sorted(set(point_features) - set(CLOUD_FEATURES))
    carried = ("a point cloud without normals does not carry" if missing == ["normal"]
               else "a point cloud does not carry")
    return InputError(f"{where}: the network reads point features "
                      f"({', '.join(missing)}) that {carried}; "
                      "give the mesh, or a network for point clouds (--model points)")


def _cloud_features(cloud: PointCloud, point_features: Sequence[str]) -> bool:
    """Whether a point cloud carries ``point_features``: the cloud features
    (:data:`vptoolkit.point_features.CLOUD_FEATURES`), and ``normal`` where it has normals."""
    from vptoolkit.point_features import CLOUD_FEATURES

    carried = set(CLOUD_FEATURES) | ({"normal"} if cloud.normals is not None else set())
    return set(point_features) <= carried


def cloud_surface(cloud: PointCloud, point_features: Sequence[str], *,
                  where: str | None = None) -> tuple[NDArray[np.float64],
                                                     NDArray[np.float32] | None]:
    """A point cloud's points as they are, and the ``point_features`` it carries (None for no
    features).

    A cloud carries the cloud features (computed from its points), and
    ``normal`` where it has normals (its own); a face feature is refused in
    one line naming ``where`` (default: the cloud's name).
    """
    from vptoolkit.point_features import point_features as features_of

    points = np.array(cloud.points, dtype=np.float64)
    if not point_features:
        return points, None
    if not _cloud_features(cloud, point_features):
        raise _features_refused(cloud.name if where is None else where, point_features)
    if "normal" not in point_features:
        return points, features_of(points, point_features)
    assert cloud.normals is not None  # unit length, checked by PointCloud
    return points, np.concatenate(
        [cloud.normals.astype(np.float32) if name == "normal" else features_of(points, [name])
         for name in point_features], axis=1)


def _source_surface(source: ModelSource, point_features: Sequence[str], *, seed: int,
                    model: Mesh | PointCloud | None = None,
                    ) -> tuple[NDArray[np.float64], NDArray[np.float32] | None]:
    """An input model's surface points and their ``point_features`` (None for no features;
    a point cloud carries ``normal`` alone, where it has normals; any other is refused,
    :func:`_features_refused`); ``model``: a file's model, read already."""
    if not point_features:
        return ((np.array(model.points, dtype=np.float64) if isinstance(model, PointCloud)
                 else source.points(seed=seed)), None)
    if source.kind == "file":
        model = source.model() if model is None else model
        if isinstance(model, PointCloud):
            return cloud_surface(model, point_features, where=source.origin)
        return mesh_surface(model, point_features, seed=seed)
    assert source.dataset is not None
    return source.points(seed=seed), source.dataset.point_features(source.position,
                                                                   point_features)


class MeshPredictor:
    """A checkpoint loaded once, called on a mesh or cloud: ``predictor(mesh) -> (n_measures, 3)``.

    The hook behind ``vptool render --model`` and ``vptool thumbnails
    --model`` (a :data:`vptoolkit.pictures.views.DirectionSource`). A mesh becomes
    network inputs as in :func:`predict`: 20000 surface points (seed
    ``seed``), then ``n_inputs`` inputs of the checkpoint's input size chosen
    with generators seeded from ``seed`` and the points' content
    (:func:`vptoolkit.learn.draws.network_indices`); the answer is the consensus of the network's
    answers to them, asked in one batch. A point cloud
    (:class:`~vptoolkit.point_cloud.PointCloud`) is drawn from as it is, with the point
    features it carries (:func:`cloud_surface`).

    Parameters
    ----------
    model_path : path-like
        A checkpoint, a per-category folder, or ``"default"`` for the bundled
        pretrained network.
    seed : int
        Seed of the sampling (default: 0).
    threads : int, optional
        Torch threads during each call (default: torch's setting).
    category : str, optional
        The category whose network predicts (required for a per-category folder).
    n_inputs : int
        Network inputs per mesh (default: :data:`N_INPUTS`).

    Attributes
    ----------
    measures : tuple of str
        The measure of each row of a call's answer (the network's heads).

    Examples
    --------
    >>> predictor = MeshPredictor("default")          # doctest: +SKIP
    >>> predictor(load_mesh("chair.off")).shape        # doctest: +SKIP
    (4, 3)
    >>> predictor.measures                              # doctest: +SKIP
    ('VE', 'VR', 'VKL', 'VMI')
    """

    def __init__(self, model_path: str | os.PathLike[str] = DEFAULT_MODEL, *, seed: int = 0,
                 threads: int | None = None, category: str | None = None,
                 n_inputs: int = N_INPUTS) -> None:
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise InputError(f"seed: expected a non-negative integer, got {seed!r}")
        self.n_inputs = check_n_inputs(n_inputs)
        networks = load_networks(model_path)
        route = _route(networks, Path(model_path).name, category)
        self.model, self.config = networks[route]
        self.checkpoint = _checkpoint_name(model_path, route)
        self.n_points, self.n_fps = _input_sizes(self.config, None, None)
        self.measures = self.model.measures
        self.seed = seed
        self.threads = threads

    def inputs(self, mesh: MeshLike | PointCloud) -> NDArray[np.float32]:
        """The network inputs of a mesh or a point cloud, ``(n_inputs, n_points, 3 + F) float32``.

        As the class docstring says, with the ``F`` point features the network
        reads (``model.config.point_features``) after the coordinates. A point
        cloud's own points are drawn from, with the features it carries
        (:func:`cloud_surface`: the cloud features, and ``normal`` where it
        has normals; a network that reads a face feature refuses it in one
        line).
        """
        if isinstance(mesh, PointCloud):
            name = mesh.name
            points, features = cloud_surface(mesh, self.model.config.point_features)
        else:
            mesh = as_mesh(mesh)  # once: a trimesh or Open3D mesh is converted here
            name = mesh.name
            points, features = mesh_surface(mesh, self.model.config.point_features,
                                            seed=self.seed)
        return network_inputs(points, n_points=self.n_points, n_fps=self.n_fps,
                              seed=self.seed, name=name, n_inputs=self.n_inputs,
                              features=features)

    def __call__(self, mesh: MeshLike | PointCloud) -> NDArray[np.float64]:
        """Unit directions, one per measure, from the mesh centre towards the camera."""
        points = self.inputs(mesh)
        with torch_threads(self.threads):
            answers = predict_directions(self.model, points, checkpoint=self.checkpoint)
        return consensus_directions(answers[None])[0]


def predict(
    model_path: str | os.PathLike[str],
    inputs: (str | os.PathLike[str] | ViewpointDataset
             | Sequence[str | os.PathLike[str] | ViewpointDataset]),
    *,
    split: Split = "test",
    batch_size: int = 64,
    seed: int = 0,
    n_points: int | None = None,
    n_fps: int | None = None,
    progress: bool = False,
    threads: int | None = None,
    category: str | None = None,
    device: str = "auto",
    n_inputs: int = N_INPUTS,
    max_points: int = MAX_POINTS,
) -> Predictions:
    """Predict the best view of every input model for each measure.

    Parameters
    ----------
    model_path : path-like
        A checkpoint (folder, ``*.safetensors`` or ``*.json``) written by
        :func:`vptoolkit.learn.train.train_model` or
        :func:`vptoolkit.learn.model.save_model`, a per-category folder of
        :func:`vptoolkit.learn.train.train_per_category`, or ``"default"``.
    inputs : path-like, ViewpointDataset or a sequence of them
        Mesh files, ``.npy`` point files and dataset stores or folders, in
        any mix (see the module docstring).
    split : str, optional
        Split of dataset inputs: ``"train"``, ``"validation"``, ``"test"`` or None
        for every model (default: "test").
    batch_size : int
        Network inputs per forward pass (default: 64; 4 models at the default ``n_inputs``).
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
    category : str, optional
        Category of mesh and point-file inputs, for a per-category folder
        (dataset models carry their own).
    device : {"auto", "cpu", "cuda"}
        Where the network runs (default: "auto", CUDA when available).
    n_inputs : int
        Network inputs per model, 1 to 64, whose answers' consensus is the
        prediction (default: :data:`N_INPUTS`; 1 asks the network once).
    max_points : int
        Most points a point cloud file keeps; a larger one is thinned on
        reading (:func:`vptoolkit.io.load`; default:
        :data:`~vptoolkit.point_cloud.MAX_POINTS`).

    Returns
    -------
    Predictions
        In input order; names are file stems or dataset model names;
        ``directions`` ``(n_models, M, 3)`` for the network's ``M`` measures,
        which ``measures`` names in head order.

    Raises
    ------
    InputError
        On a missing or unreadable input, an unknown file type, an unknown
        split, duplicate model names, a model whose category has no network,
        an invalid option, or a network that answers no direction (broken
        weights, :func:`predict_directions`).
    CheckpointError
        If the checkpoint's weights do not match its architecture.
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed: expected a non-negative integer, got {seed!r}")
    n_inputs = check_n_inputs(n_inputs)
    networks = load_networks(model_path)
    tqdm = require("tqdm").tqdm
    from vptoolkit.inputs import claim_name, open_inputs
    from vptoolkit.io import POINT_SUFFIXES

    names: list[str] = []
    seen: set[str] = set()
    routes: list[str | None] = []
    prepared: list[NDArray[np.float32]] = []
    found: list[NDArray[np.float64]] = []

    def answer_prepared() -> None:  # the inputs held so far, then let them go
        with torch_threads(threads):
            found.append(_predict_routed(networks, prepared, routes, batch_size=batch_size,
                                         device=device, model_path=model_path))
        prepared.clear()
        routes.clear()

    cloud_network = (CLOUD_MODELS.get(str(model_path))
                     if is_bundled_model(model_path) and None in networks else None)
    with open_inputs(inputs, split=split, max_points=max_points) as sources:
        wanted = _features_read(networks)
        for source in sources:  # refused before any work: a points-only file for features
            if (wanted and cloud_network is None and source.kind == "file"
                    and Path(source.origin).suffix.lower() in POINT_SUFFIXES):
                model = source.model()
                if isinstance(model, PointCloud) and not _cloud_features(model, wanted):
                    raise _features_refused(source.origin, wanted)
        for source in tqdm(sources, disable=not progress, desc="inputs", unit="model"):
            claim_name(seen, source.name)
            route = _route(networks, source.name,
                           source.category if source.category is not None else category)
            read = (source.model() if cloud_network is not None and source.kind == "file"
                    else None)
            if (cloud_network is not None and isinstance(read, PointCloud)
                    and not _cloud_features(read, wanted)):
                route = cloud_network  # the bundled network of what the cloud carries
                if route not in networks:
                    networks[route] = load_model(route)
            size, fps = _input_sizes(networks[route][1], n_points, n_fps)
            points, features = _source_surface(source, networks[route][0].config.point_features,
                                               seed=seed, model=read)
            names.append(source.name)
            routes.append(route)
            prepared.append(network_inputs(points, n_points=size, n_fps=fps, seed=seed,
                                           name=source.name, n_inputs=n_inputs,
                                           features=features))
            if len(prepared) == _MODELS_HELD:
                answer_prepared()
    if prepared or not found:
        answer_prepared()
    measures = next(iter(networks.values()))[0].measures
    directions = np.concatenate(found)
    return Predictions(tuple(names), directions.reshape(len(names), len(measures), 3), measures)
