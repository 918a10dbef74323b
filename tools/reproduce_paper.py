"""Reproduce the experiments of the paper's section 5 end to end.

Schelling et al., *Enabling Viewpoint Learning through Dynamic Label
Generation* (Eurographics 2021). One command regenerates, on data we can ship
or build here, every experiment of section 5 plus the resolution study of
figure 3, and writes each as one section of ``docs/results.md`` between the
markers ``<!-- NAME:start -->`` and ``<!-- NAME:end -->`` (the scheme of
``tools/reproduce_labels.py``), so a section can be regenerated on its own
with ``--sections``:

``labels``
    Table 2, label methods on procedural shapes: :func:`reproduce_labels.run`
    (its working folder is ``--labels-out``; the other sections reuse its
    dataset and ML+GL checkpoint).
``timings``
    Table 3: brute-force measures (:func:`vptoolkit.measures.quality.compute_view_quality`,
    raster backend, 250 / 500 / 1000 views at the library's default
    resolution) against the network (an untrained :class:`ViewpointNet`; the
    weights do not change the cost) at batch 1 / 64 / 256 on 4096 points, for
    meshes of 10k to 1M faces made from the bundled bunny by midpoint
    subdivision (:func:`mesh_with_faces`).
``robustness``
    Table 4: the trained ML+GL network on the test split with (a) the
    dataset's points (cleaned meshes), (b) points sampled from the raw source
    meshes, (c) a Poisson-disk sampling and (d) the mesh vertices, without
    retraining; then the twelve bundled real meshes, network against a random
    view and the PCA heuristic.
``subdivision``
    Figure 8: the seat of a procedural chair subdivided 1-to-4 again and
    again; angle of each measure's best view and of the network's prediction
    to level 0, in degrees.
``resolution``
    Figure 3 extended: best-view stability, normalised quality lost and
    Spearman rank correlation of every measure at 128 ... 2048 px against the
    finest resolution, and a recommended resolution for fast builds.

Every number in the document comes from the run (the paper's numbers are
copied from its tables into the ``PAPER_*`` constants and shown beside
ours); the numbers also go to ``<out>/paper.json``. Figures are PNG files
under ``docs/figures/``.

Usage::

    python tools/reproduce_paper.py                       # full sizes: hours on 2 cores
    python tools/reproduce_paper.py --quick               # minutes; writes under --out only
    python tools/reproduce_paper.py --sections timings    # regenerate one section
    python tools/reproduce_paper.py --skip-labels         # reuse the trained checkpoint

Libraries do the general work: trimesh's midpoint subdivision
(:func:`subdivide`, :func:`mesh_with_faces`), scipy's Spearman correlation
(:func:`spearman`, scipy comes with the ``dev`` extra) and
:func:`vptoolkit.points.poisson_disk_points`. Tables and sections of
``docs/results.md`` are written by the sibling module ``results_doc``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np
import reproduce_labels
from numpy.typing import NDArray
from results_doc import (
    command_line,
    format_seconds,
    machine,
    markdown_table,
    score_cells,
    write_section,
)

from vptoolkit.conventions import RESOLUTION
from vptoolkit.geometry import face_areas, face_normals
from vptoolkit.io import load_mesh
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.mesh import Mesh
from vptoolkit.points import poisson_disk_points, sample_surface
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import angle_between_deg

SECTIONS = ("labels", "timings", "robustness", "subdivision", "resolution")
"""Section names, in document order; each owns ``<!-- NAME:start/end -->``."""

# The paper's table 3 (i7-8700K + GTX 1080): faces -> seconds for 250 / 500 / 1000
# sampled views, then seconds per model for the network at batch 1 / 64 / 256.
# None is the paper's "N/A" (not finished after 12 h).
PAPER_TIMINGS: dict[int, tuple[float | None, ...]] = {
    10_000: (20, 40, 79, 0.263, 0.015, 0.012),
    50_000: (92, 184, 373, 0.253, 0.013, 0.010),
    100_000: (178, 356, 722, 0.260, 0.018, 0.015),
    400_000: (737, 1479, 2929, 0.270, 0.020, 0.017),
    1_000_000: (2030, None, None, 0.258, 0.010, 0.007),
}
# The paper's table 4, ML+GL on ModelNet40 (%), VE, VR, VKL, VMI.
PAPER_ROBUSTNESS: dict[str, tuple[float, float, float, float]] = {
    "preprocessed meshes": (79.3, 78.2, 91.2, 92.5),
    "raw meshes": (78.9, 76.2, 88.6, 90.4),
    "surface sampling": (79.1, 74.6, 88.9, 88.4),
}
NETWORK_BUDGET_SECONDS = 60.0
"""Time after which a network cell stops repeating (once three passes ran)."""
HELD_OUT_ROTATIONS = 8
"""Fixed rotations per held-out real mesh in table 4 (:mod:`vptoolkit.evaluate.protocol`)."""
SURFACE_POINTS = 20_000
"""Surface points per mesh before the network input is picked (the paper's)."""
POISSON_INIT_FACTOR = 5
"""Uniform candidates per Poisson-disk point (Open3D's default ``init_factor``)."""
LOSS_THRESHOLD = 2.0
"""Largest normalised quality (in %) a fast resolution may lose against the finest."""
SPEARMAN_THRESHOLD = 0.95
"""Smallest rank correlation with the finest resolution a fast resolution must keep."""


# ============================================================================ sizes


@dataclass(frozen=True)
class PaperSizes:
    """Every size of one run; the defaults are the full run's.

    Attributes
    ----------
    labels : reproduce_labels.LabelSizes
        Table 2's benchmark and training budget; its networks read coordinates
        alone (no ``point_features``), the paper's input.
    label_methods : tuple of str
        Label methods of table 2 (ML+GL must be among them for table 4).
    timing_faces : tuple of int
        Target face counts of table 3's meshes.
    timing_views : tuple of int
        Candidate views of the brute-force columns.
    timing_resolution : int
        Image side in px of the brute-force columns (the library default).
    timing_batches : tuple of int
        Batch sizes of the network columns.
    timing_points, timing_fps : int
        Network input points and how many of them farthest point sampling picks.
    measure_repeats, network_repeats : int
        Timed repetitions (median reported) of each measure and network cell.
    sample_meshes : tuple of str, optional
        Bundled meshes of table 4's held-out rows (default None: all twelve).
    chair_seed : int
        ``make_shape("chair", seed=...)`` of figure 8.
    subdivision_levels : int
        Figure 8 subdivides the seat 1, 2, ..., this many times.
    subdivision_views, subdivision_resolution : int
        Views and px of figure 8's measures.
    resolution_meshes : tuple of str
        Bundled meshes of the resolution study.
    resolutions : tuple of int
        Image sides in px of the resolution study; the largest is the reference.
    resolution_views : int
        Views of the resolution study.
    """

    labels: reproduce_labels.LabelSizes = field(
        default_factory=lambda: reproduce_labels.LabelSizes(point_features=()))
    label_methods: tuple[str, ...] = reproduce_labels.METHODS
    timing_faces: tuple[int, ...] = (10_000, 50_000, 100_000, 400_000, 1_000_000)
    timing_views: tuple[int, ...] = (250, 500, 1000)
    timing_resolution: int = RESOLUTION
    timing_batches: tuple[int, ...] = (1, 64, 256)
    timing_points: int = 4096
    timing_fps: int = 1024
    measure_repeats: int = 1
    network_repeats: int = 10
    sample_meshes: tuple[str, ...] | None = None
    chair_seed: int = 47
    subdivision_levels: int = 6
    subdivision_views: int = 1000
    subdivision_resolution: int = RESOLUTION
    resolution_meshes: tuple[str, ...] = ("bunny.ply", "Duck.glb", "lego.obj", "teapot.stl")
    resolutions: tuple[int, ...] = (128, 256, 512, 1024, 2048)
    resolution_views: int = 1000


FULL = PaperSizes()
QUICK = PaperSizes(
    labels=replace(reproduce_labels.QUICK, point_features=()),
    timing_faces=(10_000, 50_000),
    timing_resolution=256,
    timing_batches=(1, 64),
    network_repeats=3,
    subdivision_levels=4,
    subdivision_views=200,
    subdivision_resolution=256,
    resolution_meshes=("bunny.ply", "teapot.stl"),
    resolutions=(128, 256, 512, 1024),
    resolution_views=200,
)
"""The ``--quick`` sizes: well under 15 minutes on two busy cores."""


@dataclass(frozen=True)
class RunOptions:
    """Where a run reads and writes, and what it runs.

    Attributes
    ----------
    out : Path
        Working folder: ``paper.json``, the samples dataset.
    labels_out : Path
        Working folder of :func:`reproduce_labels.run` (shapes, dataset, models).
    results : Path
        Markdown file whose sections are replaced.
    figures : Path
        Folder of the PNG figures.
    sizes : PaperSizes
        Sizes of the run.
    sections : tuple of str
        Sections to (re)generate, from :data:`SECTIONS`.
    workers : int
        Processes of the dataset builds.
    command : str
        The command line written into every section.
    network : Path, optional
        Checkpoint of table 4 and figure 8 (default: table 2's ML+GL one).
    """

    out: Path
    labels_out: Path
    results: Path
    figures: Path
    sizes: PaperSizes = FULL
    sections: tuple[str, ...] = SECTIONS
    workers: int = 2
    command: str = "python tools/reproduce_paper.py"
    network: Path | None = None


# ============================================================================ geometry helpers


def subdivide(
    mesh: Mesh, selected: NDArray[np.bool_] | None = None
) -> tuple[Mesh, NDArray[np.bool_]]:
    """Midpoint 1-to-4 subdivision of some (default: all) faces (``trimesh.remesh.subdivide``).

    Each selected face ``(a, b, c)`` becomes four with the edge midpoints
    ``m_xy = (x + y) / 2``; the winding (counter-clockwise front) and the
    surface are unchanged, so only the discretisation changes. A midpoint is
    shared by the selected faces on both sides of an edge; an unselected
    neighbour keeps its edge whole (a T-junction on the same straight line,
    which leaves no gap).

    Parameters
    ----------
    mesh : Mesh
        The mesh.
    selected : (n_faces,) bool, optional
        Faces to subdivide (default: all).

    Returns
    -------
    subdivided : Mesh
        The unselected faces first, in their order, then four faces per
        selected face; ``n_faces + 3 * n_selected`` faces.
    is_new : (n_faces_out,) bool
        True for the faces made by the subdivision.
    """
    import trimesh

    is_selected = (np.ones(mesh.n_faces, dtype=bool) if selected is None
                   else np.asarray(selected, dtype=bool))
    vertices, faces = trimesh.remesh.subdivide(mesh.vertices, mesh.faces,
                                               face_index=np.flatnonzero(is_selected))
    is_new = np.zeros(len(faces), dtype=bool)
    is_new[mesh.n_faces - int(is_selected.sum()):] = True
    return Mesh(np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64),
                mesh.name), is_new


