"""Score a viewpoint network on held-out meshes under the rotated protocol, beside the baselines.

Builds (or resumes) a dataset of the meshes in a folder with the benchmark's
settings (cleaned, 20000 points, 1000 views at 256 px), then scores the
network, a random view (expectation), the PCA axis and, when ``--train`` names
a dataset, the best constant direction of its training split, each under
``--rotations`` fixed rotations per mesh (:mod:`vptoolkit.evaluate.protocol`), with the
standard error over meshes and the paired difference of the network to each
baseline.

``--model`` may be given again: the first network is compared with the
others (and with the baselines); ``--searches 16@32,64@64`` adds plain
searches of N views at R px (:func:`reproduce_labels.search_answer`) on the
cleaned meshes under the same rotations.

``--inputs 1,8`` scores the first network once per count of network inputs per
mesh (:func:`vptoolkit.learn.predict.predict`, the consensus of the answers
to that many inputs) and adds its rotation consistency: the angle between
the answer for each cleaned mesh and the answer for a copy resampled with
another seed and turned by a fixed rotation, turned back, per measure; the
median and the share of meshes within 10 degrees.

Usage::

    python tools/score_held_out.py vptoolkit/samples --model default
    python tools/score_held_out.py MESH_FOLDER --model runs/ml_gl \\
        --out reproduction/held_out/mine --json scores.json
    python tools/score_held_out.py MESH_FOLDER --inputs 1,8
    python tools/score_held_out.py MESH_FOLDER --model default --model points --searches 16@32

The bundled samples are the check that ships; keep any other held-out folder
out of training and tuning.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import NamedTuple, NoReturn

import numpy as np
from reproduce_labels import parse_searches, search_answer
from results_doc import (
    add_results_option,
    command_line,
    comparison_table,
    machine,
    markdown_table,
    score_cells,
    write_section,
)

from vptoolkit.cli.group import exit_code, one_line_error
from vptoolkit.data import open_dataset
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.dataset.builder.run import build_dataset
from vptoolkit.errors import VptoolkitError
from vptoolkit.evaluate.protocol import (
    ProtocolScores,
    best_constant_directions,
    constant_predictor,
    pca_predictor,
    random_view_scores,
    score_mesh_protocol,
    score_protocol,
)
from vptoolkit.learn.checkpoint import DEFAULT_MODEL, is_bundled_model
from vptoolkit.learn.draws import N_INPUTS
from vptoolkit.learn.predict import MeshPredictor, network_predictor
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.mesh import Mesh
from vptoolkit.points import N_SURFACE_POINTS
from vptoolkit.rotations import fixed_rotations
from vptoolkit.settings import MeasureSettings


class _Parser(argparse.ArgumentParser):
    """argparse whose errors are one line, like every other check of the arguments."""

    def error(self, message: str) -> NoReturn:
        fail(message)


def fail(message: str) -> NoReturn:
    """One line on stderr and exit status 2: the arguments are wrong."""
    print(f"score_held_out.py: error: {' '.join(message.split())}", file=sys.stderr)
    raise SystemExit(2)


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = _Parser(description=__doc__.splitlines()[0])
    parser.add_argument("meshes", type=Path, help="folder of mesh files (category = parent folder)")
    parser.add_argument("--model", action="append", default=None,
                        help="checkpoint, per-category folder or bundled name ('default', "
                        "'points'); repeatable, the first is compared with the rest "
                        "(default: default)")
    parser.add_argument("--searches", default="",
                        help="plain searches scored beside, N@R views at px, comma-separated "
                        "(default: none)")
    parser.add_argument("--out", type=Path, help="dataset folder, new or a build to resume "
                        "(default: reproduction/held_out/<folder name>)")
    parser.add_argument("--train", type=Path,
                        help="a dataset whose train split gives the best constant direction")
    parser.add_argument("--rotations", type=int, default=8, help="fixed rotations per mesh")
    parser.add_argument("--inputs", default=str(N_INPUTS),
                        help="network inputs per mesh, a comma-separated list of counts: one "
                        f"network row and rotation consistency per count (default: {N_INPUTS})")
    parser.add_argument("--views", type=int, default=1000)
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--json", type=Path, help="also write the scores here")
    add_results_option(parser, "held_out")
    args = parser.parse_args(argv)
    check_args(args)
    return args


def check_args(args: argparse.Namespace) -> None:
    """Every argument checked before the build and the scoring, each failure one line (exit 2)."""
    if not args.meshes.is_dir():
        fail(f"{args.meshes}: {'not a folder' if args.meshes.exists() else 'no such folder'}")
    for name in ("rotations", "views", "resolution", "workers"):
        if getattr(args, name) < 1:
            fail(f"--{name}: {getattr(args, name)} is not a positive integer")
    try:
        args.inputs = [int(count) for count in str(args.inputs).split(",")]
    except ValueError:
        fail(f"--inputs: {args.inputs}: expected comma-separated counts, e.g. 1,8")
    if not all(1 <= count <= 64 for count in args.inputs) or len(set(args.inputs)) < len(
            args.inputs):
        fail(f"--inputs: {args.inputs}: expected distinct counts from 1 to 64")
    if args.out is not None and args.out.exists() and not args.out.is_dir():
        fail(f"--out: {args.out}: exists and is not a folder")
    if args.out is not None and args.out.is_dir() and any(args.out.iterdir()) and not (
            (args.out / ".staging").is_dir() or (args.out / "dataset.zarr").exists()
            or (args.out / "dataset.h5").exists()):
        fail(f"--out: {args.out}: exists and holds no build to resume; give a new folder")
    args.model = args.model or [DEFAULT_MODEL]
    for model in args.model:
        if not is_bundled_model(model) and not Path(model).exists():
            fail(f"--model: {model}: no such checkpoint or folder")
    try:
        args.searches = parse_searches(args.searches)
    except SystemExit:
        fail(f"--searches: {args.searches}: expected N@R views at px, e.g. 16@32")
    if args.train is not None and not args.train.exists():
        fail(f"--train: {args.train}: no such dataset")
    for name in ("json", "results"):
        path = getattr(args, name)
        if path is not None:
            if path.is_dir():
                fail(f"--{name}: {path}: is a folder")
            if not path.parent.is_dir():
                fail(f"--{name}: {path}: folder {path.parent} does not exist")


def network_label(n_inputs: int, counts: Sequence[int], name: str = "") -> str:
    """The row of the network asked ``n_inputs`` times: ``network``, or with its count; a
    compared network's rows carry its ``name``."""
    label = f"network {name}" if name else "network"
    return label if len(counts) == 1 else f"{label}, {n_inputs} input{'s' * (n_inputs > 1)}"


