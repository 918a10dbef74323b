"""Benchmark of best-view answers for a point cloud: which to use when all you have is points.

Every answer sees a rotated cloud of a model and returns one direction per
measure in the cloud's frame; the direction is turned back by the cloud's
rotation ``R_k`` (``d R_k``) and scored against the labels of the model's
cleaned mesh the authors' way: the normalised quality of the nearest
labelled view, in % (:meth:`vptoolkit.data.ViewpointDataset.quality_of`),
mean over the rotations, then mean ± standard error over models
(:class:`vptoolkit.evaluate.protocol.ProtocolScores`). Two kinds of cloud,
one table each: ``uniform`` (area-uniform surface points with their normals)
and ``scan`` (a virtual scan, :func:`vptoolkit.scan.virtual_scan`: partial,
noisy, uneven).

Answers (rows):

* ``vptool best-view CLOUD``: :func:`vptoolkit.best_view.search.search_best_views`
  of a :class:`vptoolkit.point_cloud.PointCloud` with the default
  ``SearchSettings()`` (64 views, 128 px), as the command runs it;
* anytime point search N @ R: the same search with ``SearchSettings(budget=N,
  resolution=R)`` (the default's budget and resolution are its row);
* flat point search N @ R: the splat visibility of the cloud
  (:class:`vptoolkit.visibility.splats.PointScene`) over N Fibonacci
  directions (:func:`vptoolkit.sphere.fibonacci_sphere`) at R px, the paper's
  four measures from its histograms with the points' areas as the surface
  (:func:`vptoolkit.measures.sums.quality_from_histograms`,
  :func:`vptoolkit.point_areas.point_areas`), the best view per measure;
* a reconstruction, then the default search of the mesh it makes (the time
  includes the reconstruction): Open3D's screened Poisson
  (``TriangleMesh.create_from_point_cloud_poisson``, depth 8, the cloud's
  normals, the vertices of density below the :data:`POISSON_CROP` quantile
  removed) and ball pivoting (radii 1, 2 and 4 times the mean
  nearest-neighbour distance). A reconstruction that makes no usable mesh
  scores the model's random-view expectation, counted below the table;
* the network of coordinates alone (the bundled ``points`` checkpoint,
  :func:`vptoolkit.learn.predict.network_predictor`);
* the occlusion-free estimate from the cloud's normals
  (:func:`vptoolkit.measures.unoccluded.unoccluded_best_views`, equal areas);
* Open3D's hidden point removal over N Fibonacci directions: the camera at
  the cloud's centre plus the direction times the bounding-box diameter, the
  radius a hundred diameters, the direction that keeps the most points, one
  view for every measure (the loop a user writes from Open3D's tutorial);
* the PCA axis (:func:`vptoolkit.evaluate.baselines.pca_directions`) and a
  random view (:func:`vptoolkit.evaluate.protocol.random_view_scores`, an
  expectation);
* for reference, the cleaned mesh itself: its search at the same budgets
  (``search_best_views(mesh turned by R_k, SearchSettings(budget=N))``) and
  the plain 16-view search at 32 px
  (:func:`vptoolkit.measures.quality.compute_view_quality` on 16 Fibonacci
  views), the same numbers in both tables.

Cost: the median wall time per cloud (per mesh for the mesh rows) in ms on
this machine, the cloud in memory; each answer's first call in a run is made
twice and timed the second time (numba's kernels compile, torch loads).
Below each table, the default cloud search minus the network, the largest
hidden point removal and the mesh's plain 16-view search at 32 px, paired
over models (:func:`vptoolkit.evaluate.protocol.paired_difference`).

Resuming
    With ``--scores DIR`` every answer's scores and seconds of each (model,
    rotation, cloud kind) are appended to ``DIR/scores.jsonl`` as they are
    computed, and a rerun computes only what is missing there; the cases run
    rotation-major (rotation 0 of every model, then rotation 1, ...), so a
    run stopped early covers every model. The tables are made of the cases
    whose every row is stored (``--report-only``: from the store alone,
    computing nothing), each model's mean over its stored rotations.

Data
    A point benchmark folder of ``tools/make_point_benchmark_data.py``
    (``manifest.json``, ``labels/`` and ``clouds/<name>_r<k>_{uniform,scan}.npz``),
    or any folder of meshes: then the labels are built once under ``--cache``
    (:func:`bench_best_view.labels`) and the clouds are drawn from each turned
    cleaned mesh (:func:`vptoolkit.points.sample_surface`,
    :func:`vptoolkit.scan.virtual_scan`) under ``--rotations`` fixed rotations.

Usage::

    python tools/bench_point_clouds.py --quick --models 2           # a smoke test, a minute
    python tools/bench_point_clouds.py BENCH_FOLDER --scores SCORES_DIR \\
        --results docs/results.md --section point_clouds
    python tools/bench_point_clouds.py BENCH_FOLDER --scores SCORES_DIR --report-only \\
        --results docs/results.md --section point_clouds   # the tables of what is stored
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np
from bench_best_view import labels
from results_doc import (
    add_results_option,
    command_line,
    comparison_table,
    format_seconds,
    machine,
    markdown_table,
    score_cells,
    write_section,
)

from vptoolkit.best_view.search import BUDGET, SEARCH_RESOLUTION, SearchSettings, search_best_views
from vptoolkit.data import ViewpointDataset, open_dataset
from vptoolkit.errors import InputError, MeasurementError, VptoolkitError
from vptoolkit.evaluate.baselines import pca_directions
from vptoolkit.evaluate.protocol import ProtocolScores, random_view_scores
from vptoolkit.learn.draws import N_INPUTS
from vptoolkit.measures.quality import compute_view_quality, normalize_quality
from vptoolkit.measures.sums import quality_from_histograms
from vptoolkit.measures.unoccluded import unoccluded_best_views
from vptoolkit.mesh import Mesh
from vptoolkit.point_areas import point_areas
from vptoolkit.point_cloud import PointCloud
from vptoolkit.points import N_SURFACE_POINTS, sample_surface
from vptoolkit.progress import progress_bar
from vptoolkit.rotations import fixed_rotations, model_key
from vptoolkit.scan import SCAN_RESOLUTION, virtual_scan
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere

SAMPLES = Path(__file__).resolve().parent.parent / "vptoolkit" / "samples"
KINDS = ("uniform", "scan")
MESH_KIND = "mesh"  # the store's kind of the rows that search the cleaned mesh itself
POINTS_NETWORK = "points"  # the bundled checkpoint that reads coordinates alone
SCANNERS = 3  # scanners of a drawn virtual scan, as tools/make_point_benchmark_data.py
POISSON_DEPTH = 8  # octree depth of the Poisson reconstruction
POISSON_CROP = 0.05  # quantile of the Poisson densities below which vertices are removed
PIVOT_RADII = (1.0, 2.0, 4.0)  # ball-pivoting radii, in mean nearest-neighbour distances
PLAIN = (16, 32)  # views and px of the mesh's plain search, the default cloud search's target
DEFAULT_ROW = (f"`vptool best-view CLOUD` (SearchSettings(): {BUDGET} views @ "
               f"{SEARCH_RESOLUTION})")
README_SECTION = "readme_point_clouds"  # the section of --readme that readme_table fills
FEW_VIEWS = 8  # the budget of the README's many-clouds row
SCORES_FILE = "scores.jsonl"
SETTINGS_FILE = "settings.json"

Cloud = tuple[np.ndarray, np.ndarray]  # points (n, 3), normals (n, 3), float64
CloudAnswer = Callable[[np.ndarray, np.ndarray, str], "np.ndarray | None"]
MeshAnswer = Callable[[Mesh], np.ndarray]


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source", nargs="?", type=Path, default=SAMPLES,
                        help="a point benchmark folder (manifest.json, labels/, clouds/) or a "
                             "folder of meshes (default: the bundled samples)")
    parser.add_argument("--cache", type=Path, default=Path("reproduction/bench_point_clouds"),
                        help="where the labels of a mesh folder are built once")
    parser.add_argument("--scores", type=Path,
                        help="keep every computed score here (scores.jsonl) and compute only "
                             "what it lacks (default: none, nothing kept)")
    parser.add_argument("--report-only", action="store_true",
                        help="compute nothing: the tables of the cases --scores holds in full")
    parser.add_argument("--models", type=int, help="take the first N models (default: all)")
    parser.add_argument("--budgets", default=f"8,16,{BUDGET}",
                        help=f"views of the point and mesh searches (default: 8,16,{BUDGET})")
    parser.add_argument("--hpr-views", default="16,100",
                        help="directions of the hidden point removal search (default: 16,100)")
    parser.add_argument("--resolution", type=int, default=SEARCH_RESOLUTION,
                        help=f"px of the searches (default: {SEARCH_RESOLUTION})")
    parser.add_argument("--rotations", type=int, default=4,
                        help="fixed rotations per model: drawn for a mesh folder, the first "
                             "ones stored for a benchmark folder (default: 4)")
    parser.add_argument("--network-inputs", type=int, default=N_INPUTS,
                        help=f"inputs of the network per cloud, their consensus answers "
                             f"(default: {N_INPUTS}, as vptool predict)")
    add_results_option(parser, "point_clouds")
    parser.add_argument("--readme", type=Path,
                        help="also write the short table of which answer to use for a cloud "
                             f"into the {README_SECTION} section of this file (README.md)")
    parser.add_argument("--json", type=Path, help="write every row's numbers here")
    parser.add_argument("--quick", action="store_true",
                        help="a mesh folder's labels at 100 views and 64 px, 1 rotation, "
                             "2000-point clouds, 64 px scans, budgets 8 and 16 at 64 px, "
                             "2 network inputs")
    args = parser.parse_args(argv)
    try:
        args.budget_list = [int(b) for b in args.budgets.split(",")]
        args.hpr_list = [int(b) for b in args.hpr_views.split(",")]
    except ValueError:
        parser.error("--budgets, --hpr-views: expected integers separated by commas")
    if not args.budget_list or not args.hpr_list or min(args.budget_list + args.hpr_list) < 1:
        parser.error("--budgets, --hpr-views: every count must be at least 1")
    if (min(args.rotations, args.resolution, args.network_inputs) < 1
            or (args.models is not None and args.models < 1)):
        parser.error("--rotations, --resolution, --network-inputs and --models must be at least 1")
    if not args.source.is_dir():
        parser.error(f"{args.source}: not a folder")
    if args.scores is not None and args.scores.exists() and not args.scores.is_dir():
        parser.error(f"--scores: {args.scores} is not a folder")
    if args.report_only and args.scores is None:
        parser.error("--report-only: give --scores, the folder to report")
    for option, path in (("--results", args.results), ("--readme", args.readme)):
        if path is not None and path.exists() and not path.is_file():
            parser.error(f"{option}: {path} is not a file")
    if args.quick:
        args.budget_list, args.rotations, args.resolution, args.network_inputs = [8, 16], 1, 64, 2
    return args


# --------------------------------------------------------------------------- data


@dataclass(frozen=True)
class Case:
    """One model under one rotation: the turned cleaned mesh and its clouds.

    ``row`` is the model's row in the scored dataset, ``index`` the rotation's
    number; ``rotation`` turns rows as ``v @ rotation.T``, so a direction
    ``d`` of the turned frame is ``d @ rotation`` in the model's.
    """

    row: int
    name: str
    index: int
    rotation: np.ndarray
    mesh: Mesh
    clouds: dict[str, Cloud]


CaseKey = tuple[int, str, int]  # row in the dataset, model name, rotation number


def case_keys(dataset: ViewpointDataset, rotations: int) -> list[CaseKey]:
    """Every (row, name, rotation) of the run, rotation-major: rotation 0 of every model first."""
    return [(row, name, k) for k in range(rotations) for row, name in enumerate(dataset.names)]


def turned_mesh(dataset: ViewpointDataset, row: int, rotation: np.ndarray) -> Mesh:
    """The stored cleaned mesh of ``row`` turned by ``rotation``."""
    vertices, faces = dataset.mesh(row)
    return Mesh(np.asarray(vertices, np.float64) @ rotation.T, np.asarray(faces, np.int64),
                name=dataset.names[row])


def benchmark_case(folder: Path, dataset: ViewpointDataset, key: CaseKey) -> Case:
    """One case of a point benchmark folder: its stored clouds of the model and rotation."""
    row, name, k = key
    clouds = {}
    for kind in KINDS:
        path = folder / "clouds" / f"{name}_r{k}_{kind}.npz"
        if not path.is_file():
            raise InputError(f"{path}: missing; the benchmark folder has no {kind} cloud "
                             f"of {name} under rotation {k}")
        with np.load(path, allow_pickle=False) as arrays:
            clouds[kind] = (np.asarray(arrays["points"], np.float64),
                            np.asarray(arrays["normals"], np.float64))
            rotation = np.asarray(arrays["rotation"], np.float64)
    return Case(row, name, k, rotation, turned_mesh(dataset, row, rotation), clouds)


def drawn_case(dataset: ViewpointDataset, key: CaseKey, rotations: int, *, n_points: int,
               scan_resolution: int) -> Case:
    """A case of a mesh folder: the turned cleaned mesh's uniform sample and virtual scan."""
    row, name, k = key
    rotation = fixed_rotations(name, rotations)[k]
    mesh = turned_mesh(dataset, row, rotation)
    uniform = sample_surface(mesh, n_points, seed=k)
    scan = virtual_scan(mesh, SCANNERS, resolution=scan_resolution,
                        seed=(model_key(name) + k) % 2**63)
    return Case(row, name, k, rotation, mesh,
                {"uniform": (uniform.points, uniform.normals), "scan": scan})


