"""An anytime best-view search: the best direction per measure within a budget of rendered views.

The cost of a view search is the number of triangle-ID images drawn, whatever
the machine; :func:`search_best_views` spends a budget of ``budget`` views in
stages, coarse to fine, and returns the best direction it measured for each
measure it searches (:mod:`vptoolkit.measures`; by default the paper's four,
VE, VR, VKL and VMI; any other that a few views can evaluate, see
*Measures* below):

1. **coarse**: a Fibonacci sphere of ``coarse_views`` directions (half the
   budget) at ``coarse_resolution`` pixels (``resolution`` up to 128 px, then
   128), laid out in the model's principal-axis frame (the sphere's poles on
   the axis of least spread), so the pattern turns with the model and any
   input orientation is searched alike;
2. **prior** (optional): the first candidate directions proposed by someone
   else, e.g. the occlusion-free estimate (:class:`vptoolkit.best_view.prior.UnoccludedPrior`)
   or a network (:mod:`vptoolkit.learn.prior`), drawn at
   ``resolution``: at most an eighth of the budget (one view at least), since
   on real meshes a larger share cost the sphere more than the network's
   candidates gave back;
3. **confirm**: the two best coarse directions of each measure drawn again at
   ``resolution`` (only when the coarse sphere was drawn smaller);
4. **refine**: rounds of pattern search: around each measure's best direction
   so far, a ring of four directions at an angle that starts at half the
   coarse spacing and halves every round (the ring turned by 45 degrees each
   time), until the budget is spent or the angle falls below
   :data:`MIN_STEP_DEG`.

Budgets below :data:`FLAT_BELOW` views are one coarse sphere at
``resolution``: there, more directions beat refining a few.

An elevation band (``SearchSettings(up=..., elevation=(low, high))``, in
degrees above the horizon of the model's up axis) holds every stage inside
it: the coarse sphere is a Fibonacci pattern of the band alone (evenly spaced
in ``sin(elevation)``, the area measure of the band, around the up axis), and
the prior's candidates and the refinement's rings are moved into the band
along their meridian (:func:`vptoolkit.sphere.into_band`: the elevation clamped to
``[low, high]``, the azimuth kept). Without a band the whole sphere is searched,
as above. Why these
choices: ``docs/design/best-view.md``.

Only views drawn at ``resolution`` compete for the answer, so every answer's
measured value is at that resolution, and the answer is never worse there than
the coarse pass's own best, drawn again. VMI needs the face distribution
``p(z)`` over the whole sphere; it is estimated from the coarse sphere's views
(``p(z) = sum_v a_z(v) / sum_v a_t(v)``, as for a full measurement), and a face
no coarse view saw gets the share one more view would give it if that view saw
every face in proportion to its area (``mean_v a_t(v) A_z / A_t``, divided by
``sum_v a_t(v) + mean_v a_t(v)``). With no coarse view, ``p(z) = A_z / A_t``,
which makes VMI equal VKL.

Measures
    One measuring session (:class:`vptoolkit.measures.session.MeasuringSession`)
    draws and measures every stage. The paper's four are measured from each
    stage's streamed pixel counts as above (with the estimated ``p(z)``). Any
    other registered measure is computed by the session from the same
    drawing (:attr:`Measure.compute <vptoolkit.measures.measure.Measure.compute>`),
    with the depth and silhouette statistics drawn too where one needs them;
    the per-mesh curvature is computed once per search (the session's
    ``mesh_cache``). Where such a measure compares a view with the others drawn (I2
    and I3 through the distributions over the views, SS through the largest
    projected area), the others are every view drawn at ``resolution`` so
    far, and the competing views are measured again after each stage, so
    every comparison is over one set of views. Measures that need the
    neighbouring views on the sphere or a saliency computed from all views
    (:data:`UNSEARCHABLE_NEEDS`: INS, DVS, SAL, EVMI, MS) cannot be
    evaluated on a few scattered views; the search refuses them
    (:func:`searchable_measures`), and ``vptool measures`` computes them
    over the full sphere.

Directions are unit vectors from the bounding-box centre towards the camera,
in the mesh's own coordinates; raw values are in each measure's units (bits
for VE, VKL, VMI; VR a fraction); which way is better is the registry's
(:attr:`Measure.higher_is_better <vptoolkit.measures.measure.Measure.higher_is_better>`:
higher for VE and VR, lower for VKL and VMI). :meth:`BestViews.camera_pose`
hands the camera that drew an answer to another renderer (:mod:`vptoolkit.camera`).

Size
    About 600 lines for one concept, the search of one mesh or cloud: its
    settings (:class:`SearchSettings`), the stages,
    and which views a session measures together (the paper's four per stage
    with the estimated ``p(z)``, the others over the competing views). The
    stages and the measuring share the incumbents, the estimate and the
    competing views, which a split would have to pass between modules; the
    search over many inputs is :mod:`vptoolkit.best_view.run`, its answer
    (:class:`~vptoolkit.best_view.answer.BestViews`) :mod:`vptoolkit.best_view.answer`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Final, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.best_view.answer import BestViews, SearchStage
from vptoolkit.camera import Camera
from vptoolkit.checks import check_int_range
from vptoolkit.conventions import PICTURE_UP
from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.io.objects import model_of
from vptoolkit.measures.quality import ranked_views
from vptoolkit.measures.registry import get_measure, resolve_measures
from vptoolkit.measures.session import MeasuringSession
from vptoolkit.mesh import Mesh, MeshLike
from vptoolkit.point_cloud import PointCloud
from vptoolkit.settings import MAX_RESOLUTION, MeasureSettings
from vptoolkit.sphere import as_directions, band_directions, coarse_directions, into_band
from vptoolkit.upright import resting_up
from vptoolkit.visibility import ViewHistograms

__all__ = [
    "BUDGET",
    "SEARCH_RESOLUTION",
    "COARSE_RESOLUTION",
    "FLAT_BELOW",
    "MIN_STEP_DEG",
    "MAX_BUDGET",
    "UNSEARCHABLE_NEEDS",
    "SearchSettings",
    "search_best_views",
    "check_search_settings",
    "searchable_measures",
]

BUDGET: Final = 64
"""Default budget: views drawn per mesh, over all stages."""

SEARCH_RESOLUTION: Final = 128
"""Default side in pixels of the images that decide the answer."""

COARSE_RESOLUTION: Final = 128
"""Largest default side in pixels of the coarse sphere's images (at most ``resolution``)."""

