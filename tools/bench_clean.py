"""Benchmark of :func:`vptoolkit.clean.clean_mesh`: seconds and faces per step.

Builds toy airplanes of about 10k, 50k and 400k faces from trimesh primitives
(a capsule fuselage pierced by box wings and tail, with seats hidden inside,
so every step has work to do) and cleans each one. Real meshes can be added
with ``--mesh PATH`` (repeatable), e.g. raw ModelNet40 airplanes.

For every mesh it prints the face count after each step, the seconds per
step, self-intersections before and after, and the ratio of the total time to
a baseline measured in the same run: one plain visibility pass over the same
mesh (1000 views at the same resolution, one-sided), the unit of work that
step 2 repeats on a doubled mesh.

``--baseline DIR`` also cleans every mesh with the vptoolkit checked out in
DIR (``git worktree add DIR REV``), in a child process run there, just before
this code cleans it, and prints that row (``base``) above this code's with
the ratio of the totals. ``--repeat N`` keeps the fastest of N cleanings per
mesh and code (after one untimed warm-up in the child), which damps the noise
of a shared machine; the baseline pass and the ratio to it are timed once.

Usage::

    python tools/bench_clean.py
    python tools/bench_clean.py --sizes 10000 --mesh path/to/airplane_0001.off
    python tools/bench_clean.py --sizes --mesh airplane_0001.off --baseline /tmp/base --repeat 3
    python tools/bench_clean.py --json results.json
    python tools/bench_clean.py --results docs/benchmarks.md   # and its section ``clean``
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh
from results_doc import add_results_option, printed_section

from vptoolkit.clean import clean_mesh
from vptoolkit.mesh import Mesh
from vptoolkit.settings import MeasureSettings

DEFAULT_SIZES = (10_000, 50_000, 400_000)


def toy_airplane(n_faces: int) -> Mesh:
    """A self-intersecting airplane of about ``n_faces`` faces with hidden seats.

    Parameters
    ----------
    n_faces : int
        Approximate face count; the fuselage takes about 60% of it and the
        boxes are subdivided to a matching edge length.

    Returns
    -------
    Mesh
        Named ``toy_airplane_<n_faces>``.
    """
    fuselage_faces = 0.6 * n_faces
    count = max(8, int(math.sqrt(fuselage_faces / 2.0)))  # about 2 count^2 faces
    fuselage = trimesh.creation.capsule(height=8.0, radius=1.0, count=[count, count])
    fuselage.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0]))
    wing = trimesh.creation.box(extents=[2.0, 12.0, 0.25])
    tail_fin = trimesh.creation.box(extents=[1.2, 0.2, 2.5])
    tail_fin.apply_translation([-4.2, 0.0, 1.2])
    stabilizer = trimesh.creation.box(extents=[1.0, 4.0, 0.15])
    stabilizer.apply_translation([-4.4, 0.0, 0.3])
    seats = []
    for row in range(6):
        for side in (-0.45, 0.45):
            seat = trimesh.creation.box(extents=[0.4, 0.4, 0.5])
            seat.apply_translation([-2.5 + row * 0.9, side, -0.3])
            seats.append(seat)
    boxes = [wing, tail_fin, stabilizer, *seats]
    box_area = sum(float(box.area) for box in boxes)
    box_budget = max(n_faces - len(fuselage.faces), 12 * len(boxes))
    # Right triangles of legs L have area L^2 / 2; refine the guess twice.
    edge = math.sqrt(2.0 * box_area / box_budget)
    for _ in range(3):
        subdivided = [
            trimesh.remesh.subdivide_to_size(box.vertices, box.faces, max_edge=edge)
            for box in boxes
        ]
        made = sum(len(faces) for _, faces in subdivided)
        edge *= math.sqrt(made / box_budget)
    parts = [fuselage]
    parts += [trimesh.Trimesh(vertices, faces, process=False) for vertices, faces in subdivided]
    vertices = np.vstack([part.vertices for part in parts])
    offsets = np.cumsum([0] + [len(part.vertices) for part in parts[:-1]])
    faces = np.vstack([part.faces + offset for part, offset in zip(parts, offsets)])
    return Mesh(vertices, faces, name=f"toy_airplane_{n_faces}")


def baseline_seconds(mesh: Mesh, resolution: int) -> float:
    """Seconds of one plain visibility pass over ``mesh``: 1000 views, no cleaning."""
    from vptoolkit.visibility import face_pixel_totals

    start = time.perf_counter()
    face_pixel_totals(mesh, MeasureSettings(resolution=resolution))
    return time.perf_counter() - start


def bench_one(
    mesh: Mesh, *, max_faces: int, resolution: int, repeat: int = 1
) -> dict[str, object]:
    """Clean ``mesh`` ``repeat`` times and return the fastest report plus the baseline."""
    baseline = baseline_seconds(mesh, resolution)
    reports = [
        clean_mesh(mesh, max_faces=max_faces, settings=MeasureSettings(resolution=resolution))[1]
        for _ in range(repeat)
    ]
    report = min(reports, key=lambda report: report.seconds)
    record = report.to_dict()
    record["baseline_seconds"] = baseline
    record["ratio_to_baseline"] = report.seconds / baseline if baseline > 0 else float("nan")
    return record


_CHILD_CLEAN = """
import inspect, json, sys
import numpy as np
import vptoolkit
from vptoolkit.clean import clean_mesh
from vptoolkit.mesh import Mesh
data = np.load(sys.argv[1])
mesh = Mesh(data["vertices"], data["faces"], name=str(data["name"]))
options, repeat = json.loads(sys.argv[2]), int(sys.argv[3])
resolution = options.pop("resolution")
if "settings" in inspect.signature(clean_mesh).parameters:
    from vptoolkit.settings import MeasureSettings
    options["settings"] = MeasureSettings(resolution=resolution)