def score(
    dataset_path: Path, model: str, *, rotations: int, train: Path | None = None,
    inputs: Sequence[int] = (N_INPUTS,), others: Sequence[str] = (),
    searches: Sequence[tuple[int, int]] = (),
) -> dict[str, ProtocolScores]:
    """Every row under the rotated protocol on all models of ``dataset_path``: ``model`` per
    count of ``inputs``, each of ``others`` at the last count, the baselines and the
    ``searches`` (views, px) on the stored cleaned meshes."""
    rows: dict[str, ProtocolScores] = {}
    with open_dataset(dataset_path) as dataset:
        # A per-category folder routes each mesh to its category's network.
        categories = dict(zip(dataset.names, dataset.categories))
        asked = [(model, count, network_label(count, inputs)) for count in inputs]
        asked += [(other, inputs[-1], network_label(inputs[-1], inputs, Path(other).name))
                  for other in others]
        for checkpoint, count, label in asked:
            predictor = network_predictor(checkpoint, categories=categories, n_inputs=count,
                                          dataset=dataset)
            rows[label] = score_protocol(dataset, predictor, n_rotations=rotations)
        rows["random view (expectation)"] = random_view_scores(dataset)
        rows["PCA axis"] = score_protocol(dataset, pca_predictor, n_rotations=rotations)
        if train is not None:
            with open_dataset(train) as source:
                constant = best_constant_directions(source.split("train"))
            rows["best constant direction"] = score_protocol(dataset, constant_predictor(constant),
                                                             n_rotations=rotations)
        for views, px in searches:
            rows[f"plain search {views} @ {px}"] = score_mesh_protocol(
                dataset, search_answer(views, px), n_rotations=rotations)
    return rows


CONSISTENT_DEG = 10.0
"""An answer within this angle of the resampled, rotated copy's counts as the same."""


class Consistency(NamedTuple):
    """How far a network's answers for a mesh and for its resampled, rotated copy lie apart.

    ``angles``: degrees; ``gaps``: the absolute difference of their scores
    (normalised quality of the nearest sampled view, percentage points), which
    is about 0 where the two answers are mirror images on a symmetric model.
    Both ``(n_meshes, n_measures)``.
    """

    angles: np.ndarray
    gaps: np.ndarray