def mesh_with_faces(mesh: Mesh, n_faces: int, *, name: str | None = None) -> Mesh:
    """A version of ``mesh`` with about ``n_faces`` faces and the same surface.

    Fewer faces than the mesh has: quadric decimation
    (:func:`vptoolkit.clean.simplify.simplify_mesh`, at most ``n_faces``). More: whole
    1-to-4 subdivisions while ``4 * faces <= n_faces``, then the
    ``ceil((n_faces - faces) / 3)`` largest faces are subdivided once more
    (the finished mesh has ``n_faces`` to ``n_faces + 2`` faces).
    """
    if mesh.n_faces > n_faces:
        from vptoolkit.clean.simplify import simplify_mesh

        mesh = simplify_mesh(mesh, max_faces=n_faces)
    while 4 * mesh.n_faces <= n_faces:
        mesh, _ = subdivide(mesh)
    n_split = math.ceil((n_faces - mesh.n_faces) / 3)
    if n_split > 0:
        largest = np.argsort(-face_areas(mesh), kind="stable")[:n_split]
        selected = np.zeros(mesh.n_faces, dtype=bool)
        selected[largest] = True
        mesh, _ = subdivide(mesh, selected)
    return Mesh(mesh.vertices, mesh.faces, name or f"{mesh.name}_{mesh.n_faces}")