# --------------------------------------------------------------------------- answers


def point_search(points: np.ndarray, normals: np.ndarray, n_views: int,
                 resolution: int) -> np.ndarray:
    """The flat point search: each measure's best of ``n_views`` Fibonacci views of the splats.

    Returns
    -------
    directions : (4, 3) float64
        VE, VR, VKL, VMI, in the cloud's frame.
    """
    from vptoolkit.visibility.splats import PointScene

    directions = fibonacci_sphere(n_views)
    scene = PointScene(points, normals)
    raw = quality_from_histograms(scene.histograms(directions, resolution), point_areas(points),
                                  n_views=n_views)
    return np.asarray(directions[np.argmax(normalize_quality(raw), axis=0)])


def hidden_point_removal_search(points: np.ndarray, n_views: int) -> np.ndarray:
    """Open3D's hidden point removal from ``n_views`` Fibonacci cameras: the one that sees most.

    Returns
    -------
    direction : (1, 3) float64
        One direction for every measure, in the cloud's frame.
    """
    import open3d as o3d

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    diameter = float(np.linalg.norm(cloud.get_max_bound() - cloud.get_min_bound()))
    centre = cloud.get_center()
    directions = fibonacci_sphere(n_views)
    seen = [len(cloud.hidden_point_removal(centre + direction * diameter, diameter * 100)[1])
            for direction in directions]
    return np.asarray(directions[int(np.argmax(seen))][None])


