"""Benchmark of best-view answers: quality against cost, under rotation, in one run.

For every mesh file under MESH_DIR (the bundled samples by default) the labels
are built once with :func:`vptoolkit.dataset.builder.run.build_dataset` (cleaned, 1000
views at 256 px, the paper's scoring grid) and cached under ``--cache``. Then
every answer below sees the user's raw file under ``--rotations`` fixed
rotations per mesh (:func:`vptoolkit.rotations.fixed_rotations`), its answer is
rotated back and scored the authors' way: the normalised quality of the
nearest of the 1000 views, in %, mean over rotations, then mean ± standard
error over meshes.

Answers:

* random view (an expectation: the mean quality over the 1000 views);
* PCA axis (:func:`vptoolkit.evaluate.baselines.pca_directions` of 20000 surface points);
* the unoccluded estimate (:mod:`vptoolkit.measures.unoccluded`), no image drawn: from
  the mesh's faces, and from 2000 surface points with their normals (what a
  scan gives);
* the network alone (:class:`vptoolkit.learn.predict.MeshPredictor`, per ``--model``);
* plain search N @ R: :func:`vptoolkit.measures.quality.compute_view_quality` on N
  Fibonacci views at R px, each measure's best view;
* coarse-to-fine search N @ R: :func:`vptoolkit.best_view.search.search_best_views`;
* prior-guided search N @ R: the same with the candidates of
  :class:`vptoolkit.best_view.prior.UnoccludedPrior` and of
  :class:`vptoolkit.learn.prior.NetworkPrior` (per ``--model``);

at every budget of ``--budgets``. Two more rows are ceilings, not answers: the
best of a set of candidate directions as the labels score them (an oracle
choice), which no search that draws those candidates can beat:

* a sphere of ``--ceiling-views`` directions in the principal frame
  (:func:`vptoolkit.sphere.coarse_directions`), what a search of that
  budget draws;
* the candidates of each prior, all of them, however many it proposes (their
  mean count is the row's views).

A prior helps only where its candidates' ceiling beats the sphere's at the
same number of views. Cost: views drawn, and the median wall time
per mesh and rotation in ms (the mesh already loaded; the prior's network time
included). The Pareto front (no other row at most as slow and at least as good
in the mean over the four measures) is starred. With ``--results FILE`` the
table replaces the ``best_view`` section of FILE (``docs/results.md``). With
``--readme FILE`` the short table of which answer to use when
(:func:`readme_table`: the default search, an 8-view search, the unoccluded
estimate from points with normals, the network alone and the PCA axis, beside
a random view and a flat sphere of 256 views) replaces the
``readme_best_view`` section of FILE (``README.md``).

With ``--cloud-search FILE`` the tool runs only :func:`cloud_against_mesh`: the
default 64-view search of a 20,000-point cloud of the bunny (area-uniform
surface points with normals) against the same search of the bunny decimated to
10,000 faces, median wall time of alternating runs, and writes the ratio into
the ``cloud_search`` section of FILE (``docs/benchmarks.md``).

Usage::

    python tools/bench_best_view.py                          # the bundled samples
    python tools/bench_best_view.py --cloud-search docs/benchmarks.md
    python tools/bench_best_view.py ~/meshes --budgets 8,64   # any folder of meshes
    python tools/bench_best_view.py --quick                   # a smoke test, seconds
    python tools/bench_best_view.py --results docs/results.md --section best_view
    python tools/bench_best_view.py --results docs/results.md --readme README.md
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from collections.abc import Callable
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np
from results_doc import (
    add_results_option,
    command_line,
    machine,
    markdown_table,
    score_cells,
    write_section,
)

from vptoolkit.best_view.prior import resolve_prior
from vptoolkit.best_view.search import BUDGET, SEARCH_RESOLUTION, SearchSettings, search_best_views
from vptoolkit.data import open_dataset
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.dataset.builder.run import build_dataset
from vptoolkit.dataset.builder.sources import discover_models
from vptoolkit.errors import VptoolkitError
from vptoolkit.evaluate.baselines import pca_directions
from vptoolkit.evaluate.protocol import ProtocolScores, random_view_scores
from vptoolkit.io import load_mesh
from vptoolkit.learn.checkpoint import BUNDLED_MODELS
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.measures.unoccluded import (
    UNOCCLUDED_DIRECTIONS,
    mesh_elements,
    unoccluded_best_views,
)
from vptoolkit.mesh import Mesh
from vptoolkit.points import N_SURFACE_POINTS, sample_surface
from vptoolkit.progress import progress_bar
from vptoolkit.rotations import fixed_rotations
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import coarse_directions

SAMPLES = Path(__file__).resolve().parent.parent / "vptoolkit" / "samples"
Answer = Callable[[Mesh], np.ndarray]
SCAN_POINTS = 2000  # surface points of the unoccluded estimate's scan stand-in
README_SECTION = "readme_best_view"  # the section of --readme that readme_table fills
FEW_VIEWS = 8  # the README's budget for many meshes: `vptool best-view --views 8`
FLAT_VIEWS = 256  # the flat sphere the README sets beside the default search
CLOUD_POINTS = 20_000  # points of the cloud that cloud_against_mesh searches
CLOUD_MESH_FACES = 10_000  # faces of the mesh it searches beside them
CLOUD_REPEATS = 9  # timed searches of each
CLOUD_SECTION = "cloud_search"  # the section of --cloud-search that the ratio fills


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mesh_dir", nargs="?", type=Path, default=SAMPLES,
                        help="folder of mesh files (default: the bundled samples)")
    parser.add_argument("--cache", type=Path, default=Path("reproduction/bench_best_view"),
                        help="where the labels are built once")
    parser.add_argument("--budgets", default="4,8,16,32,64,256", help="views per mesh")
    parser.add_argument("--resolution", type=int, default=SEARCH_RESOLUTION,
                        help="px of the searches")
    parser.add_argument("--rotations", type=int, default=4, help="fixed rotations per mesh")
    parser.add_argument("--model", action="append", default=None,
                        help="network checkpoint or bundled name, repeatable (default: the "
                             "bundled ones, default and points)")
    add_results_option(parser, "best_view")
    parser.add_argument("--readme", type=Path,
                        help=f"also write the short table of which answer to use into the "
                             f"{README_SECTION} section of this file, README.md (needs "
                             f"--budgets with {FEW_VIEWS}, {BUDGET} and {FLAT_VIEWS}, the "
                             f"default --resolution and both bundled networks)")
    parser.add_argument("--json", type=Path, help="write every row's numbers here")
    parser.add_argument("--ceiling-views", type=int, default=8,
                        help="directions of the sphere whose ceiling is shown (default: 8)")
    parser.add_argument("--quick", action="store_true",
                        help="3 meshes, 1 rotation, budgets 4 and 16, labels at 64 px")
    parser.add_argument("--cloud-search", type=Path, metavar="FILE",
                        help="only time a search of a 20,000-point cloud against one of a "
                             "10,000-face mesh and write it into the cloud_search section of "
                             "FILE (docs/benchmarks.md)")
    args = parser.parse_args(argv)
    try:
        args.budget_list = [int(b) for b in args.budgets.split(",")]
    except ValueError:
        parser.error(f"--budgets: expected integers separated by commas, got {args.budgets!r}")
    if not args.budget_list or min(args.budget_list) < 1:
        parser.error("--budgets: every budget must be at least 1")
    if min(args.rotations, args.resolution, args.ceiling_views) < 1:
        parser.error("--rotations, --resolution and --ceiling-views must be at least 1")
    if not args.mesh_dir.is_dir():
        parser.error(f"{args.mesh_dir}: not a folder")
    if args.results is not None and args.results.exists() and not args.results.is_file():
        parser.error(f"--results: {args.results} is not a file")
    if args.quick:
        args.budget_list, args.rotations, args.ceiling_views = [4, 16], 1, 4
    args.models = args.model or list(BUNDLED_MODELS)
    if args.readme is not None and ({FEW_VIEWS, BUDGET, FLAT_VIEWS} - set(args.budget_list)
                                    or args.resolution != SEARCH_RESOLUTION
                                    or set(BUNDLED_MODELS) - set(args.models)):
        parser.error(f"--readme: its table needs --budgets with {FEW_VIEWS}, {BUDGET} and "
                     f"{FLAT_VIEWS}, --resolution {SEARCH_RESOLUTION} and both bundled networks "
                     f"(no --quick)")
    return args


def labels(mesh_dir: Path, cache: Path, *, quick: bool) -> Path:
    """Build (or resume) the labels of every mesh under ``mesh_dir``; the store's folder."""
    sources = discover_models(mesh_dir)
    if quick:
        sources = sources[:3]
    key = hashlib.sha256()
    for source in sources:
        key.update(f"{source.name}\0{source.path.stat().st_size}\0".encode())
        key.update(hashlib.sha256(source.path.read_bytes()).digest())
    key.update(b"quick" if quick else b"full")
    out = cache / key.hexdigest()[:16]
    src = out / "meshes"
    if not src.exists():
        src.mkdir(parents=True)
        for source in sources:
            (src / source.path.name).symlink_to(source.path.resolve())
    measure = MeasureSettings(views=100 if quick else 1000, resolution=64 if quick else 256)
    options = BuildOptions(measure, n_points=2000 if quick else N_SURFACE_POINTS)
    build_dataset(src, out / "build", options, workers=2, progress=True)
    return out