def flat_part(mesh: Mesh) -> NDArray[np.bool_]:
    """The upward-facing plane of largest area, as a face mask (a chair's seat).

    Faces whose unit normal has ``z > 0.999`` are grouped by the height of
    their centroid (rounded to 1e-6); the group of largest total area wins.

    Returns
    -------
    is_flat : (n_faces,) bool
    """
    is_up = face_normals(mesh)[:, 2] > 0.999
    heights = np.round(mesh.vertices[mesh.faces].mean(axis=1)[:, 2], 6)
    areas = face_areas(mesh)
    planes = np.unique(heights[is_up])
    if len(planes) == 0:
        raise ValueError(f"{mesh.name}: no upward-facing face to subdivide")
    best = max(planes, key=lambda z: float(areas[is_up & (heights == z)].sum()))
    return is_up & (heights == best)


def spearman(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    """Spearman's rank correlation (``scipy.stats.spearmanr``) over the pairs where both are finite.

    Returns NaN if fewer than two pairs remain or a side is constant.
    """
    from scipy.stats import spearmanr

    is_kept = np.isfinite(a) & np.isfinite(b)
    a, b = a[is_kept], b[is_kept]
    if len(a) < 2 or np.ptp(a) == 0 or np.ptp(b) == 0:
        return math.nan
    return float(spearmanr(a, b).statistic)


# ============================================================================ network helpers


class Network:
    """A checkpoint with the input sizes it was trained on.

    Parameters
    ----------
    model : ViewpointNet
    n_points, n_fps : int
        Input points and how many of them farthest point sampling picks.
    """

    def __init__(self, model: Any, n_points: int, n_fps: int) -> None:
        self.model, self.n_points, self.n_fps = model, n_points, n_fps

    @classmethod
    def load(cls, checkpoint: Path) -> Network:
        """Load ``checkpoint`` (see :func:`vptoolkit.learn.model.load_model`)."""
        from vptoolkit.learn.model import load_model

        if not checkpoint.exists():
            raise SystemExit(f"{checkpoint}: no trained ML+GL checkpoint; run the labels "
                             "section first (without --skip-labels) or point --labels-out at one")
        model, config = load_model(checkpoint)
        trained = config.get("input", {})
        return cls(model, int(trained.get("n_points", 4096)), int(trained.get("n_fps", 1024)))

    def directions(
        self, clouds: Mapping[str, NDArray[Any]], *, seed: int = 0
    ) -> NDArray[np.float64]:
        """Predicted directions of named surface samples.

        Each cloud becomes one input as :func:`vptoolkit.learn.predict.predict`
        makes it (:func:`network_points`, seeded from ``seed`` and the points' content).

        Returns
        -------
        directions : (n_clouds, 4, 3) float64
            Unit vectors, in the order of ``clouds``.
        """
        from vptoolkit.learn.draws import network_points
        from vptoolkit.learn.predict import predict_directions

        inputs = np.stack([
            network_points(np.asarray(points, dtype=np.float64), n_points=self.n_points,
                           n_fps=self.n_fps, seed=seed, name=name)
            for name, points in clouds.items()
        ])
        return predict_directions(self.model, inputs)


def checkpoint_path(options: RunOptions) -> Path:
    """The network of table 4 and figure 8: ``--network``, else table 2's ML+GL checkpoint."""
    if options.network is not None:
        return options.network
    return options.labels_out / "models" / "ml_gl" / "model.safetensors"


# ============================================================================ markdown helpers


def _header(title: str, options: RunOptions, seconds: float, dataset: str) -> list[str]:
    return [
        f"## {title}", "",
        f"Command: `{options.command}`; {datetime.now(timezone.utc):%Y-%m-%d}, {machine()}; "
        f"wall time {format_seconds(seconds)}.", "",
        f"Dataset: {dataset}", "",
    ]


def _one_decimal(values: Sequence[float]) -> list[str]:
    return [f"{v:.1f}" for v in values]


def _figure_link(options: RunOptions, figure: Path, caption: str) -> str:
    return f"![{caption}]({os.path.relpath(figure, options.results.parent)})"


def _seconds(value: float) -> str:
    """Seconds with three significant digits (``0.0123 s``, ``1.23 s``, ``123 s``)."""
    return f"{value:.3g} s"


def _median_seconds(function: Callable[[], Any], repeats: int, *,
                    budget_seconds: float = math.inf) -> float:
    """Median wall time of up to ``repeats`` calls; stops early once the calls
    took ``budget_seconds`` in total and at least three (or ``repeats``) ran."""
    times: list[float] = []
    while len(times) < repeats:
        started = time.perf_counter()
        function()
        times.append(time.perf_counter() - started)
        if sum(times) >= budget_seconds and len(times) >= min(3, repeats):
            break
    return statistics.median(times)


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


# ============================================================================ sections


@dataclass
class Section:
    """One generated section: its markdown and the numbers behind it (JSON types)."""

    name: str
    markdown: str
    numbers: dict[str, Any]


def section_labels(options: RunOptions) -> Section:
    """Table 2 by :func:`reproduce_labels.run` in ``labels_out``."""
    table = reproduce_labels.run(options.labels_out, options.sizes.labels,
                                 methods=options.sizes.label_methods, workers=options.workers,
                                 command=options.command)
    numbers = json.loads((options.labels_out / "table2.json").read_text())
    return Section("labels", table, numbers)


def section_timings(options: RunOptions) -> Section:
    """Table 3: brute-force sampling of the measures against network prediction.

    Brute force: wall time of one :func:`compute_view_quality` call (raster
    backend; all four measures in one procedure, as in the paper), median of
    ``measure_repeats``, after a warm-up that compiles the rasteriser. The
    network: an untrained default :class:`ViewpointNet` in evaluation mode on
    ``timing_points`` points of the mesh's surface, the same cloud repeated
    ``batch`` times, median of up to ``network_repeats`` forward passes
    (fewer once they took ``NETWORK_BUDGET_SECONDS``) divided by
    ``batch`` (seconds per model). Loading, sampling and input picking are not
    timed, as in the paper.
    """
    import torch
    from tqdm import tqdm

    from vptoolkit.learn.config import ModelConfig
    from vptoolkit.learn.draws import network_points
    from vptoolkit.learn.model import ViewpointNet

    sizes = options.sizes
    started = time.perf_counter()
    load_before = os.getloadavg()[0]
    base = load_mesh(sample_path("bunny.ply"))
    meshes = [mesh_with_faces(base, target, name=f"bunny_{target}")
              for target in sizes.timing_faces]
    compute_view_quality(base, MeasureSettings(views=2, resolution=64))  # compile or load it
    model = ViewpointNet(ModelConfig()).eval()
    brute: list[list[float]] = [[] for _ in meshes]  # [mesh][views] seconds
    network: list[list[float]] = [[] for _ in meshes]  # [mesh][batch] seconds per model
    cells = [(i, views) for i in range(len(meshes)) for views in sizes.timing_views]
    for i, views in tqdm(cells, desc="timings: measures", unit="run"):
        seconds = _median_seconds(
            lambda mesh=meshes[i], views=views: compute_view_quality(
                mesh, MeasureSettings(views=views, resolution=sizes.timing_resolution)),
            sizes.measure_repeats)
        brute[i].append(seconds)
    for i, mesh in enumerate(tqdm(meshes, desc="timings: network", unit="mesh")):
        surface = sample_surface(mesh, SURFACE_POINTS, seed=0).points
        cloud = torch.from_numpy(network_points(surface, n_points=sizes.timing_points,
                                                n_fps=sizes.timing_fps, seed=0, name=mesh.name))
        for batch in sizes.timing_batches:
            inputs = cloud.expand(batch, -1, -1).contiguous()
            with torch.inference_mode():
                model(inputs)  # warm-up
                seconds = _median_seconds(lambda inputs=inputs: model(inputs),
                                          sizes.network_repeats,
                                          budget_seconds=NETWORK_BUDGET_SECONDS)
            network[i].append(seconds / batch)
    load_after = os.getloadavg()[0]
    seconds = time.perf_counter() - started

    columns = ([f"{v} views" for v in sizes.timing_views]
               + [f"batch {b}" for b in sizes.timing_batches])
    paper_columns = {250: 0, 500: 1, 1000: 2}
    paper_batches = {1: 3, 64: 4, 256: 5}
    lines = _header(
        "Table 3: brute-force sampling against network prediction", options, seconds,
        f"the bundled bunny ({base.n_faces} faces) decimated or subdivided (midpoint 1-to-4, "
        "then the largest faces once more) to "
        + ", ".join(f"{mesh.n_faces}" for mesh in meshes) + " faces.")
    lines += [
        f"Sampling: `compute_view_quality` (raster backend, all four measures in one pass) "
        f"for {', '.join(map(str, sizes.timing_views))} Fibonacci views at "
        f"{sizes.timing_resolution} px, median of {sizes.measure_repeats} run(s), "
        "wall time in seconds. Network: an untrained `ViewpointNet` (default architecture; "
        f"weights do not change the cost) on {sizes.timing_points} points "
        f"({sizes.timing_fps} by farthest point sampling) of each mesh's surface, batch "
        f"{' / '.join(map(str, sizes.timing_batches))}, median of up to {sizes.network_repeats} "
        f"forward passes (a cell stops once its passes took {NETWORK_BUDGET_SECONDS:.0f} s, "
        f"after at least {min(3, sizes.network_repeats)}), seconds per model, "
        f"torch {torch.__version__} with "
        f"{torch.get_num_threads()} threads on the CPU. As in the paper, loading, cleaning, "
        "point sampling and weight loading are not timed. Load average "
        f"{load_before:.2f} before and {load_after:.2f} after (other jobs shared the machine "
        "when it is above 0); paper: i7-8700K, OpenGL sampling, TensorFlow on a GTX 1080, "
        "in parentheses.",
        "",
    ]
    table = []
    for i, (mesh, target) in enumerate(zip(meshes, sizes.timing_faces)):
        paper = PAPER_TIMINGS.get(target)
        cells_text = []
        values = brute[i] + network[i]
        keys = [paper_columns.get(v) for v in sizes.timing_views] + \
               [paper_batches.get(b) for b in sizes.timing_batches]
        for value, key in zip(values, keys):
            reference = paper[key] if paper is not None and key is not None else None
            text = _seconds(value)
            if paper is not None and key is not None:
                text += f" ({'N/A' if reference is None else _seconds(reference)})"
            cells_text.append(text)
        speedup = brute[i][-1] / network[i][0]
        table.append([f"{mesh.n_faces:,}", *cells_text, f"{speedup:,.0f}x"])
    lines += markdown_table(["faces", *columns, "speed-up (most views / batch 1)"], table,
                            align="r" * (len(columns) + 2))
    lines += ["", f"On {meshes[-1].n_faces:,} faces, sampling {sizes.timing_views[-1]} views took "
              f"{_seconds(brute[-1][-1])} and one network prediction (batch "
              f"{sizes.timing_batches[0]}) {_seconds(network[-1][0])}."]
    numbers = {
        "faces": [mesh.n_faces for mesh in meshes], "views": list(sizes.timing_views),
        "batches": list(sizes.timing_batches), "resolution": sizes.timing_resolution,
        "sampling_seconds": brute, "network_seconds_per_model": network,
        "load_average": [load_before, load_after], "seconds": seconds,
    }
    return Section("timings", "\n".join(lines), numbers)


def section_robustness(options: RunOptions) -> Section:
    """Table 4: one trained network under other meshing and sampling, plus real meshes.

    Test split of the labels dataset, scored with :func:`score_directions`
    (mean over categories of the normalised quality of the nearest sampled
    view, in %) against the dataset's quality (of the cleaned meshes), with
    inputs from (a) the stored points, (b) ``SURFACE_POINTS``-style area-uniform
    points of the raw source meshes (``labels_out/shapes``), (c) Poisson-disk
    points of the cleaned meshes and (d) the cleaned meshes' vertices. Then
    the bundled real meshes, built into a dataset with the labels dataset's
    settings, scored for the network, a random view and the PCA heuristic
    under :data:`HELD_OUT_ROTATIONS` fixed rotations each (the rotated
    protocol of :mod:`vptoolkit.evaluate.protocol`, with standard errors).
    """
    from tqdm import tqdm

    from vptoolkit.data import open_dataset
    from vptoolkit.dataset.builder.options import BuildOptions
    from vptoolkit.dataset.builder.run import build_dataset
    from vptoolkit.evaluate.protocol import (
        ProtocolScores,
        pca_predictor,
        random_view_scores,
        score_protocol,
    )
    from vptoolkit.evaluate.scores import score_directions
    from vptoolkit.learn.predict import network_predictor

    started = time.perf_counter()
    network = Network.load(checkpoint_path(options))
    rows: dict[str, NDArray[np.float64]] = {}
    with open_dataset(options.labels_out / "dataset") as dataset:
        attrs = dataset.attrs
        n_surface, is_cleaned = int(attrs["n_points"]), bool(attrs["cleaning"]["enabled"])
        test = dataset.split("test")
        names = test.names
        stored, raw, poisson, vertices = {}, {}, {}, {}
        for position, name in enumerate(tqdm(names, desc="robustness: test inputs", unit="model")):
            stored[name] = test[position]["points"]
            source = options.labels_out / "shapes" / test.record(position)["source"]
            raw[name] = sample_surface(load_mesh(source), n_surface, seed=0).points
            cleaned = Mesh(*test.mesh(position), name=name)
            poisson[name] = poisson_disk_points(cleaned, n_surface, seed=0,
                                                oversampling=POISSON_INIT_FACTOR)
            vertices[name] = np.asarray(cleaned.vertices)
        inputs = {
            "(a) dataset points (cleaned meshes)": stored,
            "(b) raw source meshes": raw,
            "(c) Poisson-disk sampling": poisson,
            "(d) mesh vertices": vertices,
        }
        for label, clouds in inputs.items():
            rows[label] = score_directions(test, network.directions(clouds)).mean
        rows["random view (expectation)"] = np.mean(
            list(random_view_scores(test).category_means().values()), axis=0)
        n_vertices = [len(cloud) for cloud in vertices.values()]
        n_test, n_categories = len(test), len(set(test.categories))
        labels_settings = (int(attrs["n_views"]), int(attrs["resolution"]))

    samples_dir = sample_path("bunny.ply").parent
    chosen = options.sizes.sample_meshes
    samples_source = samples_dir
    if chosen is not None:  # a subset: link the chosen files into a folder of their own
        samples_source = options.out / "samples_source"
        samples_source.mkdir(parents=True, exist_ok=True)
        for file_name in chosen:
            link = samples_source / file_name
            if not link.exists():
                link.symlink_to(sample_path(file_name))
    build_options = BuildOptions(
        MeasureSettings(views=labels_settings[0], resolution=labels_settings[1]),
        n_points=n_surface, clean=is_cleaned, split_seed=0)
    built = build_dataset(samples_source, options.out / "samples", build_options,
                          workers=options.workers, progress=True)
    held_out: dict[str, ProtocolScores] = {}
    with open_dataset(built.path) as samples:
        held_out["network (ML+GL)"] = score_protocol(
            samples, network_predictor(checkpoint_path(options), dataset=samples),
            n_rotations=HELD_OUT_ROTATIONS)
        held_out["random view (expectation)"] = random_view_scores(samples)
        held_out["PCA axis"] = score_protocol(samples, pca_predictor,
                                              n_rotations=HELD_OUT_ROTATIONS)
        per_model = dict(zip(samples.names, held_out["network (ML+GL)"].scores.tolist()))
        sample_faces = {record["name"]: record["n_faces"] for record in samples.records}
    n_failed = built.n_failures
    seconds = time.perf_counter() - started

    paper_rows = {"(a) dataset points (cleaned meshes)": "preprocessed meshes",
                  "(b) raw source meshes": "raw meshes",
                  "(c) Poisson-disk sampling": "surface sampling"}
    cleaning = ("cleaned" if is_cleaned
                else "not cleaned (quick run: rows a and b see the same meshes)")
    lines = _header(
        "Table 4: robustness to meshing and point sampling", options, seconds,
        f"test split of the table-2 benchmark ({n_test} models, {n_categories} categories, "
        f"{cleaning}; quality from {labels_settings[0]} views at {labels_settings[1]} px of the "
        f"dataset's meshes), and {len(per_model)} bundled real meshes never seen in training.")
    lines += [
        f"One ML+GL network (`{checkpoint_path(options)}`, trained on the train split's "
        f"points), no retraining. Inputs: {network.n_points} points ({network.n_fps} by farthest "
        f"point sampling) picked from (a) the dataset's {n_surface} stored surface points, (b) "
        f"{n_surface} area-uniform points of the raw, uncleaned source meshes, (c) {n_surface} "
        "Poisson-disk points of the cleaned meshes (Yuksel's sample elimination in Open3D from "
        f"{POISSON_INIT_FACTOR}x as many uniform points) and (d) the cleaned meshes' vertices "
        f"only ({min(n_vertices)} to {max(n_vertices)} per model; drawn again where fewer than "
        f"{network.n_points}). "
        "Scores: mean over categories of the normalised quality of the nearest sampled view, "
        "in %. The paper's rows (ModelNet40; its different sampling is Qi et al.'s points) "
        "in the last column.",
        "",
    ]
    table = []
    for label, scores in rows.items():
        paper = PAPER_ROBUSTNESS.get(paper_rows.get(label, ""))
        table.append([label, *_one_decimal(scores),
                      " / ".join(_one_decimal(paper)) if paper else ""])
    lines += markdown_table(["input", *PAPER_MEASURES, "paper (ModelNet40)"], table,
                            align="l" + "r" * len(PAPER_MEASURES) + "l")
    ours = rows["(a) dataset points (cleaned meshes)"] - np.vstack(
        [rows["(b) raw source meshes"], rows["(c) Poisson-disk sampling"]])
    paper = np.subtract(PAPER_ROBUSTNESS["preprocessed meshes"],
                        [PAPER_ROBUSTNESS["raw meshes"], PAPER_ROBUSTNESS["surface sampling"]])
    lines += [
        "", f"Largest drop from (a) to (b) or (c): {float(ours.max()):.1f} points "
        f"(paper: {float(paper.max()):.1f}).",
        "",
        f"Held-out real meshes (`vptoolkit/samples`, {len(per_model)} meshes, "
        f"{'cleaned' if is_cleaned else 'not cleaned'}, {n_surface} points, quality from "
        f"{labels_settings[0]} views at {labels_settings[1]} px; {n_failed} failed to build), "
        f"each under {HELD_OUT_ROTATIONS} fixed rotations (`vptoolkit.evaluate.protocol`), "
        "mean over meshes ± standard error:",
        "",
        *markdown_table(["method", *PAPER_MEASURES],
                        [[label, *score_cells(scores)] for label, scores in held_out.items()]),
        "", "Network per mesh:", "",
        *markdown_table(["mesh", "faces", *PAPER_MEASURES],
                        [[name, str(sample_faces[name]), *_one_decimal(scores)]
                         for name, scores in per_model.items()]),
    ]
    numbers = {
        "test": {label: scores.tolist() for label, scores in rows.items()},
        "held_out": {label: {"mean": scores.mean.tolist(), "sem": scores.sem.tolist()}
                     for label, scores in held_out.items()},
        "held_out_per_model": per_model, "seconds": seconds,
    }
    return Section("robustness", "\n".join(lines), numbers)


def section_subdivision(options: RunOptions) -> Section:
    """Figure 8: subdivide a chair's seat and follow the best views.

    Level ``k`` splits every seat triangle of level ``k - 1`` into four
    (:func:`subdivide`), so the seat has ``2 * 4**k`` triangles and the surface
    never changes. Per level: each measure's best sampled view and the trained
    network's four predictions (on area-uniform surface points, seed 0), and
    their angles in degrees to level 0. The network's noise floor is the
    largest angle between level-0 predictions from sampling seeds 0 and 1..3.
    """
    from tqdm import tqdm

    from vptoolkit.synthetic import make_shape

    sizes = options.sizes
    started = time.perf_counter()
    network = Network.load(checkpoint_path(options))
    mesh = make_shape("chair", seed=sizes.chair_seed)
    is_seat = flat_part(mesh)
    best_views, predicted, n_faces, ve_elevation = [], [], [], []
    for level in tqdm(range(sizes.subdivision_levels + 1), desc="subdivision levels", unit="level"):
        if level > 0:
            mesh, is_seat = subdivide(mesh, is_seat)
        quality = compute_view_quality(mesh, MeasureSettings(
            views=sizes.subdivision_views, resolution=sizes.subdivision_resolution))
        best_views.append(quality.best_views)
        surface = sample_surface(mesh, SURFACE_POINTS, seed=0).points
        predicted.append(network.directions({mesh.name: surface})[0])
        n_faces.append(mesh.n_faces)
        ve_elevation.append(math.degrees(math.asin(float(quality.best_views[0, 2]))))
    base = make_shape("chair", seed=sizes.chair_seed)
    reseeded = [
        network.directions({base.name: sample_surface(base, SURFACE_POINTS, seed=s).points})[0]
        for s in (1, 2, 3)]
    noise = np.max([angle_between_deg(predicted[0], other) for other in reseeded], axis=0)
    measure_angles = np.array([angle_between_deg(views, best_views[0]) for views in best_views])
    network_angles = np.array([angle_between_deg(views, predicted[0]) for views in predicted])
    seconds = time.perf_counter() - started

    figure = options.figures / "fig8_subdivision.png"
    plt = _pyplot()
    fig, axes = plt.subplots(figsize=(6.4, 4.0))
    levels = np.arange(len(n_faces))
    for column, measure in enumerate(PAPER_MEASURES):
        line, = axes.plot(levels, measure_angles[:, column], marker="o",
                          label=f"{measure} best view")
        axes.plot(levels, network_angles[:, column], linestyle="--", marker="x",
                  color=line.get_color(), label=f"network ({measure} head)")
    axes.set_xlabel("subdivision level of the seat (seat triangles = 2 x 4^level)")
    axes.set_ylabel("angle to level 0 (degrees)")
    axes.set_title(f"Seat subdivision of chair seed {sizes.chair_seed}")
    axes.set_xticks(levels)
    axes.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    figure.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(figure, dpi=120)
    plt.close(fig)

    lines = _header(
        "Figure 8: mesh discretisation", options, seconds,
        f"`vptoolkit.synthetic.make_shape('chair', seed={sizes.chair_seed})` ({n_faces[0]} faces); "
        f"its seat top ({int(flat_part(base).sum())} triangles, the largest upward plane) is "
        f"split 1-to-4 at every level up to {sizes.subdivision_levels} ({n_faces[-1]} faces).")
    lines += [
        f"Measures from {sizes.subdivision_views} views at {sizes.subdivision_resolution} px; the "
        f"network is the ML+GL checkpoint `{checkpoint_path(options)}` on {network.n_points} "
        f"points picked from {SURFACE_POINTS} area-uniform surface points (seed 0). "
        "Angles in degrees between each "
        "level's best view (or prediction) and level 0's; VE elevation is the angle of VE's best "
        "view above the horizontal seat plane (90 = straight from the top, negative = from "
        "below). The network's noise "
        "floor (largest angle between level-0 predictions from sampling seeds 0 and 1, 2, 3): "
        + ", ".join(f"{m} {v:.1f}" for m, v in zip(PAPER_MEASURES, noise)) + ".",
        "",
        *markdown_table(
            ["level", "faces", *PAPER_MEASURES, "VE elevation",
             *(f"net {m}" for m in PAPER_MEASURES)],
            [[str(level), str(n_faces[level]), *_one_decimal(measure_angles[level]),
              f"{ve_elevation[level]:.1f}", *_one_decimal(network_angles[level])]
             for level in levels],
            align="r" * (2 * len(PAPER_MEASURES) + 3)),
    ]
    drift = measure_angles.max(axis=0)
    lines += [
        "", "Largest drift over the levels: " + ", ".join(
            f"{m} {v:.1f}" for m, v in zip(PAPER_MEASURES, drift))
        + f" degrees for the measures; network {network_angles.max():.1f} degrees "
        f"(noise floor {noise.max():.1f}).",
        "", _figure_link(options, figure, "Angle to level 0 against subdivision level"),
    ]
    numbers = {
        "faces": n_faces, "measure_angles_deg": measure_angles.tolist(),
        "network_angles_deg": network_angles.tolist(), "network_noise_deg": noise.tolist(),
        "ve_elevation_deg": ve_elevation, "seconds": seconds,
    }
    return Section("subdivision", "\n".join(lines), numbers)


def section_resolution(options: RunOptions) -> Section:
    """Resolution study: how each measure changes with the image side.

    Against the finest resolution ``F`` on the same views, per mesh, measure
    and resolution ``r``: the angle in degrees between the best views at ``r``
    and at ``F``; the quality lost, ``100 * (1 - q_F*[best_r])`` with ``q_F*``
    the normalised quality at ``F``; and Spearman's rank correlation of the
    raw values over the views. The table takes the worst over the meshes. The
    recommended resolution is the smallest whose worst loss is at most
    ``LOSS_THRESHOLD`` % and worst correlation at least ``SPEARMAN_THRESHOLD``
    for every measure.
    """
    from tqdm import tqdm

    sizes = options.sizes
    started = time.perf_counter()
    resolutions = sorted(sizes.resolutions)
    finest = resolutions[-1]
    n_res, n_meshes = len(resolutions), len(sizes.resolution_meshes)
    angles = np.zeros((n_meshes, n_res, len(PAPER_MEASURES)))
    losses = np.zeros_like(angles)
    rhos = np.zeros_like(angles)
    times = np.zeros((n_meshes, n_res))
    faces = []
    for i, name in enumerate(tqdm(sizes.resolution_meshes, desc="resolution study", unit="mesh")):
        mesh = load_mesh(sample_path(name))
        faces.append(mesh.n_faces)
        qualities = []
        for j, resolution in enumerate(resolutions):
            begin = time.perf_counter()
            qualities.append(compute_view_quality(mesh, MeasureSettings(
                views=sizes.resolution_views, resolution=resolution)))
            times[i, j] = time.perf_counter() - begin
        reference = qualities[-1]
        for j, quality in enumerate(qualities):
            angles[i, j] = angle_between_deg(quality.best_views, reference.best_views)
            losses[i, j] = 100.0 * (
                1.0 - reference.normalized[quality.best_index, np.arange(len(PAPER_MEASURES))])
            rhos[i, j] = [spearman(quality.raw[:, m], reference.raw[:, m])
                          for m in range(len(PAPER_MEASURES))]
    worst_angle, worst_loss, worst_rho = angles.max(axis=0), losses.max(axis=0), rhos.min(axis=0)
    spacing = math.degrees(math.sqrt(4 * math.pi / sizes.resolution_views))
    seconds = time.perf_counter() - started

    passing = [r for j, r in enumerate(resolutions[:-1])
               if (worst_loss[j] <= LOSS_THRESHOLD).all()
               and (worst_rho[j] >= SPEARMAN_THRESHOLD).all()]
    if passing:
        j = resolutions.index(passing[0])
        recommendation = (
            f"Recommendation: {passing[0]} px for fast builds, the smallest resolution whose worst "
            f"normalised-quality loss stays at or below {LOSS_THRESHOLD:.0f} % "
            f"({worst_loss[j].max():.1f} %) and whose rank correlation stays at or above "
            f"{SPEARMAN_THRESHOLD} ({worst_rho[j].min():.3f}) for every measure on these meshes; "
            f"its best views lie within {worst_angle[j].max():.1f} degrees of the {finest} px ones "
            f"(neighbouring views are about {spacing:.1f} degrees apart) and it takes "
            f"{times[:, j].sum() / times[:, -1].sum():.2f}x the time of {finest} px.")
    else:
        recommendation = (
            f"Recommendation: no resolution below {finest} px kept the worst quality loss within "
            f"{LOSS_THRESHOLD:.0f} % and the rank correlation above {SPEARMAN_THRESHOLD} for every "
            f"measure on these meshes; keep {finest} px, or accept the losses in the table.")

    figure = options.figures / "resolution_study.png"
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(11.0, 3.6))
    panels = [(worst_angle, "worst best-view angle (degrees)"),
              (worst_loss, "worst quality lost (%)"), (worst_rho, "worst Spearman rho")]
    for axis, (values, title) in zip(axes, panels):
        for column, measure in enumerate(PAPER_MEASURES):
            axis.plot(resolutions, values[:, column], marker="o", label=measure)
        axis.set_xscale("log", base=2)
        axis.set_xticks(resolutions, [str(r) for r in resolutions])
        axis.set_xlabel("resolution (px)")
        axis.set_title(title, fontsize=10)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"Against {finest} px, worst over {n_meshes} meshes, "
                 f"{sizes.resolution_views} views", fontsize=10)
    fig.tight_layout()
    figure.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(figure, dpi=120)
    plt.close(fig)

    lines = _header(
        "Resolution study (figure 3, every measure)", options, seconds,
        "bundled meshes "
        + ", ".join(f"{name} ({n} faces)" for name, n in zip(sizes.resolution_meshes, faces))
        + f"; {sizes.resolution_views} Fibonacci views at " + ", ".join(map(str, resolutions))
        + " px (raster backend).")
    lines += [
        f"Per measure, against {finest} px and worst over the meshes: angle between the best views "
        "(degrees) / normalised quality at the finest resolution lost by taking this "
        "resolution's best view (%) / Spearman's rank correlation of the raw values over the "
        "views. Time: total seconds for all meshes.",
        "",
        *markdown_table(
            ["resolution", *PAPER_MEASURES, "time"],
            [[str(resolution),
              *(f"{worst_angle[j, m]:.1f} / {worst_loss[j, m]:.1f} / {worst_rho[j, m]:.3f}"
                for m in range(len(PAPER_MEASURES))),
              f"{times[:, j].sum():.1f} s"]
             for j, resolution in enumerate(resolutions)],
            align="r" * (len(PAPER_MEASURES) + 2)),
    ]
    lines += ["", recommendation, "",
              _figure_link(options, figure, "Best-view angle, quality lost and rank correlation "
                                            "against resolution")]
    numbers = {
        "meshes": list(sizes.resolution_meshes), "resolutions": resolutions,
        "angles_deg": angles.tolist(), "quality_lost_percent": losses.tolist(),
        "spearman": rhos.tolist(), "seconds_per_mesh": times.tolist(),
        "recommended": passing[0] if passing else None, "seconds": seconds,
    }
    return Section("resolution", "\n".join(lines), numbers)