def reconstruction(points: np.ndarray, normals: np.ndarray, name: str, method: str) -> Mesh:
    """A mesh of the cloud by Open3D: ``"poisson"`` or ``"pivoting"`` (see the module docstring).

    Raises
    ------
    InputError
        The reconstruction made no mesh with a surface
        (:class:`vptoolkit.mesh.Mesh`'s checks).
    """
    import open3d as o3d

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    cloud.normals = o3d.utility.Vector3dVector(normals)
    if method == "poisson":
        made, densities = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(
            cloud, depth=POISSON_DEPTH)
        density = np.asarray(densities)
        if len(density):
            made.remove_vertices_by_mask(density < np.quantile(density, POISSON_CROP))
    else:
        spacing = float(np.mean(np.asarray(cloud.compute_nearest_neighbor_distance())))
        made = o3d.geometry.TriangleMesh.create_from_point_cloud_ball_pivoting(
            cloud, o3d.utility.DoubleVector([spacing * r for r in PIVOT_RADII]))
    return Mesh(np.asarray(made.vertices, np.float64), np.asarray(made.triangles, np.int64),
                name=name)


def reconstructed_search(method: str) -> CloudAnswer:
    """The default search of the cloud's reconstruction; None where the reconstruction fails."""
    def answer(points: np.ndarray, normals: np.ndarray, name: str) -> np.ndarray | None:
        try:
            return search_best_views(reconstruction(points, normals, name, method),
                                     SearchSettings()).directions
        except (InputError, MeasurementError):
            return None

    return answer