def network_label(model: str) -> str:
    """The rows' name of a network: ``network``, or with its folder's name."""
    return "network" if model == "default" else f"network {Path(model).name}"


def network_priors(models: list[str]) -> dict[str, Any]:
    """Row label of each network -> its :class:`~vptoolkit.learn.prior.NetworkPrior`,
    loaded once for the prior rows and the ceilings."""
    return {network_label(model): resolve_prior(model) for model in models}


def drawless_answers(models: list[str]) -> dict[str, Answer]:
    """Row label -> an answer that draws no image: PCA, the unoccluded estimate, the networks
    (each as ``vptool predict`` asks it, about its default count of inputs)."""
    from vptoolkit.learn.predict import MeshPredictor

    def pca(mesh: Mesh) -> np.ndarray:
        return pca_directions(sample_surface(mesh, 20000, seed=0).points[None])[0]

    def unoccluded_faces(mesh: Mesh) -> np.ndarray:
        return unoccluded_best_views(*mesh_elements(mesh),
                                     directions=coarse_directions(mesh, UNOCCLUDED_DIRECTIONS))

    def unoccluded_points(mesh: Mesh) -> np.ndarray:  # a scan's stand-in: points and normals
        return unoccluded_best_views(sample_surface(mesh, SCAN_POINTS, seed=0).normals)

    rows: dict[str, Answer] = {
        "PCA axis": pca,
        "unoccluded estimate, faces": unoccluded_faces,
        f"unoccluded estimate, {SCAN_POINTS} points with normals": unoccluded_points,
    }
    for model in models:
        rows[f"{network_label(model)} alone"] = MeshPredictor(model)
    return rows