SECTION_FUNCTIONS: dict[str, Callable[[RunOptions], Section]] = {
    "labels": section_labels, "timings": section_timings, "robustness": section_robustness,
    "subdivision": section_subdivision, "resolution": section_resolution,
}


# ============================================================================ driver


def run(options: RunOptions) -> dict[str, Section]:
    """Generate the chosen sections, in document order, writing each as soon as it is done.

    Each section replaces its ``<!-- NAME:start -->`` ... ``<!-- NAME:end -->``
    block of ``options.results`` and its entry of ``options.out / "paper.json"``.

    Returns
    -------
    dict of str to Section
    """
    unknown = set(options.sections) - set(SECTIONS)
    if unknown:
        raise SystemExit(f"--sections: unknown {', '.join(sorted(unknown))}; "
                         f"choose from {', '.join(SECTIONS)}")
    options.out.mkdir(parents=True, exist_ok=True)
    numbers_path = options.out / "paper.json"
    done: dict[str, Section] = {}
    for name in SECTIONS:
        if name not in options.sections:
            continue
        section = SECTION_FUNCTIONS[name](options)
        write_section(options.results, name, section.markdown)
        numbers = json.loads(numbers_path.read_text()) if numbers_path.exists() else {}
        numbers[name] = section.numbers
        numbers_path.write_text(json.dumps(numbers, indent=2) + "\n")
        print(section.markdown + "\n", flush=True)
        done[name] = section
    return done