def cloud_answers(budgets: list[int], hpr_views: list[int], resolution: int,
                  network_inputs: int) -> dict[str, tuple[str, CloudAnswer]]:
    """Row label -> (views drawn, answer on a cloud), in table order."""
    from vptoolkit.learn.predict import network_predictor

    network = network_predictor(POINTS_NETWORK, n_inputs=network_inputs)

    def flat(budget: int) -> CloudAnswer:
        return lambda points, normals, name: point_search(points, normals, budget, resolution)

    def searched(settings: SearchSettings) -> CloudAnswer:
        return lambda points, normals, name: search_best_views(
            PointCloud(points, normals, name=name), settings).directions

    def removal(views: int) -> CloudAnswer:
        return lambda points, normals, name: hidden_point_removal_search(points, views)

    rows: dict[str, tuple[str, CloudAnswer]] = {
        DEFAULT_ROW: (str(BUDGET), searched(SearchSettings()))}
    for budget in budgets:
        if (budget, resolution) != (BUDGET, SEARCH_RESOLUTION):
            rows[f"anytime point search {budget} @ {resolution}"] = (
                str(budget), searched(SearchSettings(budget=budget, resolution=resolution)))
    for budget in budgets:
        rows[f"flat point search {budget} @ {resolution}"] = (str(budget), flat(budget))
    default_search = f"{BUDGET} @ {SEARCH_RESOLUTION}"
    rows[f"Poisson depth {POISSON_DEPTH} + mesh search {default_search}"] = (
        str(BUDGET), reconstructed_search("poisson"))
    rows[f"ball pivoting + mesh search {default_search}"] = (
        str(BUDGET), reconstructed_search("pivoting"))
    rows["network of coordinates alone"] = (
        "–", lambda points, normals, name: network([points], [name])[0])
    rows["unoccluded estimate, normals"] = (
        "–", lambda points, normals, name: unoccluded_best_views(normals))
    for views in hpr_views:
        rows[f"Open3D hidden point removal, {views} views"] = (str(views), removal(views))
    rows["PCA axis"] = ("–", lambda points, normals, name: pca_directions([points],
                                                                          n_measures=1)[0])
    return rows


