"""The evaluation protocol for predicted viewpoints: rotated inputs, baselines, standard errors.

Meshes arrive in any orientation, so a viewpoint predictor is scored on
rotated inputs (:func:`score_protocol`):

1. every model gets ``n_rotations`` fixed rotations ``R_k``
   (:func:`vptoolkit.rotations.fixed_rotations`, seeded by its name);
2. the predictor sees the surface points ``x R_k^T`` and answers with one
   direction per measure in that frame (per measure the dataset records,
   :attr:`~vptoolkit.data.ViewpointDataset.measures`, ``M`` in all; or one
   direction for every measure);
3. the answer goes back to the model's frame (``d R_k``) and scores the
   normalised quality of the nearest sampled view, in percent (the
   authors' scoring, :meth:`vptoolkit.data.ViewpointDataset.quality_of`);
4. a model's score is the mean over its rotations; a table row is the mean
   over models with its standard error ``s / sqrt(n)`` (``s`` the sample
   standard deviation over models).

An answer that needs the mesh itself (a search that draws views) is scored
the same way by :func:`score_mesh_protocol`: it sees the stored cleaned mesh
rotated by the same ``R_k`` instead of the points.

``rotate=False`` scores the models in their stored orientation (one pass):
the paper's protocol, a second table, easy for shapes that are stored upright.

Baselines under the same protocol
    :func:`random_view_scores`: a direction drawn uniformly on the sphere,
    as an expectation, not one draw: the mean normalised quality over the
    sampled views. A uniform direction's nearest view is each Fibonacci view
    with probability equal to its Voronoi cell's share of the sphere, and
    those cells have equal area to within a few percent, so this is the
    expectation up to that (checked against 20000 random directions by the
    tests). Rotations do not change it.

    :func:`pca_predictor`: the smallest principal axis
    (:func:`vptoolkit.evaluate.baselines.pca_directions`), rotation-equivariant,
    one direction for every measure.

    :func:`best_constant_directions` and :func:`constant_predictor`: one fixed
    direction per measure, the sampled view with the best mean score over a
    training split in its stored orientation. Under rotation it is as good as
    a random view; on upright shapes it is a strong rival.

Every score array has one column per measure the dataset records, in its
order (:attr:`ProtocolScores.measures`).

A difference between two rows is significant here when it exceeds twice its
paired standard error (:func:`paired_difference`), about a 95 % level.

Needs numpy only.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import check_int
from vptoolkit.data import ViewpointDataset
from vptoolkit.errors import InputError
from vptoolkit.evaluate.baselines import pca_directions
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.mesh import Mesh
from vptoolkit.rotations import fixed_rotations

__all__ = [
    "Predictor",
    "ProtocolScores",
    "score_protocol",
    "score_mesh_protocol",
    "random_view_scores",
    "pca_predictor",
    "best_constant_directions",
    "constant_predictor",
    "paired_difference",
]

Predictor = Callable[[Sequence[NDArray[np.float64]], Sequence[str]], NDArray[np.float64]]
"""``predictor(points, names) -> (n_models, M, 3)``: one direction per measure the dataset
records for each ``(n_points_i, 3)`` cloud, in the cloud's own frame (not necessarily unit);
or ``(n_models, 1, 3)``, one direction for every measure."""


@dataclass(frozen=True)
class ProtocolScores:
    """Per-model scores of one predictor under the protocol, in percent.

    Attributes
    ----------
    names, categories : tuple of str
        The models, in dataset order.
    scores : (n_models, M) float64
        Mean over the model's rotations of the normalised quality of the
        nearest sampled view, in percent, one column per name of ``measures``.
    n_rotations : int
        Rotations per model (0 for the stored orientation).
    measures : tuple of str
        The columns' measures, the dataset's (default: the paper's four).
    """

    names: tuple[str, ...]
    categories: tuple[str, ...]
    scores: NDArray[np.float64]
    n_rotations: int
    measures: tuple[str, ...] = PAPER_MEASURES

    @property
    def mean(self) -> NDArray[np.float64]:
        """(M,) mean over models."""
        return np.asarray(self.scores.mean(axis=0))

    @property
    def sem(self) -> NDArray[np.float64]:
        """(M,) standard error of :attr:`mean` (sample standard deviation / sqrt(n))."""
        n = len(self.scores)
        if n < 2:
            return np.full(self.scores.shape[1], np.nan)
        return np.asarray(self.scores.std(axis=0, ddof=1) / np.sqrt(n))

    def category_means(self) -> dict[str, NDArray[np.float64]]:
        """Mean over each category's models, categories sorted."""
        categories = np.array(self.categories)
        return {name: self.scores[categories == name].mean(axis=0)
                for name in sorted(set(self.categories))}


def _check_dataset(dataset: ViewpointDataset) -> None:
    if not isinstance(dataset, ViewpointDataset):
        raise InputError(f"dataset: expected a ViewpointDataset, got {type(dataset).__name__}")
    if len(dataset) == 0:
        raise InputError(f"{dataset.path.name}: no models to score")


def _models_and_rotations(dataset: ViewpointDataset, n_rotations: int) -> tuple[list[str], int]:
    """The names of the models to score (at least one) and the checked rotations per model."""
    _check_dataset(dataset)
    return list(dataset.names), check_int(n_rotations, "n_rotations", minimum=1)


def _per_measure(directions: NDArray[np.float64], n_measures: int, what: str,
                 ) -> NDArray[np.float64]:
    """``(..., n_measures, 3)`` directions: as given, or one direction (``(..., 1, 3)``)
    repeated for every measure."""
    expected = (*directions.shape[:-2], n_measures, 3)
    if directions.shape[-2:] == (1, 3):
        return np.repeat(directions, n_measures, axis=-2)
    if directions.ndim < 2 or directions.shape != expected:
        raise InputError(f"{what}: expected directions of shape {expected} "
                         f"(or {(*expected[:-2], 1, 3)}: one for every measure), "
                         f"got {directions.shape}")
    return directions


def _directions(predictor: Predictor, clouds: list[NDArray[np.float64]],
                names: list[str], n_measures: int) -> NDArray[np.float64]:
    directions = np.asarray(predictor(clouds, names), dtype=np.float64)
    if directions.ndim != 3 or len(directions) != len(clouds):
        raise InputError("predictor: expected directions of shape "
                         f"({len(clouds)}, {n_measures}, 3), got {directions.shape}")
    return _per_measure(directions, n_measures, "predictor")


def score_protocol(dataset: ViewpointDataset, predictor: Predictor, *, n_rotations: int = 4,
                   rotate: bool = True, seed: int = 0) -> ProtocolScores:
    """Score a predictor on rotated inputs (or the stored orientation).

    Parameters
    ----------
    dataset : ViewpointDataset
        The models to score, e.g. a test split.
    predictor : callable
        ``predictor(points, names) -> (n_models, M, 3)`` or ``(n_models, 1, 3)``,
        see :data:`Predictor`; called once per rotation index with every
        model's rotated surface points.
    n_rotations : int
        Rotations per model, at least 1 (default: 4); ignored without ``rotate``.
    rotate : bool
        True (default): the rotated protocol; False: the stored orientation.
    seed : int
        Seed of the rotations (default: 0).

    Returns
    -------
    ProtocolScores
        Each model's score averaged over its rotations (``n_rotations`` 0:
        the stored orientation).
    """
    names, n_rotations = _models_and_rotations(dataset, n_rotations)
    points = [np.asarray(dataset[i]["points"], dtype=np.float64) for i in range(len(dataset))]
    if rotate:
        rotations = np.stack([fixed_rotations(name, n_rotations, seed=seed) for name in names])
    else:
        rotations = np.eye(3)[None, None].repeat(len(names), axis=0)
    measures = dataset.measures
    totals = np.zeros((len(names), len(measures)))
    for k in range(rotations.shape[1]):
        turned = [cloud @ rotations[i, k].T for i, cloud in enumerate(points)]
        directions = _directions(predictor, turned, names, len(measures))
        for i in range(len(names)):
            back = directions[i] @ rotations[i, k]
            totals[i] += 100.0 * np.diagonal(dataset.quality_of(i, back))
    return ProtocolScores(tuple(names), tuple(dataset.categories), totals / rotations.shape[1],
                          n_rotations if rotate else 0, measures)


def score_mesh_protocol(dataset: ViewpointDataset,
                        answer: Callable[[Mesh], NDArray[np.float64]], *,
                        n_rotations: int = 4, seed: int = 0) -> ProtocolScores:
    """Score an answer that draws the mesh (e.g. a plain search) on rotated meshes.

    The same protocol as :func:`score_protocol`, with the stored cleaned
    mesh ``V R_k^T`` in place of the points: ``answer(mesh) -> (M, 3)``
    directions in the rotated frame, scored after ``d R_k``.

    Parameters
    ----------
    dataset : ViewpointDataset
        The models to score; their stored meshes are used.
    answer : callable
        ``answer(mesh) -> (M, 3)`` unit directions, one per measure the
        dataset records, in its order; or ``(1, 3)``, one for every measure.
    n_rotations : int
        Rotations per model, at least 1 (default: 4).
    seed : int
        Seed of the rotations (default: 0).

    Returns
    -------
    ProtocolScores
        Each model's score averaged over the answers for its rotated meshes.
    """
    names, n_rotations = _models_and_rotations(dataset, n_rotations)
    measures = dataset.measures
    totals = np.zeros((len(names), len(measures)))
    for i, name in enumerate(names):
        stored, faces = dataset.mesh(i)
        vertices = np.asarray(stored, dtype=np.float64)
        faces64 = np.asarray(faces, dtype=np.int64)
        for turn in fixed_rotations(name, n_rotations, seed=seed):
            rotated = Mesh(vertices @ turn.T, faces64, name=name)
            directions = _per_measure(np.asarray(answer(rotated), dtype=np.float64),
                                      len(measures), "answer")
            totals[i] += 100.0 * np.diagonal(dataset.quality_of(i, directions @ turn))
    return ProtocolScores(tuple(names), tuple(dataset.categories), totals / n_rotations,
                          n_rotations, measures)


def random_view_scores(dataset: ViewpointDataset) -> ProtocolScores:
    """The expected score of a uniformly random direction.

    That is the mean quality over the sampled views.
    """
    _check_dataset(dataset)
    scores = np.stack([100.0 * np.asarray(dataset[i]["quality"], dtype=np.float64).mean(axis=0)
                       for i in range(len(dataset))])
    return ProtocolScores(tuple(dataset.names), tuple(dataset.categories), scores, 0,
                          dataset.measures)


def pca_predictor(points: Sequence[NDArray[np.float64]],
                  names: Sequence[str]) -> NDArray[np.float64]:
    """The PCA heuristic as a :data:`Predictor`: ``(n_models, 1, 3)``, one direction for
    every measure.

    See :func:`vptoolkit.evaluate.baselines.pca_directions`.
    """
    return pca_directions(list(points), n_measures=1)


def best_constant_directions(dataset: ViewpointDataset) -> NDArray[np.float64]:
    """The sampled view with the best mean normalised quality over ``dataset``, per measure.

    Parameters
    ----------
    dataset : ViewpointDataset
        Usually a training split, in its stored orientation.

    Returns
    -------
    directions : (M, 3) float64
        Unit vectors, one per measure the dataset records, in its order.
    """
    _check_dataset(dataset)
    total = np.zeros((len(dataset.views), len(dataset.measures)))
    for i in range(len(dataset)):
        total += np.asarray(dataset[i]["quality"], dtype=np.float64)
    return np.asarray(dataset.views[total.argmax(axis=0)], dtype=np.float64)


def constant_predictor(directions: NDArray[np.float64]) -> Predictor:
    """A :data:`Predictor` answering ``directions`` ``(M, 3)`` (one per measure, e.g. from
    :func:`best_constant_directions`) for every input."""
    fixed = np.asarray(directions, dtype=np.float64)
    if fixed.ndim != 2 or fixed.shape[1] != 3 or len(fixed) == 0:
        raise InputError(f"directions: expected shape (n_measures, 3), got {fixed.shape}")

    def predict(points: Sequence[NDArray[np.float64]], names: Sequence[str]) -> NDArray[np.float64]:
        return np.repeat(fixed[None], len(points), axis=0)

    return predict


def paired_difference(
    first: ProtocolScores, second: ProtocolScores,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Mean and standard error of ``first - second`` over the same models, per measure.

    Returns
    -------
    difference, sem : (M,) float64
        In percentage points; the difference is significant at about the
        95 % level where ``|difference| > 2 sem``.
    """
    if first.names != second.names:
        raise InputError("paired_difference: the two score sets cover different models")
    if first.measures != second.measures:
        raise InputError("paired_difference: the two score sets cover different measures "
                         f"({', '.join(first.measures)}; {', '.join(second.measures)})")
    delta = first.scores - second.scores
    n = len(delta)
    sem = delta.std(axis=0, ddof=1) / np.sqrt(n) if n > 1 else np.full(delta.shape[1], np.nan)
    return np.asarray(delta.mean(axis=0)), np.asarray(sem)