FLAT_BELOW: Final = 16
"""Budgets below this are one coarse sphere at ``resolution``, no refinement."""

MIN_STEP_DEG: Final = 0.25
"""The refinement stops once its ring is narrower than this, in degrees."""

MAX_BUDGET: Final = 100_000
"""Largest budget accepted (views per mesh)."""

UNSEARCHABLE_NEEDS: Final = frozenset({"neighbours", "saliency"})
"""Needs (:data:`vptoolkit.measures.registry.NEEDS`) a search cannot meet: the
neighbouring views on the sphere, and a saliency computed from all views."""


_RING = 4  # directions per ring of the refinement
_FIRST_STEP = 0.5  # the first ring's angle, in coarse spacings
_PRIOR_SHARE = 0.125  # the most of the budget a prior's candidates take (at least one view)
_CONFIRM_PER_MEASURE = 2  # coarse directions per measure drawn again at full resolution


@dataclass
class _Incumbents:
    """The best direction and raw value per measure among the views drawn at full resolution."""

    directions: NDArray[np.float64]
    raw: NDArray[np.float64]
    higher_is_better: tuple[bool, ...]

    @classmethod
    def empty(cls, higher_is_better: Sequence[bool]) -> _Incumbents:
        n = len(higher_is_better)
        return cls(np.zeros((n, 3)), np.full(n, np.nan), tuple(higher_is_better))

    def offer(self, directions: NDArray[np.float64], raw: NDArray[np.float64],
              columns: Sequence[int]) -> None:
        """Keep, per measure of ``columns``, the better of the incumbent and the best new
        view (first on ties)."""
        for column in columns:
            higher = self.higher_is_better[column]
            values = raw[:, column]
            if not np.isfinite(values).any():
                continue
            best = int(np.nanargmax(values) if higher else np.nanargmin(values))
            current = self.raw[column]
            better = values[best] > current if higher else values[best] < current
            if not np.isfinite(current) or better:
                self.directions[column] = directions[best]
                self.raw[column] = values[best]

    def take_best(self, directions: NDArray[np.float64], raw: NDArray[np.float64],
                  columns: Sequence[int]) -> None:
        """Take, per measure of ``columns``, the best of these views alone (first on ties):
        for values measured again over every competing view."""
        self.raw[list(columns)] = np.nan
        self.offer(directions, raw, columns)

    def centres(self) -> NDArray[np.float64]:
        """Distinct incumbent directions, in measure order."""
        distinct: list[NDArray[np.float64]] = []
        for column in np.flatnonzero(np.isfinite(self.raw)):
            direction = self.directions[column]
            if all(float(direction @ other) < 1.0 - 1e-12 for other in distinct):
                distinct.append(direction)
        return np.array(distinct).reshape(-1, 3)