def mesh_answers(budgets: list[int], resolution: int) -> dict[str, tuple[str, MeshAnswer]]:
    """Row label -> (views drawn, the search on the mesh), the reference rows."""
    def searched(budget: int) -> MeshAnswer:
        return lambda mesh: search_best_views(
            mesh, SearchSettings(budget=budget, resolution=resolution)).directions

    views, px = PLAIN
    rows: dict[str, tuple[str, MeshAnswer]] = {
        f"plain search {views} @ {px} (the mesh itself)": (str(views), lambda mesh: (
            compute_view_quality(mesh, MeasureSettings(views=views, resolution=px)).best_views))}
    for budget in budgets:
        rows[f"mesh search {budget} @ {resolution} (the mesh itself)"] = (str(budget),
                                                                          searched(budget))
    return rows


# --------------------------------------------------------------------------- the store


class ScoreStore:
    """Each answer's scores (4 measures, %) and seconds per (model, rotation, kind), kept.

    Entries live in memory and, with a folder, are appended to
    ``folder/scores.jsonl`` one JSON line each as they are computed:
    ``{"model", "rotation", "kind", "row", "scores", "seconds", "load"}``,
    ``scores`` null where the answer made none (a failed reconstruction),
    ``load`` the machine's 1-minute load average when it was done. The folder's
    ``settings.json`` records what the rows' labels do not name (the source,
    the network's inputs, quick), and a folder of other settings is refused.
    """

    def __init__(self, folder: Path | None, settings: dict[str, Any]) -> None:
        self.entries: dict[tuple[str, int, str, str], tuple[np.ndarray, float]] = {}
        self.loads: dict[tuple[str, int, str, str], float] = {}
        self.path: Path | None = None
        if folder is None:
            return
        self.path = path = folder / SCORES_FILE
        folder.mkdir(parents=True, exist_ok=True)
        recorded = folder / SETTINGS_FILE
        if recorded.is_file():
            stored = json.loads(recorded.read_text(encoding="utf-8"))
            if stored != settings:
                raise InputError(f"{recorded}: scores of other settings ({stored}, here "
                                 f"{settings}); give another --scores folder")
        else:
            recorded.write_text(json.dumps(settings, indent=2) + "\n", encoding="utf-8")
        if path.is_file():
            text = path.read_text(encoding="utf-8")
            for line in text.splitlines():
                try:
                    entry = json.loads(line)
                    key = (entry["model"], int(entry["rotation"]), entry["kind"], entry["row"])
                    values = [np.nan if v is None else float(v)
                              for v in (entry["scores"] or [None] * 4)]
                    self.entries[key] = (np.asarray(values), float(entry["seconds"]))
                    if entry.get("load") is not None:
                        self.loads[key] = float(entry["load"])
                except (ValueError, KeyError, TypeError):
                    continue  # a line cut short when a run was stopped
            if text and not text.endswith("\n"):
                with path.open("a", encoding="utf-8") as stream:
                    stream.write("\n")

    def has(self, name: str, rotation: int, kind: str, row: str) -> bool:
        return (name, rotation, kind, row) in self.entries

    def add(self, name: str, rotation: int, kind: str, row: str, scores: np.ndarray,
            seconds: float) -> None:
        key = (name, rotation, kind, row)
        self.entries[key] = (scores, seconds)
        self.loads[key] = load = os.getloadavg()[0]
        if self.path is not None:
            cells = [None if not np.isfinite(v) else float(v) for v in scores]
            line = json.dumps({"model": name, "rotation": rotation, "kind": kind, "row": row,
                               "scores": None if all(c is None for c in cells) else cells,
                               "seconds": seconds, "load": round(load, 2)})
            with self.path.open("a", encoding="utf-8") as stream:
                stream.write(line + "\n")


def timed_score(dataset: ViewpointDataset, case: Case, answer: Callable[[], Any],
                ) -> tuple[np.ndarray, float]:
    """Run ``answer``; its scores in % per measure after turning back (NaN where it gave
    None), and its seconds."""
    started = time.perf_counter()
    found = answer()
    seconds = time.perf_counter() - started
    if found is None:
        return np.full(len(dataset.measures), np.nan), seconds
    directions = np.broadcast_to(np.asarray(found, np.float64), (len(dataset.measures), 3))
    return 100.0 * np.diagonal(dataset.quality_of(case.row, directions @ case.rotation)), seconds