def answers(budgets: list[int], resolution: int, drawless: dict[str, Answer],
            priors: dict[str, Any]) -> dict[str, tuple[str, Answer]]:
    """Row label -> (views drawn, answer), in table order."""
    rows: dict[str, tuple[str, Answer]] = {label: ("–", answer)
                                           for label, answer in drawless.items()}
    def plain(budget: int) -> Answer:
        return lambda mesh: compute_view_quality(
            mesh, MeasureSettings(views=budget, resolution=resolution)).best_views

    def searched(budget: int, prior: Any = None) -> Answer:
        return lambda mesh: search_best_views(
            mesh, SearchSettings(budget=budget, resolution=resolution),
            prior=None if prior is None else prior(mesh)).directions

    for budget in budgets:
        rows[f"plain search {budget} @ {resolution}"] = (str(budget), plain(budget))
        rows[f"coarse-to-fine {budget} @ {resolution}"] = (str(budget), searched(budget))
        for label, prior in priors.items():
            rows[f"{label} prior + search {budget} @ {resolution}"] = (str(budget),
                                                                         searched(budget, prior))
    return rows


def score(dataset: Any, meshes: dict[str, Mesh], rotations: int,
          answers: dict[str, Answer]) -> dict[str, tuple[ProtocolScores, float]]:
    """Each answer's protocol scores and its median ms per mesh and rotation.

    The answers take turns on every rotated mesh, so a busy machine slows
    them alike.
    """
    names = list(dataset.names)
    for answer in answers.values():  # untimed: numba's cached kernels and torch load once
        answer(meshes[names[0]])
    totals = {label: np.zeros((len(names), 4)) for label in answers}
    seconds: dict[str, list[float]] = {label: [] for label in answers}
    with progress_bar(total=len(names) * rotations, description="answers", unit="mesh") as bar:
        for row, name in enumerate(names):
            mesh = meshes[name]
            for turn in fixed_rotations(name, rotations):
                rotated = Mesh(mesh.vertices @ turn.T, mesh.faces, name=name)
                for label, answer in answers.items():
                    started = time.perf_counter()
                    directions = np.asarray(answer(rotated), dtype=np.float64)
                    seconds[label].append(time.perf_counter() - started)
                    totals[label][row] += 100.0 * np.diagonal(
                        dataset.quality_of(row, directions @ turn))
                bar.update(1)
    return {label: (ProtocolScores(tuple(names), tuple(dataset.categories),
                                   totals[label] / rotations, rotations),
                    1000.0 * float(np.median(seconds[label])))
            for label in answers}