def consistency(dataset_path: Path, model: str, inputs: Sequence[int]) -> dict[int, Consistency]:
    """Rotation consistency per count of network inputs.

    Compares the answer for each stored cleaned mesh (surface sampled with seed
    0) with the answer for the mesh sampled with seed 1 and turned by
    ``fixed_rotations(name, 1, seed=1)``, turned back.
    """
    per_category = not is_bundled_model(model) and (Path(model) / "categories.json").is_file()
    predictors: dict[tuple[int, int, str | None], MeshPredictor] = {}

    def answer(mesh: Mesh, category: str, count: int, seed: int) -> np.ndarray:
        key = (count, seed, category if per_category else None)
        if key not in predictors:
            predictors[key] = MeshPredictor(model, seed=seed, n_inputs=count, category=key[2])
        return predictors[key](mesh)

    angles: dict[int, list[np.ndarray]] = {count: [] for count in inputs}
    gaps: dict[int, list[np.ndarray]] = {count: [] for count in inputs}
    with open_dataset(dataset_path) as dataset:
        for i, (name, category) in enumerate(zip(dataset.names, dataset.categories)):
            vertices, faces = dataset.mesh(i)
            mesh = Mesh(np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64),
                        name=name)
            turn = fixed_rotations(name, 1, seed=1)[0]
            turned = Mesh(mesh.vertices @ turn.T, mesh.faces, name=name)
            for count in inputs:
                first = answer(mesh, category, count, 0)
                second = answer(turned, category, count, 1) @ turn
                cosines = np.sum(first * second, axis=-1)
                angles[count].append(np.degrees(np.arccos(np.clip(cosines, -1.0, 1.0))))
                scores = [np.diagonal(dataset.quality_of(i, found)) for found in (first, second)]
                gaps[count].append(100.0 * np.abs(scores[0] - scores[1]))
    return {count: Consistency(np.stack(angles[count]), np.stack(gaps[count]))
            for count in inputs}


def table(rows: dict[str, ProtocolScores], reference: str,
          angles: dict[int, Consistency] | None = None) -> str:
    """Markdown: every row ± standard error, then the ``reference`` row minus each other.

    ``*`` marks a difference beyond two standard errors. With ``angles``, a
    last table of rotation consistency per count of inputs.
    """
    scores = markdown_table(["method", *PAPER_MEASURES],
                            [[label, *score_cells(row)] for label, row in rows.items()])
    lines = [*scores, "", *comparison_table(rows, reference)]
    if angles:
        def cell(angle: np.ndarray, gap: np.ndarray) -> str:
            return (f"{np.median(angle):.1f} ({100 * np.mean(angle <= CONSISTENT_DEG):.0f} %), "
                    f"{np.mean(gap):.1f}")

        lines += ["", "Rotation consistency between the answer for a mesh and for a resampled, "
                  "rotated copy: the median angle in degrees (the share of meshes within "
                  f"{CONSISTENT_DEG:g} degrees), then the mean difference of the two answers' "
                  "scores in points.", "",
                  *markdown_table(["network inputs", *PAPER_MEASURES],
                                  [[str(count), *map(cell, found.angles.T, found.gaps.T)]
                                   for count, found in angles.items()])]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    args = parse_args(argv)
    try:
        run(args)
    except VptoolkitError as error:
        print(f"score_held_out.py: error: {one_line_error(error)}", file=sys.stderr)
        raise SystemExit(exit_code(error)) from None
    except OSError as error:
        where = f"{error.filename}: " if error.filename else ""
        print(f"score_held_out.py: error: {where}{error.strerror or error}", file=sys.stderr)
        raise SystemExit(2) from None


def run(args: argparse.Namespace) -> None:
    out = args.out or Path("reproduction/held_out") / args.meshes.resolve().name
    options = BuildOptions(MeasureSettings(views=args.views, resolution=args.resolution),
                           n_points=N_SURFACE_POINTS, clean=True, split_seed=0)
    built = build_dataset(args.meshes, out, options, workers=args.workers, progress=True)
    first, *others = args.model
    rows = score(built.path, first, rotations=args.rotations, train=args.train,
                 inputs=args.inputs, others=others, searches=args.searches)
    angles = consistency(built.path, first, args.inputs)
    reference = network_label(args.inputs[-1], args.inputs)
    heading = (f"`{args.meshes.name}`: {len(next(iter(rows.values())).names)} meshes "
               f"({built.n_failures} failed to build), cleaned, {args.views} views at "
               f"{args.resolution} px, each under {args.rotations} fixed rotations; "
               "normalised quality of the nearest sampled view in %, mean over meshes ± "
               "standard error; * marks a paired difference beyond two standard errors.")
    print(heading)
    print(table(rows, reference, angles))
    if args.results is not None:
        write_section(args.results, args.section,
                      f"Command: `{command_line(__file__)}`; "
                      f"{datetime.now(timezone.utc):%Y-%m-%d}, {machine()}.\n\n"
                      f"{heading}\n\n{table(rows, reference, angles)}")
    if args.json is not None:
        args.json.write_text(json.dumps({label: {"names": list(s.names),
                                                 "per_model": s.scores.tolist(),
                                                 "mean": s.mean.tolist(), "sem": s.sem.tolist()}
                                         for label, s in rows.items()}, indent=2))
    network = rows[reference]
    per_model = network.scores - rows["PCA axis"].scores
    print("network minus PCA per mesh (mean over measures):",
          ", ".join(f"{n} {v:+.0f}" for n, v in zip(network.names, np.mean(per_model, axis=1))))


if __name__ == "__main__":
    main()