def compute(dataset: ViewpointDataset, keys: list[CaseKey], load: Callable[[CaseKey], Case],
            clouds: dict[str, tuple[str, CloudAnswer]], meshes: dict[str, tuple[str, MeshAnswer]],
            store: ScoreStore) -> None:
    """Score every row of every case the store lacks, in the order of ``keys``."""
    def missing(key: CaseKey) -> list[tuple[str, str]]:
        _, name, k = key
        wanted = [(kind, label) for kind in KINDS for label in clouds]
        wanted += [(MESH_KIND, label) for label in meshes]
        return [(kind, label) for kind, label in wanted if not store.has(name, k, kind, label)]

    todo = [(key, rows) for key in keys if (rows := missing(key))]
    warmed: set[str] = set()
    with progress_bar(total=len(todo), description="clouds", unit="case") as bar:
        for key, rows in todo:
            case = load(key)
            for kind, label in rows:
                if kind == MESH_KIND:
                    mesh_answer = meshes[label][1]
                    answer: Callable[[], Any] = lambda: mesh_answer(case.mesh)  # noqa: E731
                else:
                    points, normals = case.clouds[kind]
                    cloud_answer = clouds[label][1]
                    answer = lambda: cloud_answer(points, normals, case.name)  # noqa: E731
                if label not in warmed:  # numba's kernels compile, torch loads: untimed
                    answer()
                    warmed.add(label)
                store.add(case.name, case.index, kind, label, *timed_score(dataset, case, answer))
            bar.update(1)


# --------------------------------------------------------------------------- report


@dataclass
class Covered:
    """The rows' scores over the cases whose every row is stored."""

    dataset: ViewpointDataset  # the models with at least one complete case
    rotations: dict[str, list[int]]  # model -> its complete rotations
    scores: dict[str, dict[str, ProtocolScores]]  # kind (or MESH_KIND) -> row -> scores
    ms: dict[str, dict[str, float]]  # kind -> row -> median ms per call
    failures: dict[str, dict[str, int]]  # kind -> row -> calls that gave no answer
    loads: list[float]  # the 1-minute load averages recorded with the covered scores


def covered(dataset: ViewpointDataset, keys: list[CaseKey], store: ScoreStore,
            rows: dict[str, list[str]]) -> Covered | None:
    """Every row's scores over the complete cases (None when there is none).

    A model's score is the mean over its complete rotations; where an answer
    gave none, the model's random-view expectation stands in, counted in
    ``failures``.
    """
    complete: dict[str, list[int]] = {}
    for _, name, k in keys:
        if all(store.has(name, k, kind, label) for kind, row_labels in rows.items()
               for label in row_labels):
            complete.setdefault(name, []).append(k)
    if not complete:
        return None
    names = [name for name in dataset.names if name in complete]
    subset = dataset.subset(names)
    random = random_view_scores(subset).scores
    fewest = min(len(ks) for ks in complete.values())
    scores: dict[str, dict[str, ProtocolScores]] = {}
    ms: dict[str, dict[str, float]] = {}
    failures: dict[str, dict[str, int]] = {}
    loads = [store.loads[key] for key in store.loads
             if key[0] in complete and key[1] in complete[key[0]]]
    for kind, row_labels in rows.items():
        scores[kind], ms[kind], failures[kind] = {}, {}, {}
        for label in row_labels:
            totals = np.zeros((len(names), len(dataset.measures)))
            seconds: list[float] = []
            failed = 0
            for i, name in enumerate(names):
                for k in complete[name]:
                    values, spent = store.entries[(name, k, kind, label)]
                    if not np.isfinite(values).all():
                        failed += 1
                        values = np.where(np.isfinite(values), values, random[i])
                    totals[i] += values
                    seconds.append(spent)
                totals[i] /= len(complete[name])
            scores[kind][label] = ProtocolScores(tuple(names), tuple(subset.categories), totals,
                                                 fewest, dataset.measures)
            ms[kind][label] = 1000.0 * float(np.median(seconds))
            failures[kind][label] = failed
    return Covered(subset, complete, scores, ms, failures, loads)


