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

* point search N @ R: the splat visibility of the cloud
  (:class:`vptoolkit.visibility.splats.PointScene`) over N Fibonacci
  directions (:func:`vptoolkit.sphere.fibonacci_sphere`) at R px, the paper's
  four measures from its histograms with the points' areas as the surface
  (:func:`vptoolkit.measures.sums.quality_from_histograms`,
  :func:`vptoolkit.point_areas.point_areas`), the best view per measure; a
  flat search;
* anytime point search N @ R: :func:`vptoolkit.best_view.search.search_best_views`
  on a :class:`vptoolkit.point_cloud.PointCloud`, where that function takes
  one (the rows are left out where it refuses);
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
* for reference, the search on the cleaned mesh itself at the same budgets
  (``search_best_views(mesh turned by R_k, SearchSettings(budget=N))``): what
  a mesh would give, the same numbers in both tables.

Cost: the median wall time per cloud (per mesh for the mesh rows) in ms on
this machine, the cloud in memory. Below each table, the point search at its
largest budget minus the network and minus the largest hidden point removal,
paired over models (:func:`vptoolkit.evaluate.protocol.paired_difference`).

Data
    A point benchmark folder of ``tools/make_point_benchmark_data.py``
    (``manifest.json``, ``labels/`` and ``clouds/<name>_r<k>_{uniform,scan}.npz``),
    or any folder of meshes: then the labels are built once under ``--cache``
    (:func:`bench_best_view.labels`) and the clouds are drawn from each turned
    cleaned mesh (:func:`vptoolkit.points.sample_surface`,
    :func:`vptoolkit.scan.virtual_scan`) under ``--rotations`` fixed rotations.

Usage::

    python tools/bench_point_clouds.py --quick --models 2           # a smoke test, seconds
    python tools/bench_point_clouds.py BENCH_FOLDER --models 40 \\
        --results docs/results.md --section point_clouds
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable, Iterator
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
from vptoolkit.errors import InputError, VptoolkitError
from vptoolkit.evaluate.baselines import pca_directions
from vptoolkit.evaluate.protocol import ProtocolScores, random_view_scores
from vptoolkit.learn.draws import N_INPUTS
from vptoolkit.measures.quality import normalize_quality
from vptoolkit.measures.sums import quality_from_histograms
from vptoolkit.measures.unoccluded import unoccluded_best_views
from vptoolkit.mesh import Mesh
from vptoolkit.point_areas import point_areas
from vptoolkit.point_cloud import PointCloud
from vptoolkit.points import N_SURFACE_POINTS, sample_surface
from vptoolkit.progress import progress_bar
from vptoolkit.rotations import fixed_rotations, model_key
from vptoolkit.scan import SCAN_RESOLUTION, virtual_scan
from vptoolkit.sphere import fibonacci_sphere

SAMPLES = Path(__file__).resolve().parent.parent / "vptoolkit" / "samples"
KINDS = ("uniform", "scan")
POINTS_NETWORK = "points"  # the bundled checkpoint that reads coordinates alone
SCANNERS = 3  # scanners of a drawn virtual scan, as tools/make_point_benchmark_data.py

Cloud = tuple[np.ndarray, np.ndarray]  # points (n, 3), normals (n, 3), float64
CloudAnswer = Callable[[np.ndarray, np.ndarray, str], np.ndarray]
MeshAnswer = Callable[[Mesh], np.ndarray]


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source", nargs="?", type=Path, default=SAMPLES,
                        help="a point benchmark folder (manifest.json, labels/, clouds/) or a "
                             "folder of meshes (default: the bundled samples)")
    parser.add_argument("--cache", type=Path, default=Path("reproduction/bench_point_clouds"),
                        help="where the labels of a mesh folder are built once")
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
    if args.results is not None and args.results.exists() and not args.results.is_file():
        parser.error(f"--results: {args.results} is not a file")
    if args.quick:
        args.budget_list, args.rotations, args.resolution, args.network_inputs = [8, 16], 1, 64, 2
    return args


# --------------------------------------------------------------------------- data


@dataclass(frozen=True)
class Case:
    """One model under one rotation: the turned cleaned mesh and its clouds.

    ``row`` is the model's row in the scored dataset; ``rotation`` turns rows
    as ``v @ rotation.T``, so a direction ``d`` of the turned frame is
    ``d @ rotation`` in the model's.
    """

    row: int
    name: str
    rotation: np.ndarray
    mesh: Mesh
    clouds: dict[str, Cloud]


def turned_mesh(dataset: ViewpointDataset, row: int, rotation: np.ndarray) -> Mesh:
    """The stored cleaned mesh of ``row`` turned by ``rotation``."""
    vertices, faces = dataset.mesh(row)
    return Mesh(np.asarray(vertices, np.float64) @ rotation.T, np.asarray(faces, np.int64),
                name=dataset.names[row])