def parse_args(argv: Sequence[str] | None = None) -> RunOptions:
    """Command-line options as :class:`RunOptions`."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="tiny sizes (minutes); writes under --out unless "
                             "--results/--figures are given")
    parser.add_argument("--out", type=Path, default=None,
                        help="working folder (default: reproduction/paper, with --quick "
                             "reproduction/paper-quick)")
    parser.add_argument("--labels-out", type=Path, default=None,
                        help="working folder of table 2 (default: reproduction/labels, "
                             "with --quick OUT/labels)")
    parser.add_argument("--skip-labels", action="store_true",
                        help="do not (re)run table 2; reuse the checkpoint in --labels-out")
    parser.add_argument("--sections", default=",".join(SECTIONS),
                        help=f"comma-separated subset of {','.join(SECTIONS)}")
    parser.add_argument("--results", type=Path, default=None,
                        help="markdown file to update (default: docs/results.md, "
                             "with --quick OUT/results.md)")
    parser.add_argument("--figures", type=Path, default=None,
                        help="folder of the PNG figures (default: docs/figures, "
                             "with --quick OUT/figures)")
    parser.add_argument("--workers", type=int, default=2,
                        help="dataset build processes (default: 2)")
    parser.add_argument("--network", type=Path,
                        help="checkpoint of table 4 and figure 8, e.g. vptoolkit/learn/pretrained "
                             "(default: table 2's ML+GL checkpoint in --labels-out)")
    args = parser.parse_args(argv)
    if args.out is None:
        args.out = Path("reproduction/paper-quick" if args.quick else "reproduction/paper")
    sections = tuple(name.strip() for name in args.sections.split(",") if name.strip())
    if args.skip_labels:
        sections = tuple(name for name in sections if name != "labels")
    quick_default = ((lambda path: args.out / path) if args.quick
                     else (lambda path: Path("docs") / path))
    return RunOptions(
        out=args.out,
        labels_out=args.labels_out or (args.out / "labels" if args.quick
                                       else Path("reproduction/labels")),
        results=args.results or quick_default("results.md"),
        figures=args.figures or quick_default("figures"),
        sizes=QUICK if args.quick else FULL,
        sections=sections,
        workers=args.workers,
        command=command_line(__file__, argv),
        network=args.network,
    )


def main() -> None:
    started = time.perf_counter()
    options = parse_args()
    run(options)
    print(f"wrote {options.results} and figures under {options.figures} "
          f"in {format_seconds(time.perf_counter() - started)}")


if __name__ == "__main__":
    main()