def ceilings(dataset: Any, meshes: dict[str, Mesh], rotations: int,
             proposers: dict[str, Answer]) -> dict[str, tuple[ProtocolScores, float]]:
    """Each candidate set's ceiling: per measure the best label quality among its directions.

    Returns the protocol scores and the mean number of candidates per mesh and rotation.
    """
    names = list(dataset.names)
    totals = {label: np.zeros((len(names), 4)) for label in proposers}
    counts: dict[str, list[int]] = {label: [] for label in proposers}
    for row, name in enumerate(names):
        for turn in fixed_rotations(name, rotations):
            rotated = Mesh(meshes[name].vertices @ turn.T, meshes[name].faces, name=name)
            for label, propose in proposers.items():
                candidates = np.asarray(propose(rotated), dtype=np.float64)
                counts[label].append(len(candidates))
                totals[label][row] += 100.0 * dataset.quality_of(row, candidates @ turn).max(axis=0)
    return {label: (ProtocolScores(tuple(names), tuple(dataset.categories),
                                   totals[label] / rotations, rotations),
                    float(np.mean(counts[label])))
            for label in proposers}


def candidate_sets(sphere_views: int, priors: dict[str, Any]) -> dict[str, Answer]:
    """Row label -> candidate directions of a mesh, for :func:`ceilings`."""
    sets: dict[str, Answer] = {
        f"ceiling: best of the {sphere_views}-view sphere": (
            lambda mesh: coarse_directions(mesh, sphere_views))}
    for label, prior in priors.items():
        sets[f"ceiling: best of the {label} prior's candidates"] = prior
    return sets


def pareto(rows: dict[str, dict[str, Any]]) -> set[str]:
    """Rows that no other row beats: at most as slow and at least as good in the mean."""
    timed = {label: row for label, row in rows.items() if row["ms"] is not None}
    front = set()
    for label, row in timed.items():
        if not any(other["ms"] <= row["ms"] and other["mean"] >= row["mean"]
                   and (other["ms"] < row["ms"] or other["mean"] > row["mean"])
                   for other_label, other in timed.items() if other_label != label):
            front.add(label)
    return front