def kind_section(kind: str, rows: dict[str, tuple[str, ProtocolScores, float | None]],
                 reference: str, rivals: list[str], failures: dict[str, int]) -> list[str]:
    """The markdown of one cloud kind: its table and the paired differences of ``reference``."""
    lines = [f"### {kind} clouds", ""]
    lines += markdown_table(
        ["answer", "VE", "VR", "VKL", "VMI", "views", "ms per cloud"],
        ([label, *score_cells(scores), views, "–" if ms is None else f"{ms:.0f}"]
         for label, (views, scores, ms) in rows.items()))
    failed = [f"{label} {count}" for label, count in failures.items() if count]
    if failed:
        lines += ["", "Answers that made no mesh, scored as a random view (cases): "
                  + "; ".join(failed) + "."]
    lines += ["", "Paired over models, difference ± standard error in points (* beyond two "
              "standard errors):", ""]
    lines += comparison_table({label: rows[label][1] for label in [reference, *rivals]},
                              reference)
    return lines + [""]


def coverage_line(result: Covered, n_models: int, rotations: int) -> str:
    """How many models and rotations the tables cover."""
    counts = [len(ks) for ks in result.rotations.values()]
    n_cases = sum(counts)
    spread = (f"{min(counts)} rotation{'' if min(counts) == 1 else 's'} each"
              if min(counts) == max(counts) else
              f"{min(counts)} to {max(counts)} rotations each "
              f"({counts.count(max(counts))} models with {max(counts)})")
    return (f"{n_cases} of {n_models * rotations} cases complete ({n_models} models x "
            f"{rotations} fixed rotations): {len(counts)} models, {spread}")


