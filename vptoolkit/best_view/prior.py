"""Priors of the best-view search: who proposes the first candidate directions.

A prior is any callable ``prior(mesh) -> (k, 3)`` unit directions, most
promising first (the :class:`Prior` protocol);
:func:`~vptoolkit.best_view.search.search_best_views` draws its candidates
first (``prior=prior(mesh)``) and keeps what the drawing says is best, so a
prior only has to put a good direction among a few candidates, not to be
right. ``(0, 3)`` proposes nothing.

Two priors ship, and :func:`resolve_prior` finds them by name, once, for the
library and the command line alike:

``"none"``
    No prior (None).
``"unoccluded"``
    :class:`UnoccludedPrior`, the best directions of the occlusion-free
    estimate (:mod:`vptoolkit.measures.unoccluded`): no image, no network.
``"default"``, or a checkpoint's path
    :class:`vptoolkit.learn.prior.NetworkPrior`, a network's answers (torch
    is imported only then); ``"default"`` answers a point cloud with the
    bundled network of coordinates alone (``"points"``), as a cloud carries
    no face areas.

A callable is taken as it is. Directions point from the model's centre
towards the camera, in the mesh's own coordinates.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from typing import Final, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.errors import InputError
from vptoolkit.io.objects import model_of
from vptoolkit.measures.quality import ranked_views
from vptoolkit.measures.registry import resolve_measures
from vptoolkit.measures.unoccluded import (
    UNOCCLUDED_DIRECTIONS,
    UNOCCLUDED_MEASURES,
    cloud_elements,
    face_elements,
    unoccluded_quality,
)
from vptoolkit.mesh import Mesh, MeshLike
from vptoolkit.point_cloud import PointCloud
from vptoolkit.sphere import coarse_directions, distinct_directions

__all__ = ["PRIOR_NAMES", "Prior", "UnoccludedPrior", "resolve_prior"]

PRIOR_NAMES: Final = ("none", "unoccluded", "default")
"""The priors :func:`resolve_prior` knows by name (besides a checkpoint path or a callable)."""

_PROPOSING = ("VE", "VR", "VKL")  # VMI's estimate is VKL's: one candidate list for both
_RANKED = 32  # best directions per measure looked through for distinct candidates


@runtime_checkable
class Prior(Protocol):
    """What proposes candidate view directions of a mesh to the search.

    ``prior(mesh)`` returns ``(k, 3)`` float64 unit directions, most
    promising first, or ``(0, 3)`` for none; it raises
    :class:`~vptoolkit.errors.InputError` naming the mesh when it cannot
    answer. :class:`UnoccludedPrior` and
    :class:`vptoolkit.learn.prior.NetworkPrior` are priors; so is any
    function of that signature. A prior may also name what proposes a
    model's candidates, ``prior.label(mesh) -> str`` (both shipped priors
    do: ``"unoccluded"``, ``"network points"``), which
    :func:`vptoolkit.best_view.run.search_inputs` puts in the name of the
    search's prior stage.
    """

    def __call__(self, mesh: MeshLike | PointCloud) -> NDArray[np.float64]:
        """Candidate unit directions ``(k, 3)``, most promising first."""
        ...  # pragma: no cover - a protocol


class UnoccludedPrior:
    """Candidate directions of a mesh or a point cloud with normals from the occlusion-free
    estimate, for the search.

    The estimate (:func:`vptoolkit.measures.unoccluded.unoccluded_quality`)
    is evaluated on ``n_directions`` directions of the mesh's principal-frame
    Fibonacci sphere (:func:`vptoolkit.sphere.coarse_directions`, so it turns
    with the mesh); the candidates are each proposing measure's best
    ``per_measure`` directions at least ``min_angle_deg`` apart, rank by rank
    in the order VE, VR, VKL (VMI's estimate is VKL's), duplicates dropped.
    No image is drawn; the cost is a pass over the faces and one product of at
    most 1024 pooled normals with ``n_directions`` directions.

    Parameters
    ----------
    n_directions : int
        Directions evaluated (default: 128).
    per_measure : int
        Candidates per measure (default: 2).
    min_angle_deg : float
        Smallest angle between two candidates of one measure (default: 30).
    measures : str or sequence of str, optional
        The measures the search looks for (registered names, ``"paper"`` or
        ``"all"``: :func:`vptoolkit.measures.registry.resolve_measures`);
        only those the estimate has a closed form for propose candidates
        (:data:`~vptoolkit.measures.unoccluded.UNOCCLUDED_MEASURES`), so a
        search of none of them runs as without a prior (default: VE, VR
        and VKL).

    Attributes
    ----------
    proposing : tuple of str
        The measures whose estimate proposes candidates, in the order above.

    Raises
    ------
    InputError
        On a bad option or an unknown measure name; a call raises it naming
        a mesh of zero surface area.

    Examples
    --------
    >>> search_best_views(mesh, prior=UnoccludedPrior()(mesh))   # doctest: +SKIP
    """

    def __init__(self, n_directions: int = UNOCCLUDED_DIRECTIONS, *, per_measure: int = 2,
                 min_angle_deg: float = 30.0,
                 measures: str | Sequence[str] | None = None) -> None:
        for name, value in (("n_directions", n_directions), ("per_measure", per_measure)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise InputError(f"{name}: expected a positive integer, got {value!r}")
        if not 0.0 <= float(min_angle_deg) < 180.0:
            raise InputError(f"min_angle_deg: expected an angle in [0, 180), got {min_angle_deg!r}")
        self.n_directions = int(n_directions)
        self.per_measure = int(per_measure)
        self.min_angle_deg = float(min_angle_deg)
        searched = _PROPOSING if measures is None else resolve_measures(measures)
        estimated = {"VMI": "VKL"}  # the same closed form
        self.proposing = tuple(name for name in _PROPOSING
                               if name in {estimated.get(m, m) for m in searched})

    def label(self, mesh: MeshLike | PointCloud) -> str:
        """What proposes the candidates, for outputs: ``"unoccluded"``."""
        return "unoccluded"

    def __call__(self, mesh: MeshLike | PointCloud) -> NDArray[np.float64]:
        """Candidate unit directions ``(k, 3)``, most promising first; ``(0, 3)`` when no
        searched measure has a closed form.

        A point cloud (anything :func:`vptoolkit.io.objects.model_of` makes one
        of) is read through its normals, each point weighing the area it
        stands for (:func:`vptoolkit.measures.unoccluded.cloud_elements`); one
        without normals is refused in one line."""
        model = model_of(mesh)
        if not self.proposing:
            return np.zeros((0, 3))
        if isinstance(model, PointCloud):
            normals, areas = cloud_elements(model)
            frame_areas = areas
        else:
            normals, areas, frame_areas = face_elements(model)
        directions = coarse_directions(model, self.n_directions, frame_areas)
        raw = unoccluded_quality(normals, areas, directions)
        per_measure = [distinct_directions(
            directions[ranked_views(raw, UNOCCLUDED_MEASURES.index(name))[:_RANKED]],
            self.min_angle_deg)[:self.per_measure] for name in self.proposing]
        ranked = [found[rank] for rank in range(self.per_measure)
                  for found in per_measure if rank < len(found)]
        return distinct_directions(np.array(ranked).reshape(-1, 3), 1.0)


def resolve_prior(spec: str | os.PathLike[str] | Callable[[Mesh | PointCloud], ArrayLike] | None,
                  *, measures: str | Iterable[str] | None = None,
                  ) -> Callable[[Mesh | PointCloud], ArrayLike] | None:
    """The prior that ``spec`` names, made once for every mesh of a search.

    Parameters
    ----------
    spec : str, path-like, callable or None
        ``"none"`` or None: no prior; ``"unoccluded"``: :class:`UnoccludedPrior`;
        ``"default"`` or a checkpoint's path:
        :class:`vptoolkit.learn.prior.NetworkPrior` (torch imported here);
        a callable (a :class:`Prior`): itself.
    measures : str or iterable of str, optional
        The searched measures; only a prior's proposals for these count
        (default: every measure the prior knows).

    Returns
    -------
    callable or None
        ``prior(mesh) -> (k, 3)`` directions, or None for no prior.

    Raises
    ------
    InputError
        In one line for a ``spec`` of another type, ``prior: expected one of
        'none', 'unoccluded', 'default', a checkpoint path or a callable,
        got 3``; for a checkpoint that does not exist or cannot be read
        (naming it); for an unknown measure.
    MissingDependencyError
        For a network without torch installed (the ``learn`` extra).
    """
    if spec is None or (isinstance(spec, str) and spec == "none"):
        return None
    searched = None if measures is None else resolve_measures(measures)
    if isinstance(spec, str) and spec == "unoccluded":
        return UnoccludedPrior(measures=searched)
    if isinstance(spec, (str, os.PathLike)):
        from vptoolkit.learn.prior import NetworkPrior

        return NetworkPrior(spec, measures=searched)
    if callable(spec):
        return spec
    raise InputError(f"prior: expected one of {', '.join(map(repr, PRIOR_NAMES))}, a "
                     f"checkpoint path or a callable, got {spec!r}")