def readme_table(rows: dict[str, tuple[list[float], float | None]], *, meshes: str,
                 rotations: int, views: int, resolution: int, source: str) -> str:
    """The README's table of which answer to use when, from one run's rows.

    Parameters
    ----------
    rows : dict
        Row label of the full table (``"coarse-to-fine 64 @ 128"``, ``"network
        alone"``, ...) -> (mean score per measure in %, VE, VR, VKL, VMI; median
        ms per mesh and rotation, None for an expectation). Needs the rows of
        the coarse-to-fine search at :data:`FEW_VIEWS` and
        :data:`~vptoolkit.best_view.search.BUDGET` views and the plain search at
        :data:`FLAT_VIEWS`, all at :data:`~vptoolkit.best_view.search.SEARCH_RESOLUTION`,
        the unoccluded estimate from points, both bundled networks alone
        (``"network alone"``, ``"network points alone"``), the PCA axis and the
        random view.
    meshes : str
        What was scored, for the text (``"the 12 bundled meshes"``).
    rotations, views, resolution : int
        Fixed rotations per mesh; views and px of the labels.
    source : str
        The run: its command, date and machine, quoted under the table.

    Returns
    -------
    str
        Markdown whose links are relative to the repository root, where
        README.md lies: the "about 1 s" of ``vptool measures`` is not measured
        here and links the measures' benchmark.
    """
    def cells(label: str) -> list[str]:
        mean, ms = rows[label]
        return [" / ".join(f"{value:.1f}" for value in mean),
                "–" if ms is None else f"{ms:.0f} ms"]

    def search(kind: str, budget: int) -> str:
        return f"{kind} {budget} @ {SEARCH_RESOLUTION}"

    table = markdown_table(["you have", "use", "VE / VR / VKL / VMI", "time"], [
        ["one mesh, or a few", f"`vptool best-view` ({BUDGET} views)",
         *cells(search("coarse-to-fine", BUDGET))],
        ["a million meshes", f"`vptool best-view --views {FEW_VIEWS}`",
         *cells(search("coarse-to-fine", FEW_VIEWS))],
        ["the optimum over the paper's 1000 views", "`vptool measures`",
         "100 at its own resolution", "about 1 s ([benchmarks](docs/benchmarks.md#measures))"],
        ["a scan: points with normals",
         "`vptool predict -m unoccluded scan.npy` (an (N, 6) array: x y z nx ny nz)",
         *cells(f"unoccluded estimate, {SCAN_POINTS} points with normals")],
        ["a mesh, without drawing it", "`vptool predict`: the network",
         *cells("network alone")],
        ["points without normals", "`vptool predict -m points`: the network of coordinates alone",
         *cells("network points alone")],
        ["nothing but an axis", "the PCA axis (`vptoolkit.evaluate.baselines.pca_directions`)",
         *cells("PCA axis")],
    ], align="llll")
    random_view = cells("random view (expectation)")[0]
    flat, flat_ms = cells(search("plain search", FLAT_VIEWS))
    return "\n".join([
        f"Quality of each answer on {meshes}, each under {rotations} fixed "
        f"rotation{'' if rotations == 1 else 's'}, scored "
        f"the authors' way against {views} views at {resolution} px of the cleaned mesh (% of "
        "the way from the worst to the best view; VE / VR / VKL / VMI), and its median time "
        "per mesh on the machine named below, the mesh loaded:",
        "",
        *table,
        "",
        f"A random view scores {random_view}; a flat sphere of {FLAT_VIEWS} views "
        f"{flat} in {flat_ms}.",
        "",
        f"From {source}.",
    ])


def cloud_against_mesh(repeats: int = CLOUD_REPEATS) -> tuple[float, float, int]:
    """Median wall seconds of the default search (:data:`BUDGET` views) of a cloud and of a mesh.

    The mesh is the bunny decimated to :data:`CLOUD_MESH_FACES` faces
    (:func:`vptoolkit.clean.clean_mesh`); the cloud, :data:`CLOUD_POINTS`
    area-uniform points of the bunny with their normals (seed 0). Each is
    searched once first (numba's kernels load), then ``repeats`` times each,
    alternating, so that a slower spell of a shared machine falls on both.

    Returns
    -------
    cloud_s, mesh_s : float
        Median wall seconds of one search.
    n_faces : int
        Faces of the decimated mesh.
    """
    from vptoolkit.clean import clean_mesh
    from vptoolkit.point_cloud import PointCloud

    bunny = load_mesh(SAMPLES / "bunny.ply")
    mesh, _ = clean_mesh(bunny, max_faces=CLOUD_MESH_FACES)
    sample = sample_surface(bunny, CLOUD_POINTS, seed=0)
    cloud = PointCloud(sample.points, sample.normals, name="bunny")
    times: dict[str, list[float]] = {"cloud": [], "mesh": []}
    for model in (cloud, mesh):
        search_best_views(model)
    for _ in range(repeats):
        for label, model in (("cloud", cloud), ("mesh", mesh)):
            started = time.perf_counter()
            search_best_views(model)
            times[label].append(time.perf_counter() - started)
    return float(np.median(times["cloud"])), float(np.median(times["mesh"])), mesh.n_faces