def readme_table(numbers: dict[str, dict[str, Any]], coverage: str, source: str) -> str:
    """The README's table of which answer to use for a point cloud, from one run's rows.

    Parameters
    ----------
    numbers : dict
        Cloud kind -> row label -> ``{"mean": [VE, VR, VKL, VMI] in %, "ms": median ms or
        None}``, as ``--json`` writes them. Rows the run lacks (the 8-view search
        at another resolution than the command's) are left out of the table.
    coverage : str
        Which models and rotations the numbers cover, for the text.
    source : str
        The run: its command, date and machine, quoted under the table.
    """
    uniform, scan = numbers["uniform"], numbers["scan"]
    wanted = [
        ("one cloud, or a few", f"`vptool best-view cloud.ply` ({BUDGET} views)",
         DEFAULT_ROW),
        ("a million clouds", f"`vptool best-view cloud.ply --views {FEW_VIEWS}`",
         f"anytime point search {FEW_VIEWS} @ {SEARCH_RESOLUTION}"),
        ("points with normals, without drawing",
         "`vptool predict -m unoccluded cloud.npy` (x y z nx ny nz)",
         "unoccluded estimate, normals"),
        ("points without normals, without drawing",
         "`vptool predict -m points cloud.npy`: the network of coordinates alone",
         "network of coordinates alone"),
        ("time for a reconstruction", f"Open3D's Poisson (depth {POISSON_DEPTH}), then "
         "`vptool best-view mesh.ply`", f"Poisson depth {POISSON_DEPTH} + mesh search "
         f"{BUDGET} @ {SEARCH_RESOLUTION}"),
        ("for comparison", "Open3D's hidden point removal from 100 directions, the one "
         "that sees most", "Open3D hidden point removal, 100 views"),
        ("the mesh itself", f"`vptool best-view mesh.ply` ({BUDGET} views)",
         f"mesh search {BUDGET} @ {SEARCH_RESOLUTION} (the mesh itself)"),
    ]

    def mean(row: dict[str, Any]) -> str:
        return " / ".join(f"{value:.1f}" for value in row["mean"])

    table = markdown_table(
        ["you have", "use", "uniform cloud", "scan", "ms (uniform / scan)"],
        ([have, use, mean(uniform[label]), mean(scan[label]),
          f"{uniform[label]['ms']:.0f} / {scan[label]['ms']:.0f}"]
         for have, use, label in wanted if label in uniform), align="lllll")
    return "\n".join([
        f"For a point cloud, {coverage}: each answer sees the rotated uniform cloud "
        "(area-uniform points with normals) and a virtual scan (partial, noisy, uneven), "
        "scored against the labels of the model's cleaned mesh as above (VE / VR / VKL / "
        "VMI), and its median time per cloud, the cloud in memory ([the whole "
        "tables](docs/results.md#point-clouds-which-answer)):",
        "",
        *table,
        "",
        f"A random view scores {mean(uniform['random view (expectation)'])}.",
        "",
        f"From {source}.",
    ])


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    started = time.perf_counter()
    is_benchmark = (args.source / "manifest.json").is_file()
    try:
        if is_benchmark:
            manifest = json.loads((args.source / "manifest.json").read_text(encoding="utf-8"))
            rotations = min(args.rotations, int(manifest["rotations"]))
            full = open_dataset(args.source / manifest["labels"])
        else:
            rotations = args.rotations
            full = open_dataset(labels(args.source, args.cache, quick=args.quick) / "build")
        names = full.names[: args.models] if args.models else full.names
        dataset = full.subset(names)
        store = ScoreStore(args.scores, {"source": str(args.source.resolve()),
                                         "network_inputs": args.network_inputs,
                                         "quick": args.quick})

        def load(key: CaseKey) -> Case:
            if is_benchmark:
                return benchmark_case(args.source, dataset, key)
            return drawn_case(dataset, key, rotations,
                              n_points=2000 if args.quick else N_SURFACE_POINTS,
                              scan_resolution=64 if args.quick else SCAN_RESOLUTION)

        keys = case_keys(dataset, rotations)
        clouds = cloud_answers(args.budget_list, args.hpr_list, args.resolution,
                               args.network_inputs)
        meshes = mesh_answers(args.budget_list, args.resolution)
        if not args.report_only:
            compute(dataset, keys, load, clouds, meshes, store)
        result = covered(dataset, keys, store,
                         {**{kind: list(clouds) for kind in KINDS}, MESH_KIND: list(meshes)})
        if result is None:
            raise InputError(f"{args.scores}: no case has every row stored yet")
    except VptoolkitError as error:
        print(f"bench_point_clouds: error: {error}", file=sys.stderr)
        return 2

    reference = DEFAULT_ROW
    rivals = ["network of coordinates alone",
              f"Open3D hidden point removal, {max(args.hpr_list)} views",
              f"plain search {PLAIN[0]} @ {PLAIN[1]} (the mesh itself)"]
    where = (f"`{args.source.name}/`" if args.source != SAMPLES else "the bundled samples")
    ran = ("tables from the stored scores" if args.report_only else
           f"wall time {format_seconds(time.perf_counter() - started)}")
    lines = [
        f"## Best views of point clouds, {where}",
        "",
        f"Command: `{command_line(__file__, argv)}`; {datetime.now(timezone.utc):%Y-%m-%d}, "
        f"{machine()}; {ran}.",
        "",
        f"{coverage_line(result, len(dataset), rotations)}; labels: cleaned mesh, "
        f"{len(dataset.views)} views at {dataset.attrs.get('resolution', '?')} px. Each answer "
        "sees the rotated cloud, is turned back and scores the normalised quality of the "
        "nearest labelled view, in %, mean over the model's rotations, then mean ± standard "
        "error over models; ms: median per cloud (per mesh for the mesh rows) on this "
        "machine, the cloud in memory, the reconstruction rows' time including the "
        f"reconstruction (Poisson: vertices below the {POISSON_CROP:.0%} density quantile "
        f"removed; ball pivoting: radii {', '.join(f'{r:g}' for r in PIVOT_RADII)} x the mean "
        "nearest-neighbour distance). The mesh rows search the cleaned mesh itself, for "
        "reference; they are the same in both tables.",
        "",
    ]
    if result.loads:
        low, middle, high = np.percentile(result.loads, [0, 50, 100])
        lines += [f"The machine's 1-minute load average while the scores were computed: "
                        f"median {middle:.1f}, {low:.1f} to {high:.1f}; the times compare rows "
                        "of this run only.", ""]
    random_scores = random_view_scores(result.dataset)
    numbers: dict[str, dict[str, Any]] = {}
    for kind in KINDS:
        rows: dict[str, tuple[str, ProtocolScores, float | None]] = {
            label: (views, result.scores[kind][label], result.ms[kind][label])
            for label, (views, _) in clouds.items()}
        rows["random view (expectation)"] = ("–", random_scores, None)
        for label, (views, _) in meshes.items():
            rows[label] = (views, result.scores[MESH_KIND][label], result.ms[MESH_KIND][label])
        lines += kind_section(kind, rows, reference, rivals, result.failures[kind])
        numbers[kind] = {label: {"views": views, "ms": time_ms, "mean": scores.mean.tolist(),
                                 "sem": scores.sem.tolist()}
                         for label, (views, scores, time_ms) in rows.items()}
    text = "\n".join(lines).rstrip()
    print(text)
    if args.results is not None:
        write_section(args.results, args.section, text)
    if args.readme is not None:
        coverage = (f"{sum(len(ks) for ks in result.rotations.values())} (model, rotation) "
                    f"cases of {len(result.rotations)} models of {where}")
        write_section(args.readme, README_SECTION, readme_table(
            numbers, coverage, f"`{command_line(__file__, argv)}`, "
                               f"{datetime.now(timezone.utc):%Y-%m-%d}, {machine()}"))
    if args.json is not None:
        args.json.write_text(json.dumps(numbers, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
