"""Predictors: what answers a best view per model and measure, behind one call.

A predictor is any callable ``predictor(inputs, *, split="test") ->
Predictions`` (the :class:`Predictor` protocol): ``inputs`` are mesh files,
``.npy`` point files, datasets (paths, release URLs or an open
:class:`~vptoolkit.data.ViewpointDataset`), one or a sequence, told apart by
:func:`vptoolkit.inputs.open_inputs`; ``split`` is a
:data:`~vptoolkit.conventions.Split` (None: every model of a dataset). The
answer is :class:`~vptoolkit.predictions.Predictions`, in input order, which
``vptool evaluate`` scores whoever made it.

:func:`resolve_predictor` finds one by name, once, for the library and the
command line alike:

``"default"``, ``"points"`` or a checkpoint's path
    a network (:func:`vptoolkit.learn.predict.predict`; torch is imported
    only when it answers);
``"unoccluded"``
    :func:`predict_unoccluded`, the closed form of
    :mod:`vptoolkit.measures.unoccluded`: no network, no image;
a callable
    itself.

Directions are unit vectors from the model's centre towards the camera, in
each input's own coordinates.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING, Final, Protocol, TypeAlias

import numpy as np
from numpy.typing import NDArray

from vptoolkit.conventions import Split
from vptoolkit.errors import InputError
from vptoolkit.measures.unoccluded import (
    UNOCCLUDED_DIRECTIONS,
    face_elements,
    unit_normals,
    unoccluded_best_views,
    unoccluded_measures,
)
from vptoolkit.mesh import Mesh
from vptoolkit.point_cloud import MAX_POINTS
from vptoolkit.predictions import Predictions
from vptoolkit.sphere import coarse_directions

if TYPE_CHECKING:
    from vptoolkit.data import ViewpointDataset

__all__ = ["PREDICTOR_NAMES", "Inputs", "Predictor", "predict_unoccluded", "resolve_predictor"]

Inputs: TypeAlias = ("str | os.PathLike[str] | ViewpointDataset"
                     " | Sequence[str | os.PathLike[str] | ViewpointDataset]")
"""What a predictor answers: one input or a sequence of mesh files, point files and datasets."""

PREDICTOR_NAMES: Final = ("default", "points", "unoccluded")
"""The predictors :func:`resolve_predictor` knows by name (besides a checkpoint path or a
callable): the bundled networks, and the occlusion-free estimate."""


class Predictor(Protocol):
    """What answers a best view per model and measure (module docstring)."""

    def __call__(self, inputs: Inputs, *, split: Split = "test") -> Predictions:
        """The predictions of every model of ``inputs``, in input order."""
        ...  # pragma: no cover - a protocol


def predict_unoccluded(
    inputs: Inputs,
    *,
    split: Split = "test",
    n_directions: int = UNOCCLUDED_DIRECTIONS,
    measures: str | Iterable[str] | None = None,
    max_points: int = MAX_POINTS,
) -> Predictions:
    """:func:`~vptoolkit.measures.unoccluded.unoccluded_best_views` of mesh files, point files
    with normals and dataset splits.

    Parameters
    ----------
    inputs : path-like, ViewpointDataset or a sequence of them
        Mesh files (their faces, on the mesh's principal-frame sphere of
        ``n_directions``, :func:`vptoolkit.sphere.coarse_directions`),
        ``(N, 6)`` ``.npy`` point files (``x y z nx ny nz``; on the Fibonacci
        sphere of ``n_directions``) and datasets (their stored points' normals,
        likewise), in any mix, told apart by :func:`vptoolkit.inputs.open_inputs`.
        Names: file stems, or the dataset's.
    split : str, optional
        Split of dataset inputs, or None for every model (default: "test").
    n_directions : int
        Directions the estimate is evaluated at (default: 128).
    measures : str or iterable of str, optional
        The measures to answer, any of
        :data:`~vptoolkit.measures.unoccluded.UNOCCLUDED_MEASURES` (default:
        the paper's four).
    max_points : int
        Most points a point cloud file keeps; a larger one is thinned on
        reading (:func:`vptoolkit.io.load`; default:
        :data:`~vptoolkit.point_cloud.MAX_POINTS`).

    Returns
    -------
    Predictions
        ``names``, ``directions (n_models, M, 3) float64``: unit directions in
        the order of ``measures``, each in its input's own frame, and ``measures``.

    Raises
    ------
    InputError
        Naming the input, on an unreadable file, a point file without normals,
        an unknown file type or split, two models of one name, or a normal
        that is NaN, infinite or of zero length (naming the dataset and model
        for a stored one); in one line for a measure without a closed form.
    """
    from vptoolkit.inputs import claim_name, open_inputs

    names = unoccluded_measures(measures)
    seen: set[str] = set()
    answers: list[NDArray[np.float64]] = []
    with open_inputs(inputs, split=split, max_points=max_points) as sources:
        for source in sources:
            claim_name(seen, source.name)
            model = source.model() if source.kind == "file" else None
            if isinstance(model, Mesh):
                normals, areas, face_areas = face_elements(model)
                answers.append(unoccluded_best_views(
                    normals, areas, directions=coarse_directions(model, n_directions, face_areas),
                    measures=names))
            elif model is not None:
                answers.append(unoccluded_best_views(source.normals(), directions=n_directions,
                                                     measures=names))
            else:
                answers.append(unoccluded_best_views(
                    unit_normals(source.normals(), f"{source.origin}: model {source.name!r}"),
                    directions=n_directions, measures=names))
        ordered = tuple(source.name for source in sources)
    return Predictions(ordered, np.array(answers).reshape(-1, len(names), 3), names)


def resolve_predictor(spec: str | os.PathLike[str] | Callable[..., Predictions], *,
                      seed: int = 0, category: str | None = None, device: str = "auto",
                      n_inputs: int | None = None, progress: bool = False,
                      max_points: int = MAX_POINTS) -> Predictor:
    """The predictor that ``spec`` names, with one call signature (:class:`Predictor`).

    Parameters
    ----------
    spec : str, path-like or callable
        ``"default"`` or ``"points"`` (the bundled networks), a checkpoint's
        path (:func:`vptoolkit.learn.predict.predict`), ``"unoccluded"``
        (:func:`predict_unoccluded`), or a callable, returned as it is.
    seed, category, device, progress
        A network's options (:func:`vptoolkit.learn.predict.predict`); the
        unoccluded estimate has no use for them.
    n_inputs : int, optional
        A network's inputs per model (default: its :data:`~vptoolkit.learn.draws.N_INPUTS`).
    max_points : int
        Most points a point cloud file keeps, for the network and the
        unoccluded estimate alike (:func:`vptoolkit.io.load`; default:
        :data:`~vptoolkit.point_cloud.MAX_POINTS`); a callable reads its own.

    Returns
    -------
    Predictor
        ``predictor(inputs, *, split="test") -> Predictions``. A network is
        loaded when it is called, after every point file is checked.

    Raises
    ------
    InputError
        In one line for a ``spec`` of another type (``model: expected one of
        'default', 'points', 'unoccluded', a checkpoint path or a callable,
        got 3``), or for ``n_inputs`` with ``"unoccluded"``, which asks no
        network (``--inputs``).
    """
    if isinstance(spec, str) and spec == "unoccluded":
        if n_inputs is not None:
            raise InputError("n_inputs: 'unoccluded' asks no network, so it takes no network "
                             "inputs (--inputs); drop one of them")
        return functools.partial(predict_unoccluded, max_points=max_points)
    if isinstance(spec, (str, os.PathLike)):
        return functools.partial(_predict_network, spec, seed=seed, category=category,
                                 device=device, n_inputs=n_inputs, progress=progress,
                                 max_points=max_points)
    if callable(spec):
        return spec
    raise InputError(f"model: expected one of {', '.join(map(repr, PREDICTOR_NAMES))}, a "
                     f"checkpoint path or a callable, got {spec!r}")


def _predict_network(model: str | os.PathLike[str], inputs: Inputs, *, split: Split = "test",
                     seed: int, category: str | None, device: str, n_inputs: int | None,
                     progress: bool, max_points: int) -> Predictions:
    """A network's predictions; point files are checked before the network is loaded."""
    from pathlib import Path

    from vptoolkit.inputs import read_model
    from vptoolkit.io import POINT_SUFFIXES
    from vptoolkit.learn.draws import N_INPUTS
    from vptoolkit.learn.predict import predict

    entries = [inputs] if isinstance(inputs, (str, os.PathLike)) or not isinstance(
        inputs, Sequence) else inputs
    for entry in entries:
        if isinstance(entry, (str, os.PathLike)) and Path(entry).suffix.lower() in POINT_SUFFIXES \
                and Path(entry).is_file():
            read_model(Path(entry), max_points=max_points)
    return predict(model, inputs, split=split, seed=seed, progress=progress, category=category,
                   device=device, n_inputs=N_INPUTS if n_inputs is None else n_inputs,
                   max_points=max_points)
