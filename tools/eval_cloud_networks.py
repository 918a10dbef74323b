"""Which network answers a bare point cloud best: the bundled ones, networks trained on
what a cloud carries, and the face-area network fed each point's local-spacing area.

The bundled ``default`` network reads each point's face area
(:func:`vptoolkit.point_features.face_area_feature`: ``clip(ln(A_f / A_mean) / 2,
-3, 3)``), which a bare cloud does not carry; ``points`` reads coordinates
alone. A cloud does carry the area each point stands for, from its local
spacing (:func:`vptoolkit.point_areas.point_areas`, ``A_i = pi d_8^2 / 8``);
one row feeds the ``default`` network that area in place of the face area,
normalised the same way (``clip(ln(A_i / mean_j A_j) / 2, -3, 3)``), without
retraining. Each ``--model`` adds a checkpoint, which reads the features a
cloud carries (:data:`vptoolkit.point_features.CLOUD_FEATURES`, computed from
the cloud as :func:`vptoolkit.learn.predict.cloud_surface` does) or none. All
are scored on the validation clouds of a point benchmark folder
(``tools/make_point_benchmark_data.py``: ``manifest.json``, ``labels/``,
``clouds/<name>_r<k>_{uniform,scan}.npz``) as ``tools/bench_point_clouds.py``
does: each network answers the rotated cloud (the consensus of ``--inputs``
inputs, default ``N_INPUTS``, :mod:`vptoolkit.learn.draws`), the answer is turned back by the
cloud's rotation and scores the normalised quality of the nearest labelled
view in % (:meth:`vptoolkit.data.ViewpointDataset.quality_of`), mean ±
standard error over models, and every network is compared with ``points``
paired over models (:func:`vptoolkit.evaluate.protocol.paired_difference`).

Usage::

    python tools/eval_cloud_networks.py /work/bench-data/shapedb --rotations 1 \\
        --model runs/cloud_features --model runs/coordinates \\
        --results docs/results.md --section cloud_networks
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
from results_doc import (
    add_results_option,
    command_line,
    format_seconds,
    machine,
    markdown_table,
    score_cells,
    write_section,
)

from vptoolkit.data import open_dataset
from vptoolkit.errors import InputError, VptoolkitError
from vptoolkit.evaluate.protocol import ProtocolScores, paired_difference
from vptoolkit.learn.consensus import consensus_directions
from vptoolkit.learn.draws import N_INPUTS, network_inputs
from vptoolkit.learn.model import load_model
from vptoolkit.learn.predict import predict_directions
from vptoolkit.point_features import point_features, spacing_area_feature
from vptoolkit.progress import progress_bar

KINDS = ("uniform", "scan")
COORDINATES = "points: coordinates alone"
SPACING = "default: spacing area as face area"


def spacing_feature(points: np.ndarray) -> np.ndarray:
    """The spacing area normalised as the face area is, ``(n, 1) float32``
    (:func:`vptoolkit.point_features.spacing_area_feature`)."""
    return spacing_area_feature(points)[:, None]


def difference_cells(scores: ProtocolScores, reference: ProtocolScores) -> list[str]:
    """``scores`` minus ``reference`` per measure, paired over models, starred beyond 2 SE."""
    delta, sem = paired_difference(scores, reference)
    return [f"{d:+.1f} ± {e:.1f}{' *' if abs(d) > 2 * e else ''}" for d, e in zip(delta, sem)]


def _label(path: Path) -> str:
    """A checkpoint's row label: its folder's name, or the file's stem."""
    return path.name if path.is_dir() else path.stem


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source", type=Path, help="a point benchmark folder")
    parser.add_argument("--models", type=int, help="the first N models (default: all)")
    parser.add_argument("--rotations", type=int, default=1,
                        help="the first rotations of each model (default: 1)")
    parser.add_argument("--model", action="append", default=[], type=Path,
                        help="another checkpoint to score, labelled by its folder's name "
                             "(repeatable)")
    parser.add_argument("--inputs", type=int, default=N_INPUTS,
                        help=f"network inputs per cloud, their consensus answers (default: "
                             f"{N_INPUTS})")
    parser.add_argument("--versus", action="append", default=[],
                        help="also compare every network with this row, paired (a --model's "
                             "label, repeatable; `points` always)")
    parser.add_argument("--json", type=Path, help="write every model's scores here")
    add_results_option(parser, "cloud_networks")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    try:
        manifest = json.loads((args.source / "manifest.json").read_text(encoding="utf-8"))
        full = open_dataset(args.source / manifest["labels"])
        names = full.names[: args.models] if args.models else full.names
        dataset = full.subset(names)
        rotations = min(args.rotations, int(manifest["rotations"]))
        networks = {COORDINATES: load_model("points"), SPACING: load_model("default")}
        for path in args.model:
            networks[_label(path)] = load_model(path)
        unknown = [label for label in args.versus if label not in networks]
        if unknown:
            raise InputError(f"--versus: {', '.join(unknown)} is not a row; rows: "
                             f"{', '.join(networks)}")
        totals = {(kind, label): np.zeros((len(dataset), len(dataset.measures)))
                  for kind in KINDS for label in networks}
        with progress_bar(total=len(dataset) * rotations, description="clouds",
                          unit="rotation") as bar:
            for row, name in enumerate(dataset.names):
                for k in range(rotations):
                    for kind in KINDS:
                        with np.load(args.source / "clouds" / f"{name}_r{k}_{kind}.npz",
                                     allow_pickle=False) as arrays:
                            points = np.asarray(arrays["points"], np.float64)
                            rotation = np.asarray(arrays["rotation"], np.float64)
                        for label, (model, config) in networks.items():
                            features = (spacing_feature(points) if label == SPACING
                                        else point_features(points, model.config.point_features)
                                        if model.config.point_features else None)
                            inputs = network_inputs(points, n_points=config["input"]["n_points"],
                                                    n_fps=config["input"]["n_fps"], seed=0,
                                                    name=name, n_inputs=args.inputs,
                                                    features=features)
                            answer = consensus_directions(
                                predict_directions(model, inputs)[None])[0]
                            totals[kind, label][row] += 100.0 * np.diagonal(
                                dataset.quality_of(row, answer @ rotation))
                    bar.update(1)
    except VptoolkitError as error:
        print(f"eval_cloud_networks: error: {error}", file=sys.stderr)
        return 2
    scores = {key: ProtocolScores(tuple(dataset.names), tuple(dataset.categories),
                                  total / rotations, rotations, dataset.measures)
              for key, total in totals.items()}
    lines = [
        f"## Networks for bare point clouds, `{args.source.name}/`",
        "",
        f"Command: `{command_line(__file__, argv)}`; {datetime.now(timezone.utc):%Y-%m-%d}, "
        f"{machine()}; wall time {format_seconds(time.perf_counter() - started)}.",
        "",
        f"{len(dataset)} models, {rotations} fixed rotation{'' if rotations == 1 else 's'} "
        f"each; labels: cleaned mesh, {len(dataset.views)} views. Each network answers the "
        f"rotated cloud (the consensus of {args.inputs} inputs), turned back, and scores the "
        "normalised quality of the nearest labelled view, in %, mean ± standard error over "
        "models. `points` reads coordinates alone; `default` (trained on each point's face "
        "area) is fed each point's local-spacing area (`point_areas`, k = 8) normalised as "
        "the face area is, `clip(ln(A_i / mean A) / 2, -3, 3)`, without retraining. "
        "Any other network reads the cloud features it was trained on (`spacing_area`, "
        "`estimated_normal`), computed from the whole cloud, or none.",
        "",
    ]
    for kind in KINDS:
        rows = {label: scores[kind, label] for label in networks}
        lines += [f"### {kind} clouds", ""]
        lines += markdown_table(["network", "VE", "VR", "VKL", "VMI"],
                                ([label, *score_cells(s)] for label, s in rows.items()))
        for reference in (COORDINATES, *args.versus):
            lines += ["", f"Paired over models, each network minus `{reference}`, difference "
                      "± standard error in points (* beyond two standard errors):", ""]
            lines += markdown_table([f"network minus {reference}", "VE", "VR", "VKL", "VMI"],
                                    ([label, *difference_cells(rows[label], rows[reference])]
                                     for label in rows if label != reference))
        lines += [""]
    text = "\n".join(lines).rstrip()
    print(text)
    if args.results is not None:
        write_section(args.results, args.section, text)
    if args.json is not None:
        args.json.write_text(json.dumps(
            {f"{kind} / {label}": {"names": list(dataset.names),
                                   "scores": scores[kind, label].scores.tolist()}
             for kind, label in scores}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