def searchable_measures(measures: str | Sequence[str] | None = None) -> tuple[str, ...]:
    """The measures a search can look for, from what a user wrote.

    Parameters
    ----------
    measures : str, sequence of str or None
        What :func:`~vptoolkit.measures.registry.resolve_measures` takes
        (``None``: the paper's four; ``"all"``; ``"VE,SL"``).

    Returns
    -------
    tuple of str
        The names, in the order given.

    Raises
    ------
    InputError
        One line: an unknown or repeated name, or measures the search cannot
        evaluate, named with why (those with a need in
        :data:`UNSEARCHABLE_NEEDS`: the neighbouring views of each view, or a
        saliency over all views of the sphere).
    """
    names = resolve_measures(measures)
    why = {"neighbours": "the neighbouring views of each view",
           "saliency": "a saliency computed from all views"}
    refused = []
    for name in names:
        needs = sorted(get_measure(name).needs & UNSEARCHABLE_NEEDS)
        if needs:
            refused.append(f"{name} ({' and '.join(why[need] for need in needs)})")
    if refused:
        raise InputError(f"measures: {', '.join(refused)} cannot be evaluated on the few "
                         "views a search draws; measure them over the whole sphere with "
                         "vptool measures")
    return names


@dataclass(frozen=True)
class SearchSettings:
    """How a best-view search spends its views, checked once when made.

    Parameters
    ----------
    budget : int
        Views drawn over all stages, 1 to :data:`MAX_BUDGET` (default:
        :data:`BUDGET` = 64). A view at ``resolution`` px costs about what one
        of the 1000 views of :func:`~vptoolkit.measures.quality.compute_view_quality`
        costs there; views of a smaller ``coarse_resolution`` cost less.
    resolution : int
        Image side in pixels of the views that decide the answer, 1 to
        :data:`vptoolkit.settings.MAX_RESOLUTION` (default:
        :data:`SEARCH_RESOLUTION` = 128).
    coarse_views : int, optional
        Directions of the coarse sphere, 0 to ``budget`` (default: half of
        what a prior leaves; all of it below :data:`FLAT_BELOW` views). With a
        prior, the search also refuses more than the prior leaves.
    coarse_resolution : int, optional
        Image side of the coarse sphere, 1 to ``resolution`` (default:
        ``min(resolution, 128)``, and ``resolution`` below :data:`FLAT_BELOW` views).
    camera : Camera
        Camera conventions (default: ``Camera()``).
    up : tuple of 3 floats or "auto"
        The model's up axis, normalised here (default: ``(0, 1, 0)``): the
        pole of ``elevation`` and the top of the exported poses' images
        (:meth:`BestViews.camera_pose`); ``"auto"``: per mesh, the side it
        stands on (:func:`vptoolkit.upright.resting_up`). The measures' own
        camera is ``camera``.
    elevation : tuple of 2 floats, optional
        ``(low, high)`` degrees above the horizon of ``up``, ``-90 <= low <
        high <= 90``: every direction drawn lies in this band (module
        docstring). Default None: the whole sphere.

    Raises
    ------
    InputError
        A one-line message naming the field, e.g.
        ``budget: expected an integer from 1 to 100000, got 0``.

    Examples
    --------
    >>> SearchSettings(budget=16, resolution=64).to_dict()["budget"]
    16
    """

    budget: int = BUDGET
    resolution: int = SEARCH_RESOLUTION
    coarse_views: int | None = None
    coarse_resolution: int | None = None
    camera: Camera = field(default_factory=Camera)
    up: tuple[float, float, float] | Literal["auto"] = PICTURE_UP
    elevation: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        budget = check_int_range(self.budget, "budget", 1, MAX_BUDGET)
        resolution = check_int_range(self.resolution, "resolution", 1, MAX_RESOLUTION)
        object.__setattr__(self, "budget", budget)
        object.__setattr__(self, "resolution", resolution)
        if self.coarse_views is not None:
            object.__setattr__(self, "coarse_views", check_int_range(
                self.coarse_views, "coarse_views", 0, budget))
        if self.coarse_resolution is not None:
            object.__setattr__(self, "coarse_resolution", check_int_range(
                self.coarse_resolution, "coarse_resolution", 1, resolution))
        if not isinstance(self.camera, Camera):
            raise InputError(f"camera: expected a Camera, got {type(self.camera).__name__}")
        if self.up != "auto":
            up = np.asarray(self.up, dtype=np.float64) if _is_numeric(self.up) else np.zeros(0)
            if up.shape != (3,) or not np.isfinite(up).all() or not np.linalg.norm(up) > 0:
                raise InputError(f"up: expected a non-zero direction x, y, z or 'auto', "
                                 f"got {self.up!r}")
            object.__setattr__(self, "up", tuple(float(c) for c in up / np.linalg.norm(up)))
        if self.elevation is not None:
            band = (np.asarray(self.elevation, dtype=np.float64) if _is_numeric(self.elevation)
                    else np.zeros(0))
            if band.shape != (2,) or not np.isfinite(band).all() \
                    or not -90.0 <= band[0] < band[1] <= 90.0:
                raise InputError("elevation: expected (low, high) degrees with -90 <= low < "
                                 f"high <= 90, got {self.elevation!r}")
            object.__setattr__(self, "elevation", (float(band[0]), float(band[1])))

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe record: the fields, the camera as its record; ``up`` and ``elevation``
        only where they differ from the defaults, so that older records stay the same."""
        record: dict[str, Any] = {
            "budget": self.budget, "resolution": self.resolution,
            "coarse_views": self.coarse_views, "coarse_resolution": self.coarse_resolution,
            "camera": self.camera.to_dict()}
        if self.up != PICTURE_UP:
            record["up"] = self.up if isinstance(self.up, str) else list(self.up)
        if self.elevation is not None:
            record["elevation"] = list(self.elevation)
        return record


def _is_numeric(value: Any) -> bool:
    """Whether ``value`` is a sequence of real numbers (not text)."""
    try:
        return not isinstance(value, str) and all(
            isinstance(c, (int, float, np.number)) and not isinstance(c, bool) for c in value)
    except TypeError:
        return False


def check_search_settings(settings: Any) -> SearchSettings:
    """``settings`` if it is a :class:`SearchSettings`; else InputError naming its type."""
    if not isinstance(settings, SearchSettings):
        raise InputError(f"settings: expected SearchSettings, got {type(settings).__name__} "
                         "(SearchSettings(budget=..., resolution=...))")
    return settings


def ring(centre: NDArray[np.float64], angle: float, n: int, turn: float) -> NDArray[np.float64]:
    """``n`` unit directions ``angle`` radians from ``centre``, evenly around it from ``turn``."""
    helper = np.eye(3)[int(np.argmin(np.abs(centre)))]
    first = np.cross(centre, helper)
    first /= np.linalg.norm(first)
    second = np.cross(centre, first)
    phases = turn + 2.0 * math.pi * np.arange(n) / n
    around = np.cos(phases)[:, None] * first + np.sin(phases)[:, None] * second
    points = math.cos(angle) * centre + math.sin(angle) * around
    return np.asarray(points / np.linalg.norm(points, axis=1, keepdims=True))


def _face_probability(counts: NDArray[np.float64], n_views: int,
                      areas: NDArray[np.float64]) -> NDArray[np.float64]:
    """Estimated ``p(z)`` from summed pixel counts of a sphere of views (module docstring)."""
    area_share = areas / areas.sum()
    total = float(counts.sum())
    if n_views == 0 or total <= 0.0:
        return area_share
    pseudo = total / n_views  # one more view's pixels, spread over the faces by area
    return np.where(counts > 0, counts / total, pseudo * area_share / (total + pseudo))


class _Measuring:
    """The views of one search and their measuring by a session: the paper's four of each
    stage with one ``p(z)`` estimate, the others over the competing views."""

    def __init__(self, mesh: Mesh | PointCloud, camera: Camera, names: Sequence[str],
                 resolution: int) -> None:
        self.session = MeasuringSession(mesh, names,
                                        MeasureSettings(resolution=resolution, camera=camera))
        self.areas = self.session.areas
        total = float(self.areas.sum())
        if not total > 0.0:
            raise InputError(f"{mesh.name}: the mesh has zero surface area")
        self.face_probability = self.areas / total
        self.kept_directions = np.zeros((0, 3))
        self.kept_runs: list[ViewHistograms] = []

    def measure(self, directions: NDArray[np.float64], resolution: int, *,
                estimate_face_probability: bool = False, keep: bool = False,
                ) -> NDArray[np.float64]:
        """Raw measures ``(n, M)`` of the directions at ``resolution``; NaN where none is seen.

        With ``keep``, the views join the competing ones (drawn at the
        search's resolution) and the columns the session computes from the
        kept counts are left NaN here: :meth:`competing` measures them with
        the others.
        """
        session = self.session
        runs = list(session.draw(directions, resolution))
        if session.sum_columns and estimate_face_probability:
            counts = np.zeros(session.n_elements)
            for run in runs:
                counts += np.bincount(run.face_ids, weights=run.pixel_counts,
                                      minlength=session.n_elements)
            self.face_probability = _face_probability(counts, len(directions), self.areas)
        columns = list(session.sum_columns)
        if session.view_columns:
            if keep:
                first = len(self.kept_directions)
                self.kept_runs += [replace(run, first_view=first + run.first_view)
                                   for run in runs]
                self.kept_directions = np.concatenate([self.kept_directions, directions])
            else:
                columns += session.view_columns
        return session.measure(directions, resolution, histograms=runs, columns=columns,
                               face_probability=self.face_probability, require_seen=False)

    def competing(self, resolution: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Every competing view so far and its raw values ``(n, M)`` of the columns the
        session computes from the kept counts (the others NaN), measured over them together."""
        raw = self.session.measure(self.kept_directions, resolution, histograms=self.kept_runs,
                                   columns=self.session.view_columns, require_seen=False)
        return self.kept_directions, raw


def _confirm_candidates(directions: NDArray[np.float64], raw: NDArray[np.float64],
                        per_measure: int, higher_is_better: Sequence[bool],
                        ) -> NDArray[np.float64]:
    """The best ``per_measure`` coarse directions of each measure, distinct, rank by rank."""
    orders = [ranked_views(raw, column, higher_is_better) for column in range(raw.shape[1])]
    chosen: list[int] = []
    for rank in range(min(per_measure, len(directions))):
        for order in orders:
            if order[rank] not in chosen:
                chosen.append(int(order[rank]))
    return directions[chosen]


def search_best_views(
    mesh: MeshLike | PointCloud | Any,
    settings: SearchSettings = SearchSettings(),
    *,
    prior: ArrayLike | None = None,
    measures: str | Sequence[str] | None = None,
) -> BestViews:
    """Find the best view direction per measure within a budget of drawn views.

    Parameters
    ----------
    mesh : MeshLike, PointCloud or another model object
        The model, in any orientation: a Mesh, a ``trimesh.Trimesh``, an Open3D
        ``TriangleMesh`` or ``(vertices, faces)``, or a point cloud (a
        PointCloud, an ``(N, 3)`` / ``(N, 6)`` array, an Open3D or trimesh
        point cloud), as :func:`vptoolkit.io.objects.model_of` converts it. A
        cloud's points are splatted and searched as a mesh's faces are, for
        the measures defined on points
        (:func:`~vptoolkit.measures.registry.point_measures`).
    settings : SearchSettings, optional
        Budget, resolution, coarse pass and camera (default: ``SearchSettings()``:
        64 views, 128 px).
    prior : (k, 3) array_like, optional
        Candidate directions, most promising first, drawn first at
        ``resolution`` (an eighth of the budget, at least one view; e.g. from
        :class:`vptoolkit.best_view.prior.UnoccludedPrior` or
        :class:`vptoolkit.learn.prior.NetworkPrior`); each competes for
        every searched measure. No candidate (``(0, 3)``) is no prior.
    measures : str or sequence of str, optional
        The measures to search (:func:`searchable_measures`: ``None`` or
        ``"paper"`` for VE, VR, VKL and VMI, the default; names such as
        ``"NVT,SL"``; ``"all"`` names measures a search cannot evaluate and
        is refused).

    Returns
    -------
    BestViews
        Directions, raw values at ``resolution``, stages, seconds, cameras,
        one row per searched measure.

    Raises
    ------
    InputError
        On settings that are no SearchSettings, a bad prior, an
        unknown measure or one a search cannot evaluate, or a mesh that is
        none of the above or has zero surface area.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box(extents=(1, 2, 4))
    >>> found = search_best_views(box, SearchSettings(budget=16, resolution=64))
    >>> found.n_views, found.directions.shape, found.camera_pose("VE").shape
    (16, (4, 3), (4, 4))
    >>> search_best_views(box, SearchSettings(budget=16, resolution=64),
    ...                   measures="NVT,SL").measures
    ('NVT', 'SL')
    """
    started = time.perf_counter()
    names = searchable_measures(measures)
    mesh = model_of(mesh)
    chosen = check_search_settings(settings)
    budget, resolution, camera = chosen.budget, chosen.resolution, chosen.camera
    candidates = np.zeros((0, 3)) if prior is None else as_directions(prior, name="prior")
    band = chosen.elevation
    up = resting_up(mesh) if isinstance(chosen.up, str) else chosen.up
    if band is not None:
        candidates = into_band(candidates, up, band)
    n_prior = min(len(candidates), max(1, int(budget * _PRIOR_SHARE))) if len(candidates) else 0
    flat = budget < FLAT_BELOW
    n_coarse = chosen.coarse_views
    if n_coarse is None:
        n_coarse = budget - n_prior if flat else max(1, (budget - n_prior) // 2)
    elif n_prior:  # the settings checked it against the budget, not against what the prior leaves
        n_coarse = check_int_range(n_coarse, "coarse_views", 0, budget - n_prior)
    coarse_size = chosen.coarse_resolution
    if coarse_size is None:
        coarse_size = resolution if flat else min(resolution, COARSE_RESOLUTION)
    renderer = _Measuring(mesh, camera, names, resolution)
    higher = tuple(measure.higher_is_better for measure in renderer.session.measures)
    incumbents = _Incumbents.empty(higher)
    stages: list[SearchStage] = []
    drawn: list[NDArray[np.float64]] = []

    def draw(stage: str, directions: NDArray[np.float64], size: int, *,
             sphere: bool = False) -> NDArray[np.float64]:
        raw = renderer.measure(directions, size, estimate_face_probability=sphere,
                               keep=size == resolution)
        stages.append(SearchStage(stage, len(directions), size))
        drawn.append(directions)
        return raw

    def offer(directions: NDArray[np.float64], raw: NDArray[np.float64]) -> None:
        """Views drawn at ``resolution`` compete: the paper's four as measured, the
        registry's measured again with every competing view."""
        incumbents.offer(directions, raw, renderer.session.sum_columns)
        if renderer.session.view_columns:
            every, again = renderer.competing(resolution)
            incumbents.take_best(every, again, renderer.session.view_columns)

    if not n_coarse:
        sphere = np.zeros((0, 3))
    elif band is None:
        sphere = coarse_directions(mesh, n_coarse, renderer.areas)
    else:
        sphere = band_directions(n_coarse, up, band)
    if n_coarse:  # first: its views give p(z) for every later measurement
        coarse_raw = draw("coarse", sphere, coarse_size, sphere=True)
    if n_prior:
        offer(candidates[:n_prior], draw("prior", candidates[:n_prior], resolution))
    if n_coarse:
        if coarse_size == resolution:
            offer(sphere, coarse_raw)
        else:
            left = budget - n_prior - n_coarse
            again = _confirm_candidates(sphere, coarse_raw, _CONFIRM_PER_MEASURE,
                                        higher)[:left]
            if len(again):
                offer(again, draw("confirm", again, resolution))
    if not np.isfinite(incumbents.raw).any():
        raise MeasurementError(f"{mesh.name}: no face is visible from any view of the search")
    area = 4.0 * math.pi if band is None else 2.0 * math.pi * (
        math.sin(math.radians(band[1])) - math.sin(math.radians(band[0])))
    angle = _FIRST_STEP * math.sqrt(area / max(n_coarse, n_prior, 1))
    turn = 0.0
    while (left := budget - sum(stage.n_views for stage in stages)) > 0 \
            and math.degrees(angle) >= MIN_STEP_DEG:
        centres = incumbents.centres()
        rings = np.stack([ring(centre, angle, _RING, turn) for centre in centres], axis=1)
        proposals = rings.reshape(-1, 3)[:left]  # ring point by ring point, every centre in turn
        if band is not None:
            proposals = into_band(proposals, up, band)
        offer(proposals, draw("refine", proposals, resolution))
        angle *= 0.5
        turn += math.pi / _RING
    return BestViews(
        name=mesh.name,
        directions=incumbents.directions.copy(),
        raw=incumbents.raw.copy(),
        resolution=resolution,
        stages=tuple(_merge(stages)),
        seconds=time.perf_counter() - started,
        poses=camera.look_at(mesh, incumbents.directions, resolution=resolution),
        drawn=np.concatenate(drawn) if drawn else np.zeros((0, 3)),
        up=up,
        measures=names,
    )


def _merge(stages: Sequence[SearchStage]) -> list[SearchStage]:
    """Consecutive stages of one name and resolution as one (the refinement's rounds)."""
    merged: list[SearchStage] = []
    for stage in stages:
        if merged and merged[-1].name == stage.name and merged[-1].resolution == stage.resolution:
            merged[-1] = SearchStage(stage.name, merged[-1].n_views + stage.n_views,
                                     stage.resolution)
        else:
            merged.append(stage)
    return merged