else:  # code from before clean_mesh took MeasureSettings
    options["hidden_resolution"] = resolution
clean_mesh(mesh, **options)  # warm-up: numba's kernels, pymeshlab's first use
reports = [clean_mesh(mesh, **options)[1] for _ in range(repeat)]
record = min(reports, key=lambda report: report.seconds).to_dict()
record["code"] = vptoolkit.__file__
print(json.dumps(record))
"""


def bench_baseline(
    code: Path, mesh: Mesh, *, max_faces: int, resolution: int, repeat: int
) -> dict[str, object]:
    """Clean ``mesh`` with the vptoolkit checked out at ``code``, in a child process run there."""
    with tempfile.TemporaryDirectory(prefix="bench_clean_") as scratch:
        path = Path(scratch) / "mesh.npz"
        np.savez(path, vertices=mesh.vertices, faces=mesh.faces, name=mesh.name)
        options = {"max_faces": max_faces, "resolution": resolution}
        done = subprocess.run(
            [sys.executable, "-c", _CHILD_CLEAN, str(path), json.dumps(options), str(repeat)],
            env={**os.environ, "PYTHONPATH": str(code)}, cwd=code,
            capture_output=True, text=True, check=False,
        )
    if done.returncode != 0:
        raise SystemExit(f"bench_clean: the baseline cleaning failed:\n{done.stderr.strip()}")
    record: dict[str, object] = json.loads(done.stdout.strip().splitlines()[-1])
    if not Path(str(record["code"])).resolve().is_relative_to(code.resolve()):
        raise SystemExit(f"bench_clean: the baseline child imported {record['code']}, not {code}")
    return record


def _format(record: dict[str, object], label: str = "") -> str:
    steps = record["steps"]
    assert isinstance(steps, list)
    cells = [f"{label + str(record['name']):<22} {record['faces_before']:>7}"]
    for step in steps:
        cells.append(f"{step['faces_after']:>7} {step['seconds']:>6.2f}s")
    ratio = record.get("ratio_to_baseline", float("nan"))
    cells.append(
        f"{record['seconds']:>7.2f}s {ratio:>6.1f}x "
        f"{record['self_intersections_before']:>6} -> {record['self_intersections_after_repair']}"
        f" / {record['self_intersections_after']:<5} {record['self_intersection_method']}"
    )
    return " | ".join(cells)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--sizes", type=int, nargs="*", default=list(DEFAULT_SIZES),
        help="face counts of the toy airplanes (default: 10000 50000 400000)",
    )
    parser.add_argument(
        "--mesh", type=Path, action="append", default=[],
        help="also clean this mesh file (repeatable)",
    )
    parser.add_argument(
        "--max-faces", type=int, default=10_000, help="face budget (default: 10000)"
    )
    parser.add_argument(
        "--resolution", type=int, default=256, help="hidden-face image side (default: 256)"
    )
    parser.add_argument("--json", type=Path, help="also write the records to this JSON file")
    parser.add_argument(
        "--baseline", type=Path,
        help="a checkout of older vptoolkit code to clean each mesh with first (see above)",
    )
    parser.add_argument(
        "--repeat", type=int, default=1, help="cleanings per mesh and code; the fastest counts"
    )
    add_results_option(parser, "clean")
    args = parser.parse_args(argv)
    if args.baseline is not None and not (args.baseline / "vptoolkit" / "__init__.py").is_file():
        parser.error(f"--baseline: {args.baseline} holds no vptoolkit package")

    with printed_section(args.results, args.section):
        meshes = [toy_airplane(size) for size in args.sizes]
        if args.mesh:
            from vptoolkit.io import load_mesh

            meshes += [load_mesh(path) for path in sorted(args.mesh)]

        header = (
            f"{'mesh':<22} {'faces':>7} | {'repair':>15} | {'remove_hidden':>15} | "
            f"{'simplify':>15} | {'total':>8} {'/base':>7} {'self-intersections':>20}"
        )
        print(header)
        print("-" * len(header))
        records = []
        for mesh in meshes:
            if args.baseline is not None:
                base = bench_baseline(args.baseline, mesh, max_faces=args.max_faces,
                                      resolution=args.resolution, repeat=args.repeat)
                print(_format(base, "base "), flush=True)
            record = bench_one(
                mesh, max_faces=args.max_faces, resolution=args.resolution, repeat=args.repeat
            )
            if args.baseline is not None:
                record["baseline_code"] = base
                record["speed_up_over_baseline_code"] = float(base["seconds"]) / record["seconds"]
            records.append(record)
            print(_format(record), flush=True)
            if args.baseline is not None:
                print(f"{'':<22} this code is {record['speed_up_over_baseline_code']:.2f}x "
                      "as fast as the baseline code", flush=True)
        print(
            "\ncolumns: faces after each step and its seconds; total seconds and ratio to one\n"
            "plain visibility pass; self-intersections before -> after repair / after simplify."
        )
        if args.json:
            args.json.write_text(json.dumps(records, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