def benchmark_cases(folder: Path, dataset: ViewpointDataset, rotations: int) -> Iterator[Case]:
    """The cases of a point benchmark folder: its stored clouds, ``rotations`` per model."""
    for row, name in enumerate(dataset.names):
        for k in range(rotations):
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
            yield Case(row, name, rotation, turned_mesh(dataset, row, rotation), clouds)


def drawn_cases(dataset: ViewpointDataset, rotations: int, *, n_points: int,
                scan_resolution: int) -> Iterator[Case]:
    """Cases of a mesh folder: each turned cleaned mesh's uniform sample and virtual scan."""
    for row, name in enumerate(dataset.names):
        for k, rotation in enumerate(fixed_rotations(name, rotations)):
            mesh = turned_mesh(dataset, row, rotation)
            uniform = sample_surface(mesh, n_points, seed=k)
            scan = virtual_scan(mesh, SCANNERS, resolution=scan_resolution,
                                seed=(model_key(name) + k) % 2**63)
            yield Case(row, name, rotation, mesh,
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


def takes_point_clouds(cloud: Cloud) -> bool:
    """Whether :func:`search_best_views` searches a :class:`PointCloud` (it may refuse one)."""
    try:
        search_best_views(PointCloud(*cloud), SearchSettings(budget=4, resolution=32))
    except InputError:
        return False
    return True


def cloud_answers(budgets: list[int], hpr_views: list[int], resolution: int, anytime: bool,
                  network_inputs: int) -> dict[str, tuple[str, CloudAnswer]]:
    """Row label -> (views drawn, answer on a cloud), in table order."""
    from vptoolkit.learn.predict import network_predictor

    network = network_predictor(POINTS_NETWORK, n_inputs=network_inputs)
    rows: dict[str, tuple[str, CloudAnswer]] = {}

    def flat(budget: int) -> CloudAnswer:
        return lambda points, normals, name: point_search(points, normals, budget, resolution)

    def searched(budget: int) -> CloudAnswer:
        return lambda points, normals, name: search_best_views(
            PointCloud(points, normals, name=name),
            SearchSettings(budget=budget, resolution=resolution)).directions

    def removal(views: int) -> CloudAnswer:
        return lambda points, normals, name: hidden_point_removal_search(points, views)

    for budget in budgets:
        rows[f"point search {budget} @ {resolution}"] = (str(budget), flat(budget))
    if anytime:
        for budget in budgets:
            rows[f"anytime point search {budget} @ {resolution}"] = (str(budget),
                                                                     searched(budget))
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

    return {f"mesh search {budget} @ {resolution} (the mesh itself)": (str(budget),
                                                                      searched(budget))
            for budget in budgets}


# --------------------------------------------------------------------------- scoring


@dataclass
class Tally:
    """Score totals over rotations (``(n_models, M)``) and seconds per call of one row."""

    totals: np.ndarray
    seconds: list[float]
    counts: np.ndarray

    def add(self, row: int, scores: np.ndarray, seconds: float) -> None:
        self.totals[row] += scores
        self.counts[row] += 1
        self.seconds.append(seconds)

    def scores(self, dataset: ViewpointDataset, rotations: int) -> ProtocolScores:
        return ProtocolScores(tuple(dataset.names), tuple(dataset.categories),
                              self.totals / self.counts[:, None], rotations, dataset.measures)


def timed_score(dataset: ViewpointDataset, case: Case, answer: Callable[[], Any],
                ) -> tuple[np.ndarray, float]:
    """Run ``answer``; its scores in % per measure after turning back, and its seconds."""
    started = time.perf_counter()
    directions = np.asarray(answer(), dtype=np.float64)
    seconds = time.perf_counter() - started
    directions = np.broadcast_to(directions, (len(dataset.measures), 3))
    return 100.0 * np.diagonal(dataset.quality_of(case.row, directions @ case.rotation)), seconds


def score(dataset: ViewpointDataset, cases: Iterator[Case], n_cases: int,
          clouds: dict[str, tuple[str, CloudAnswer]], meshes: dict[str, tuple[str, MeshAnswer]],
          ) -> tuple[dict[str, dict[str, Tally]], dict[str, Tally]]:
    """Every row's tally, per cloud kind for the cloud answers; the first case warms up untimed."""
    def tally() -> Tally:
        return Tally(np.zeros((len(dataset), len(dataset.measures))), [],
                     np.zeros(len(dataset), np.int64))

    by_kind = {kind: {label: tally() for label in clouds} for kind in KINDS}
    by_mesh = {label: tally() for label in meshes}
    first = True
    with progress_bar(total=n_cases, description="clouds", unit="rotation") as bar:
        for case in cases:
            if first:  # numba's kernels compile and torch loads outside the timings
                for _, answer in clouds.values():
                    answer(*case.clouds["uniform"], case.name)
                first = False
            for kind in KINDS:
                points, normals = case.clouds[kind]
                for label, (_, answer) in clouds.items():
                    by_kind[kind][label].add(case.row, *timed_score(
                        dataset, case, lambda: answer(points, normals, case.name)))
            for label, (_, mesh_answer) in meshes.items():
                by_mesh[label].add(case.row, *timed_score(dataset, case,
                                                          lambda: mesh_answer(case.mesh)))
            bar.update(1)
    return by_kind, by_mesh


# --------------------------------------------------------------------------- report


def kind_section(kind: str, rows: dict[str, tuple[str, ProtocolScores, float | None]],
                 reference: str, rivals: list[str]) -> list[str]:
    """The markdown of one cloud kind: its table and the paired differences of ``reference``."""
    lines = [f"### {kind} clouds", ""]
    lines += markdown_table(
        ["answer", "VE", "VR", "VKL", "VMI", "views", "ms per cloud"],
        ([label, *score_cells(scores), views, "–" if ms is None else f"{ms:.0f}"]
         for label, (views, scores, ms) in rows.items()))
    lines += ["", "Paired over models, difference ± standard error in points (* beyond two "
              "standard errors):", ""]
    lines += comparison_table({label: rows[label][1] for label in [reference, *rivals]},
                              reference)
    return lines + [""]


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

        def cases() -> Iterator[Case]:
            if is_benchmark:
                return benchmark_cases(args.source, dataset, rotations)
            return drawn_cases(dataset, rotations,
                               n_points=2000 if args.quick else N_SURFACE_POINTS,
                               scan_resolution=64 if args.quick else SCAN_RESOLUTION)

        anytime = takes_point_clouds(next(cases()).clouds["uniform"])
        clouds = cloud_answers(args.budget_list, args.hpr_list, args.resolution, anytime,
                               args.network_inputs)
        meshes = mesh_answers(args.budget_list, args.resolution)
        by_kind, by_mesh = score(dataset, cases(), len(dataset) * rotations, clouds, meshes)
        random_scores = random_view_scores(dataset)
    except VptoolkitError as error:
        print(f"bench_point_clouds: error: {error}", file=sys.stderr)
        return 2

    def ms(seconds: list[float]) -> float:
        return 1000.0 * float(np.median(seconds))

    reference = f"point search {max(args.budget_list)} @ {args.resolution}"
    rivals = ["network of coordinates alone",
              f"Open3D hidden point removal, {max(args.hpr_list)} views"]
    where = (f"`{args.source.name}/`" if args.source != SAMPLES else "the bundled samples")
    lines = [
        f"## Best views of point clouds, {where}",
        "",
        f"Command: `{command_line(__file__, argv)}`; {datetime.now(timezone.utc):%Y-%m-%d}, "
        f"{machine()}; wall time {format_seconds(time.perf_counter() - started)}.",
        "",
        f"{len(dataset)} models, {rotations} fixed rotation{'' if rotations == 1 else 's'} "
        f"each; labels: cleaned mesh, {len(dataset.views)} views at "
        f"{dataset.attrs.get('resolution', '?')} px. Each answer sees the rotated cloud, is "
        "turned back and scores the normalised quality of the nearest labelled view, in %, "
        "mean ± standard error over models; ms: median per cloud (per mesh for the mesh rows) "
        "on this machine, the cloud in memory. The mesh rows search the cleaned mesh itself, "
        "for reference; they are the same in both tables.",
        "",
    ]
    if not anytime:
        lines += ["`search_best_views` does not take a point cloud here, so the anytime point "
                  "search has no rows.", ""]
    numbers: dict[str, dict[str, Any]] = {}
    for kind in KINDS:
        rows: dict[str, tuple[str, ProtocolScores, float | None]] = {
            label: (views, by_kind[kind][label].scores(dataset, rotations),
                    ms(by_kind[kind][label].seconds))
            for label, (views, _) in clouds.items()}
        rows["random view (expectation)"] = ("–", random_scores, None)
        for label, (views, _) in meshes.items():
            rows[label] = (views, by_mesh[label].scores(dataset, rotations),
                           ms(by_mesh[label].seconds))
        lines += kind_section(kind, rows, reference, rivals)
        numbers[kind] = {label: {"views": views, "ms": time_ms, "mean": scores.mean.tolist(),
                                 "sem": scores.sem.tolist()}
                         for label, (views, scores, time_ms) in rows.items()}
    text = "\n".join(lines).rstrip()
    print(text)
    if args.results is not None:
        write_section(args.results, args.section, text)
    if args.json is not None:
        args.json.write_text(json.dumps(numbers, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
