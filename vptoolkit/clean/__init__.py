"""Mesh cleaning: the paper's three-step pipeline, with numbers on what it changed.

Schelling et al. (2021, appendix "Mesh Cleaning Pipeline") clean every model
before measuring it, because self-intersections, hidden parts and uneven
tessellation distort the viewpoint quality measures (a face's area no longer
matches its potentially visible area, which changes ``A_t`` and ``A_z``).
:func:`clean_mesh` runs the same three steps by calling these public
functions in order, so ``simplify_mesh(remove_hidden_faces(repair_mesh(mesh)))``
(with the same options) gives the same mesh:

1. :func:`~vptoolkit.clean.repair.repair_mesh` -- remove null and duplicate
   faces, merge duplicate vertices, drop unreferenced vertices, repair
   non-manifold edges and vertices, and resolve self-intersections (see its
   Notes for how and why).
2. :func:`~vptoolkit.clean.hidden.remove_hidden_faces` -- drop the faces seen
   in none of the 1000 views (:func:`~vptoolkit.clean.hidden.hidden_faces`;
   the views, image side and camera are a
   :class:`~vptoolkit.settings.MeasureSettings`,
   :data:`~vptoolkit.clean.hidden.HIDDEN_SETTINGS` by default),
   e.g. passenger seats inside an airplane, and turn each remaining face
   towards the side it is seen from.
3. :func:`~vptoolkit.clean.simplify.simplify_mesh` -- quadric edge-collapse
   decimation to at most ``max_faces`` faces (the paper keeps models under
   10k faces), optionally followed by isotropic remeshing, then the removal
   of the intersections decimation created.

Each step returns a :class:`~vptoolkit.mesh.Mesh` that also says what the
step did (:class:`~vptoolkit.clean.repair.RepairedMesh`,
:class:`~vptoolkit.clean.hidden.VisibleMesh`,
:class:`~vptoolkit.clean.simplify.SimplifiedMesh`); the repaired mesh carries
what step 2 needs to see through the seams that removing intersecting faces
opened.

:class:`CleaningReport` records faces and vertices before and after each
step, self-intersections before and after, the hidden area removed and the
seconds per step; :meth:`CleaningReport.to_dict` gives JSON types.

The package is split along those steps: :mod:`~vptoolkit.clean.repair`,
:mod:`~vptoolkit.clean.hidden` and :mod:`~vptoolkit.clean.simplify`, with the
pure-numpy :mod:`~vptoolkit.clean.topology` and a private pymeshlab bridge
(``_meshlab``). This module holds :func:`clean_mesh`, which chains the steps,
and its report (:class:`CleaningReport`, :class:`StepReport`); each step's
names are imported from its own module (``from vptoolkit.clean.repair import
repair_mesh``).

pymeshlab is imported lazily (``pip install 'vptoolkit[clean]'``). A mesh that
cannot be cleaned raises :class:`~vptoolkit.errors.MeasurementError` whose
message starts with the mesh name; no step ever returns an empty mesh.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from vptoolkit.checks import check_bool, check_int
from vptoolkit.clean._meshlab import load_pymeshlab
from vptoolkit.clean.hidden import HIDDEN_SETTINGS, check_hidden_settings, remove_hidden_faces
from vptoolkit.clean.repair import SelfIntersectionMethod, check_method, repair_mesh
from vptoolkit.clean.simplify import MAX_FACES, simplify_mesh
from vptoolkit.errors import InputError
from vptoolkit.mesh import Mesh, MeshLike, as_mesh
from vptoolkit.settings import MeasureSettings

__all__ = ["StepReport", "CleaningReport", "clean_mesh"]

_STEP_NAMES = ("repair", "remove_hidden", "simplify")


@dataclass(frozen=True)
class StepReport:
    """Sizes and time of one cleaning step.

    Attributes
    ----------
    name : str
        ``"repair"``, ``"remove_hidden"`` or ``"simplify"``.
    faces_before, faces_after : int
        Number of triangles entering and leaving the step.
    vertices_before, vertices_after : int
        Number of vertices entering and leaving the step.
    seconds : float
        Wall-clock time of the step.
    """

    name: str
    faces_before: int
    faces_after: int
    vertices_before: int
    vertices_after: int
    seconds: float

    def to_dict(self) -> dict[str, str | int | float]:
        """Return the fields as a JSON-safe dict."""
        return {
            "name": self.name,
            "faces_before": int(self.faces_before),
            "faces_after": int(self.faces_after),
            "vertices_before": int(self.vertices_before),
            "vertices_after": int(self.vertices_after),
            "seconds": float(self.seconds),
        }


@dataclass(frozen=True)
class CleaningReport:
    """What :func:`clean_mesh` changed.

    Attributes
    ----------
    name : str
        The mesh name.
    steps : tuple of StepReport
        One entry per step, in order: ``repair``, ``remove_hidden``, ``simplify``.
    self_intersection_method : str
        What step 1 did about self-intersections: ``"none"`` (there were
        none), ``"union"``, ``"remove"`` or ``"union+remove"`` (see
        :func:`repair_mesh`).
    self_intersections_before : int
        Faces that pymeshlab's self-intersection test selects once duplicate
        vertices are merged (touching faces of an unmerged triangle soup would
        all count otherwise).
    self_intersections_after_repair : int
        The same count after step 1: zero unless ``max_rounds`` was 0.
    self_intersections_after : int
        The same count on the cleaned mesh. Decimation creates some; step 3
        removes them again (up to three rounds), so this is normally 0.
    hidden_area_removed : float
        Area of the faces removed in step 2, in model units squared.
    hidden_area_fraction : float
        ``hidden_area_removed`` over the area entering step 2.
    faces_flipped : int
        Faces reversed in step 2 because they were seen mostly from behind.
    """

    name: str
    steps: tuple[StepReport, ...]
    self_intersection_method: str
    self_intersections_before: int
    self_intersections_after_repair: int
    self_intersections_after: int
    hidden_area_removed: float
    hidden_area_fraction: float
    faces_flipped: int

    @property
    def faces_before(self) -> int:
        """Faces of the input mesh."""
        return self.steps[0].faces_before

    @property
    def faces_after(self) -> int:
        """Faces of the cleaned mesh."""
        return self.steps[-1].faces_after

    @property
    def seconds(self) -> float:
        """Total time of all steps."""
        return float(sum(step.seconds for step in self.steps))

    def step(self, name: str) -> StepReport:
        """Return the entry of the step called ``name``.

        Raises
        ------
        InputError
            If there is no step of that name.
        """
        for entry in self.steps:
            if entry.name == name:
                return entry
        raise InputError(f"name: no cleaning step {name!r}; steps are {', '.join(_STEP_NAMES)}")

    def to_dict(self) -> dict[str, Any]:
        """Return the report as JSON types only (str, int, float, list, dict).

        Returns
        -------
        dict
            The attributes, with ``steps`` as a list of dicts, plus
            ``faces_before``, ``faces_after`` and ``seconds``.
        """
        return {
            "name": self.name,
            "faces_before": int(self.faces_before),
            "faces_after": int(self.faces_after),
            "seconds": float(self.seconds),
            "self_intersection_method": self.self_intersection_method,
            "self_intersections_before": int(self.self_intersections_before),
            "self_intersections_after_repair": int(self.self_intersections_after_repair),
            "self_intersections_after": int(self.self_intersections_after),
            "hidden_area_removed": float(self.hidden_area_removed),
            "hidden_area_fraction": float(self.hidden_area_fraction),
            "faces_flipped": int(self.faces_flipped),
            "steps": [step.to_dict() for step in self.steps],
        }


def clean_mesh(
    mesh: MeshLike,
    *,
    max_faces: int = MAX_FACES,
    self_intersections: SelfIntersectionMethod = "auto",
    max_rounds: int = 5,
    settings: MeasureSettings = HIDDEN_SETTINGS,
    orient: bool = True,
    remesh: bool = False,
) -> tuple[Mesh, CleaningReport]:
    """Clean a mesh in the paper's three steps and report what changed.

    1. :func:`repair_mesh` (connectivity and self-intersections).
    2. Remove the faces seen in none of the ``settings.views`` views and turn the
       others towards the side they are seen from
       (:func:`remove_hidden_faces`). Removing intersecting faces in step 1
       can open seams through which buried parts become visible, so a face is
       also removed if the face it comes from was already hidden before the
       intersections were resolved.
    3. :func:`simplify_mesh` to at most ``max_faces`` faces.

    Parameters
    ----------
    mesh : MeshLike
        The raw mesh, e.g. a ModelNet40 model.
    max_faces : int
        Face budget of the result, at least 4 (default: 10000).
    self_intersections : {"auto", "remove"}
        How step 1 resolves self-intersections (default: "auto"; see
        :func:`~vptoolkit.clean.repair.repair_mesh`).
    max_rounds : int
        Rounds of removing intersecting faces and closing holes (default: 5).
    settings : MeasureSettings
        Views on the Fibonacci sphere, image side (at least 8), camera and
        backend of the hidden-face test (default:
        :data:`~vptoolkit.clean.hidden.HIDDEN_SETTINGS`: 1000 views at 256
        pixels).
    orient : bool
        In step 2, reverse the faces seen mostly from behind (default: True;
        see :func:`~vptoolkit.clean.hidden.remove_hidden_faces`).
    remesh : bool
        Also remesh isotropically in step 3 (default: False).

    Returns
    -------
    cleaned : Mesh
        The cleaned mesh, with the input's name and at most ``max_faces`` faces.
    report : CleaningReport
        Sizes and seconds per step, self-intersections before and after, and
        the hidden area removed.

    Raises
    ------
    InputError
        If ``mesh`` is not a mesh (:func:`~vptoolkit.mesh.as_mesh`) or an option is out of range.
    MissingDependencyError
        If pymeshlab is not installed.
    MeasurementError
        If a step fails or leaves no faces; the message starts with the mesh name.

    Examples
    --------
    >>> from vptoolkit.io import load_mesh
    >>> from vptoolkit.samples import sample_path
    >>> cleaned, report = clean_mesh(load_mesh(sample_path("bunny")), max_faces=2000)
    >>> cleaned.n_faces <= 2000, [step["name"] for step in report.to_dict()["steps"]]
    (True, ['repair', 'remove_hidden', 'simplify'])
    """
    mesh = as_mesh(mesh)
    max_faces = check_int(max_faces, "max_faces", minimum=4)
    max_rounds = check_int(max_rounds, "max_rounds", minimum=0)
    settings = check_hidden_settings(settings)
    check_method(self_intersections)
    orient = check_bool(orient, "orient")
    remesh = check_bool(remesh, "remesh")
    load_pymeshlab()

    start = time.perf_counter()
    repaired = repair_mesh(mesh, self_intersections=self_intersections, max_rounds=max_rounds)
    steps = [_step("repair", mesh, repaired, start)]
    start = time.perf_counter()
    visible = remove_hidden_faces(repaired, settings, orient=orient)
    steps.append(_step("remove_hidden", repaired, visible, start))
    start = time.perf_counter()
    simplified = simplify_mesh(visible, max_faces=max_faces, remesh=remesh)
    steps.append(_step("simplify", visible, simplified, start))

    report = CleaningReport(
        name=mesh.name,
        steps=tuple(steps),
        self_intersection_method=repaired.method,
        self_intersections_before=repaired.intersections_before,
        self_intersections_after_repair=repaired.intersections_after,
        self_intersections_after=simplified.intersections_after,
        hidden_area_removed=visible.hidden_area,
        hidden_area_fraction=visible.hidden_area_fraction,
        faces_flipped=visible.faces_flipped,
    )
    return simplified, report


def _step(name: str, before: Mesh, after: Mesh, start: float) -> StepReport:
    return StepReport(
        name=name,
        faces_before=before.n_faces,
        faces_after=after.n_faces,
        vertices_before=before.n_vertices,
        vertices_after=after.n_vertices,
        seconds=time.perf_counter() - start,
    )