def cloud_search_section(argv: list[str] | None, repeats: int = CLOUD_REPEATS) -> str:
    """The ``cloud_search`` section: :func:`cloud_against_mesh`'s times and their ratio."""
    cloud_s, mesh_s, n_faces = cloud_against_mesh(repeats)
    return (f"Command: `{command_line(__file__, argv)}`; {datetime.now(timezone.utc):%Y-%m-%d}, "
            f"{machine()}. The default search ({BUDGET} views at {SEARCH_RESOLUTION} px, the "
            f"paper's four) of {CLOUD_POINTS:,} bunny points with normals took "
            f"{1000 * cloud_s:.0f} ms, of the bunny decimated to {n_faces:,} faces "
            f"{1000 * mesh_s:.0f} ms: {cloud_s / mesh_s:.2f}x (median of {repeats} alternating "
            "runs, wall time, the kernels loaded).")


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.cloud_search is not None:
        text = cloud_search_section(argv)
        print(text)
        write_section(args.cloud_search, CLOUD_SECTION, text)
        return 0
    started = time.perf_counter()
    try:
        folder = labels(args.mesh_dir, args.cache, quick=args.quick)
        dataset = open_dataset(folder / "build")
        sources = {source.name: source.path for source in discover_models(folder / "meshes")}
        meshes = {name: load_mesh(sources[name]) for name in dataset.names}
        networks = network_priors(args.models)
        priors = {"unoccluded": resolve_prior("unoccluded"), **networks}
        rows = answers(args.budget_list, args.resolution, drawless_answers(args.models), priors)
        scored = score(dataset, meshes, args.rotations, {label: answer for label, (_, answer)
                                                         in rows.items()})
        random_scores = random_view_scores(dataset)
        results: dict[str, dict[str, Any]] = {
            "random view (expectation)": {"views": "–", "scores": random_scores, "ms": None,
                                          "mean": float(random_scores.mean.mean())}}
        for label, (views, _) in rows.items():
            scores, ms = scored[label]
            results[label] = {"views": views, "scores": scores, "ms": ms,
                              "mean": float(scores.mean.mean())}
        sets = candidate_sets(args.ceiling_views, priors)
        for label, (scores, count) in ceilings(dataset, meshes, args.rotations, sets).items():
            results[label] = {"views": f"{count:.1f}".removesuffix(".0"), "scores": scores,
                              "ms": None, "mean": float(scores.mean.mean())}
    except VptoolkitError as error:
        print(f"bench_best_view: error: {error}", file=sys.stderr)
        return 2
    front = pareto(results)
    where = "the bundled samples" if args.mesh_dir == SAMPLES else f"`{args.mesh_dir.name}/`"
    lines = [
        f"## Best views: quality against cost, {where}",
        "",
        f"Command: `{command_line(__file__, argv)}`; {datetime.now(timezone.utc):%Y-%m-%d}, "
        f"{machine()}; wall time {time.perf_counter() - started:.0f} s.",
        "",
        f"{len(dataset)} meshes, {args.rotations} fixed rotations each; labels: cleaned mesh, "
        f"{len(dataset.views)} views at {dataset.attrs.get('resolution', '?')} px. Scores in %, "
        "mean ± standard error over meshes; ms: median per mesh and rotation on this machine, "
        "the mesh loaded; * marks the Pareto front of mean quality against time. A ceiling "
        "is the best of a candidate set as the labels score it: what a search that draws "
        "those candidates could reach at most.",
        "",
    ]
    lines += markdown_table(
        ["answer", "VE", "VR", "VKL", "VMI", "views", "ms per mesh", "front"],
        ([label, *score_cells(row["scores"]), row["views"],
          "–" if row["ms"] is None else f"{row['ms']:.0f}", "*" if label in front else ""]
         for label, row in results.items()))
    text = "\n".join(lines)
    print(text)
    if args.results is not None:
        write_section(args.results, args.section, text)
    if args.readme is not None:
        where = (f"the {len(dataset)} bundled meshes" if args.mesh_dir == SAMPLES
                 else f"the {len(dataset)} meshes of `{args.mesh_dir.name}/`")
        write_section(args.readme, README_SECTION, readme_table(
            {label: (row["scores"].mean.tolist(), row["ms"]) for label, row in results.items()},
            meshes=where, rotations=args.rotations, views=len(dataset.views),
            resolution=int(dataset.attrs.get("resolution", 0)),
            source=f"`{command_line(__file__, argv)}`, {datetime.now(timezone.utc):%Y-%m-%d}, "
                   f"{machine()}"))
    if args.json is not None:
        args.json.write_text(json.dumps({label: {"views": row["views"], "ms": row["ms"],
                                                 "mean": row["scores"].mean.tolist(),
                                                 "sem": row["scores"].sem.tolist()}
                                         for label, row in results.items()}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
