"""Make the point-cloud benchmark data: labels of cleaned meshes and rotated clouds of each.

For the models of one split of a mesh collection (a ``name,split`` CSV):

1. ``OUT/meshes/``: links to the models' files at their paths under the
   collection (so each keeps its name and category), the source of
2. ``OUT/labels/``: a dataset store built from them (``vptool build-dataset``'s
   :func:`~vptoolkit.dataset.builder.run.build_dataset`: cleaned meshes, their
   20000 area-uniform surface points with normals and the paper's four
   measures over ``--views`` views at ``--resolution`` px, the split kept
   from the CSV); rerunning resumes it;
3. ``OUT/clouds/<name>_r<k>_uniform.npz`` and ``<name>_r<k>_scan.npz`` for the
   ``--rotations`` fixed rotations ``R_k`` of each model
   (:func:`vptoolkit.rotations.fixed_rotations`, as the rotated evaluation
   protocol draws them): the store's uniform points turned by ``R_k``, and a
   virtual scan (:func:`vptoolkit.scan.virtual_scan`) of the turned cleaned
   mesh from ``--scans`` scanners seeded by the model and ``k``. Each file
   holds ``points (n, 3) float32``, ``normals (n, 3) float32`` and ``rotation
   (3, 3) float64`` (rows turn as ``v @ rotation.T``), and ``seed``, the
   scan's seed (-1 for the uniform cloud). Files already there are kept.

``OUT/manifest.json`` records the arguments and the models. The labels are
those of the unturned mesh: the labels of a turned cloud are its store row's
with the view directions turned by ``R_k``.

Usage::

    python tools/make_point_benchmark_data.py --quick OUT
    python tools/make_point_benchmark_data.py OUT --meshes MESH_FOLDER \\
        --splits docs/splits/shapedb.csv --split validation
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vptoolkit.conventions import model_name
from vptoolkit.data import open_dataset
from vptoolkit.dataset.builder.options import BuildOptions, SplitFile
from vptoolkit.dataset.builder.run import build_dataset
from vptoolkit.files import write_bytes_atomic, write_json_atomic
from vptoolkit.io import find_mesh_files
from vptoolkit.mesh import Mesh
from vptoolkit.points import N_SURFACE_POINTS
from vptoolkit.progress import progress_bar
from vptoolkit.rotations import fixed_rotations, model_key
from vptoolkit.samples import SAMPLE_SPLITS
from vptoolkit.scan import SCAN_NOISE, SCAN_RESOLUTION, virtual_scan
from vptoolkit.settings import MeasureSettings

SAMPLES = Path(__file__).resolve().parents[1] / "vptoolkit" / "samples"


def parse(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="output folder (resumed when it exists)")
    parser.add_argument("--meshes", type=Path, help="folder of the mesh collection")
    parser.add_argument("--splits", type=Path, help="name,split CSV of the collection")
    parser.add_argument("--split", default="validation",
                        help="split to take (default: validation)")
    parser.add_argument("--views", type=int, default=1000,
                        help="views of the labels (default: 1000)")
    parser.add_argument("--resolution", type=int, default=256,
                        help="image side of the labels in px (default: 256)")
    parser.add_argument("--rotations", type=int, default=4, help="fixed rotations (default: 4)")
    parser.add_argument("--scans", type=int, default=3,
                        help="scanners per virtual scan (default: 3)")
    parser.add_argument("--scan-resolution", type=int, default=SCAN_RESOLUTION,
                        help=f"range image side in px (default: {SCAN_RESOLUTION})")
    parser.add_argument("--noise", type=float, default=SCAN_NOISE,
                        help=f"scan noise over the diagonal (default: {SCAN_NOISE})")
    parser.add_argument("--workers", type=int, default=1, help="build processes (default: 1)")
    parser.add_argument("--quick", action="store_true",
                        help="the bundled samples' validation split, 50 views at 64 px")
    args = parser.parse_args(argv)
    if args.quick:
        args.meshes, args.splits, args.views, args.resolution = SAMPLES, SAMPLE_SPLITS, 50, 64
    if args.meshes is None or args.splits is None:
        parser.error("give --meshes and --splits, or --quick")
    return args


def link_models(meshes: Path, splits: Path, split: str, links: Path) -> int:
    """Link the files of the ``split`` models under ``links``, at their paths under ``meshes``.

    A file is a model of the CSV when its build name
    (:func:`~vptoolkit.dataset.builder.sources.model_name` of its path under
    ``meshes``) is; returns how many were linked.
    """
    with splits.open(newline="", encoding="utf-8") as stream:
        wanted = {row["name"] for row in csv.DictReader(stream) if row["split"] == split}
    count = 0
    for path in find_mesh_files(meshes):
        relative = path.relative_to(meshes)
        if model_name(relative.as_posix()) not in wanted:
            continue
        target = links / relative
        target.parent.mkdir(parents=True, exist_ok=True)
        if not target.is_symlink():
            target.symlink_to(path.resolve())
        count += 1
    missing = len(wanted) - count
    if missing:
        print(f"{splits}: {missing} models of split {split!r} have no file under {meshes}",
              file=sys.stderr)
    return count


def write_cloud(path: Path, points: np.ndarray, normals: np.ndarray, rotation: np.ndarray,
                seed: int) -> None:
    import io

    buffer = io.BytesIO()
    np.savez_compressed(buffer, points=points.astype(np.float32),
                        normals=normals.astype(np.float32), rotation=rotation,
                        seed=np.int64(seed))
    write_bytes_atomic(path, buffer.getvalue())


def make_clouds(store: Path, clouds: Path, args: argparse.Namespace) -> list[str]:
    """Write the rotated uniform clouds and scans of every model of the store; their names."""
    dataset = open_dataset(store)
    clouds.mkdir(parents=True, exist_ok=True)
    names = dataset.names
    with progress_bar(total=len(names), description="clouds", unit="model") as bar:
        for name in names:
            item = dataset[name]
            vertices, faces = dataset.mesh(name)
            mesh = Mesh(vertices.astype(np.float64), faces.astype(np.int64), name=name)
            for k, rotation in enumerate(fixed_rotations(name, args.rotations)):
                uniform = clouds / f"{name}_r{k}_uniform.npz"
                if not uniform.exists():
                    write_cloud(uniform, item["points"] @ rotation.T,
                                item["normals"] @ rotation.T, rotation, -1)
                scan = clouds / f"{name}_r{k}_scan.npz"
                if not scan.exists():
                    seed = (model_key(name) + k) % 2**63
                    turned = Mesh(mesh.vertices @ rotation.T, mesh.faces, name=name)
                    points, normals = virtual_scan(turned, args.scans,
                                                   resolution=args.scan_resolution,
                                                   noise=args.noise, seed=seed)
                    write_cloud(scan, points, normals, rotation, seed)
            bar.update(1)
    return names


def main(argv: Sequence[str] | None = None) -> int:
    args = parse(argv)
    out: Path = args.out
    n_linked = link_models(args.meshes, args.splits, args.split, out / "meshes")
    print(f"{n_linked} models of split {args.split!r}", file=sys.stderr)
    options = BuildOptions(MeasureSettings(views=args.views, resolution=args.resolution),
                           n_points=N_SURFACE_POINTS, clean=True,
                           splits=SplitFile.read(args.splits))
    built = build_dataset(out / "meshes", out / "labels", options, workers=args.workers,
                          progress=True)
    names = make_clouds(built.path, out / "clouds", args)
    manifest = {
        "labels": str(built.path.relative_to(out)),
        "failures": built.n_failures,
        "split": args.split, "splits_file": str(args.splits),
        "views": args.views, "resolution": args.resolution,
        "rotations": args.rotations, "scans": args.scans,
        "scan_resolution": args.scan_resolution, "noise": args.noise,
        "models": names,
    }
    write_json_atomic(out / "manifest.json", manifest)
    print(f"{len(names)} models, {built.n_failures} failed to build: {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
