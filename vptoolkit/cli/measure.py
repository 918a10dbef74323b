"""Commands that measure one mesh: ``measures``, ``views``, ``clean`` and ``sample``."""

from __future__ import annotations

import math
import time
from pathlib import Path

import click

from vptoolkit.checks import check_suffix
from vptoolkit.cli.options import (
    MEASURE_NAME,
    MESH,
    max_faces_option,
    max_points_option,
    measures_option,
    points_option,
    resolution_option,
    seed_option,
    views_option,
)
from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.files import atomic_write, check_output_folder, output_json, write_json_atomic


@click.command()
@click.argument("mesh", type=MESH)
@measures_option(dest="names", help="Comma-separated measure names (VE,NVT,INS), 'all' for "
                 "every registered measure, or 'paper' for VE, VR, VKL and VMI.")
@views_option()
@resolution_option()
@click.option("--backend", type=click.Choice(["raster", "raycast"]), default="raster",
              show_default=True, help="raster: fast numba z-buffer; raycast: Open3D reference.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write views, raw and normalised measures, their names and the camera "
                   "to this .npz.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@max_points_option()
def measures(mesh: Path, names: tuple[str, ...], n_views: int, resolution: int, backend: str,
             output: Path | None, as_json: bool, max_points: int) -> None:
    """Compute viewpoint quality measures of MESH for every view; print the best views.

    By default the paper's four: VE and VR (higher is better), VKL and VMI
    (lower is better). --measures picks others of the survey by Bonaventura
    et al. (2018) by name; the table says which way each is better.
    Directions point from the model centre to the camera, in the mesh's own
    coordinates. A point cloud (a file without faces) is splatted whatever
    --backend says, its points taking the faces' place, for the measures
    defined on points (NVT, PA, HM, VR, VE, VKL, VMI, I2, I3, INS, SAL, EVMI).

    \b
    Example:
      vptool measures bunny.ply --views 1000 --resolution 512 -o bunny.npz
      vptool measures bunny.ply --measures NVT,PA,I3,INS
      vptool measures bunny.ply --measures all --json
      vptool measures scan.pcd --measures VE,VKL,VMI,INS
    """
    from vptoolkit.inputs import read_model
    from vptoolkit.measures.quality import compute_view_quality
    from vptoolkit.point_cloud import PointCloud
    from vptoolkit.settings import MeasureSettings

    settings = MeasureSettings(views=n_views, resolution=resolution,
                               backend=backend)  # type: ignore[arg-type]
    if output is not None:
        check_suffix(output, ".npz")
        check_output_folder(output, "--output")  # before the work, not after
    loaded = read_model(mesh, max_points=max_points)
    started = time.perf_counter()
    quality = compute_view_quality(loaded, settings, measures=names, progress=True)
    seconds = time.perf_counter() - started
    if output is not None:
        quality.save_npz(output)
    summary = quality.summary()
    summary["seconds"] = round(seconds, 3)
    if as_json:
        click.echo(output_json(summary, indent=2))
        return
    elements = "points" if isinstance(loaded, PointCloud) else "faces"
    click.echo(
        f"{quality.name}: {quality.n_faces} {elements}, {len(quality.views)} views at "
        f"{quality.resolution} px ({quality.backend}, {seconds:.2f} s)"
    )
    click.echo(f"{'measure':<8} {'view':>5}  {'direction (x, y, z)':<26} {'raw':>9}  best")
    for name, best in summary["best"].items():
        x, y, z = best["direction"]
        click.echo(f"{name:<8} {best['view_index']:>5}  ({x:+.3f}, {y:+.3f}, {z:+.3f})     "
                   f"{best['raw']:>9.4f}  {'max' if best['higher_is_better'] else 'min'}")
    if output is not None:
        click.echo(f"wrote {output}")


@click.command()
@click.argument("mesh", type=MESH)
@click.option("--k", "k", type=click.IntRange(1),
              help="Number of views [default: 4, or no limit with --coverage].")
@click.option("--objective", type=click.Choice(["coverage", "information", "quality"]),
              default="coverage", show_default=True,
              help="coverage: area seen; information: entropy of the views' joint face "
                   "distribution; quality: coverage, preferring good --measure views.")
@click.option("--coverage", "target", type=click.FloatRange(0, 1, min_open=True),
              help="Add views until the set sees this fraction of what all views see.")
@click.option("--measure", default="VE", show_default=True, type=MEASURE_NAME,
              help="Measure of the quality objective (its best view is the first pick).")
@views_option()
@resolution_option()
@click.option("--min-pixels", default=1, show_default=True, type=click.IntRange(1),
              help="Pixels a face needs in a view to count as seen.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write indices, directions and cumulative coverage to this .npz.")
@click.option("--json", "as_json", is_flag=True, help="Print the set as JSON.")
@max_points_option()
def views(mesh: Path, k: int | None, objective: str, target: float | None, measure: str,
          n_views: int, resolution: int, min_pixels: int, output: Path | None,
          as_json: bool, max_points: int) -> None:
    """Choose views of MESH that together show the whole model.

    A greedy search over the sampled views: each pick adds the view that best
    complements the ones before. Prints, per pick, the view, its direction and
    the area-weighted fraction of the surface seen so far. For a point cloud,
    the points (splatted) take the faces' place, each weighing the area of
    surface it stands for.

    \b
    Example:
      vptool views bunny.ply --k 4 -o bunny_views.npz
      vptool views chair.off --coverage 0.95 --objective quality
    """
    from vptoolkit.inputs import read_model
    from vptoolkit.point_cloud import PointCloud
    from vptoolkit.settings import MeasureSettings
    from vptoolkit.view_sets.search import measure_view_set

    settings = MeasureSettings(views=n_views, resolution=resolution)
    if target is not None and not math.isfinite(target):
        raise InputError(f"--coverage: must lie in (0, 1], got {target}")
    if output is not None:
        check_suffix(output, ".npz")
        check_output_folder(output, "--output")  # before drawing the views
    loaded = read_model(mesh, max_points=max_points)
    started = time.perf_counter()
    _, view_set = measure_view_set(
        loaded, 4 if k is None and target is None else k, settings=settings,
        progress=True, objective=objective, until_coverage=target,
        measure=measure, min_pixels=min_pixels)
    seconds = time.perf_counter() - started
    if view_set.reachable == 0:
        raise MeasurementError(f"{mesh}: no face has {min_pixels} pixels in any of the "
                               f"{n_views} views; lower --min-pixels or raise --resolution")
    if output is not None:
        view_set.save_npz(output)
    if as_json:
        click.echo(output_json({**view_set.summary(), "seconds": round(seconds, 3)}, indent=2))
        return
    elements = (f"{loaded.n_points} points" if isinstance(loaded, PointCloud)
                else f"{loaded.n_faces} faces")
    click.echo(f"{loaded.name}: {elements}, {n_views} views at {resolution} px, "
               f"{objective} objective ({seconds:.2f} s)")
    bits = objective == "information"
    click.echo(f"{'pick':<5} {'view':>5}  {'direction (x, y, z)':<26} {'coverage':>9}"
               + (f" {'H bits':>8}" if bits else ""))
    for pick in view_set.summary()["picks"]:
        x, y, z = pick["direction"]
        entropy = f" {pick['score']:>8.3f}" if bits else ""
        click.echo(f"{pick['pick']:<5} {pick['view_index']:>5}  ({x:+.3f}, {y:+.3f}, {z:+.3f})   "
                   f"{100 * pick['coverage']:>7.1f} %{entropy}")
    click.echo(f"reachable: {100 * view_set.reachable:.1f} % of the surface "
               f"(all {n_views} views together)")
    if output is not None:
        click.echo(f"wrote {output}")


@click.command()
@click.argument("source", type=MESH)
@click.argument("target", type=click.Path(dir_okay=False, path_type=Path))
@max_faces_option("Face budget after decimation.")
@click.option("--remesh", is_flag=True, help="Also remesh isotropically after decimation.")
@click.option("--report", "report_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Write the cleaning report as JSON to this file.")
@click.option("--json", "as_json", is_flag=True,
              help="Print the file, name, output and the cleaning report as JSON.")
def clean(source: Path, target: Path, max_faces: int, remesh: bool,
          report_path: Path | None, as_json: bool) -> None:
    """Clean SOURCE in the paper's three steps and write it to TARGET.

    Repair (duplicates, non-manifold parts, self-intersections), remove faces
    no view sees, then decimate to at most --max-faces faces. TARGET's suffix
    picks the format (.off, .ply, .obj, .stl). --json prints one record: file
    (SOURCE), name, output (TARGET), then the report (faces before and after,
    seconds, self-intersections, hidden area removed, faces flipped, and per
    step its faces and vertices before and after and seconds).

    \b
    Example:
      vptool clean airplane_0001.off airplane_0001_clean.ply --report report.json
      vptool clean bunny.ply bunny_clean.ply --max-faces 3000 --json
    """
    from vptoolkit.clean import clean_mesh
    from vptoolkit.inputs import read_model
    from vptoolkit.io import save_mesh

    check_output_folder(target, "TARGET")
    if report_path is not None:
        check_output_folder(report_path, "--report")  # before writing the mesh
    cleaned, report = clean_mesh(read_model(source, requires="surface"), max_faces=max_faces,
                                 remesh=remesh)
    save_mesh(cleaned, target)
    record = report.to_dict()
    if report_path is not None:
        write_json_atomic(report_path, record, sort_keys=False)
    if as_json:
        click.echo(output_json({"file": str(source), "name": record["name"],
                                "output": str(target), **record}, indent=2))
        return
    for step in record["steps"]:
        click.echo(f"{step['name']:<14} faces {step['faces_before']:>8} -> {step['faces_after']:<8}"
                   f" {step['seconds']:7.2f} s")
    click.echo(f"wrote {target} ({cleaned.n_faces} faces)")


@click.command()
@click.argument("mesh", type=MESH)
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Write the points to this .npy file.")
@points_option()
@seed_option(minimum=0)
@click.option("--json", "as_json", is_flag=True,
              help="Print the file, name, output, points written, seed and seconds as JSON.")
def sample(mesh: Path, output: Path, n_points: int, seed: int, as_json: bool) -> None:
    """Sample points uniformly by area on MESH, with face normals.

    OUTPUT is a float32 .npy array of shape (N, 6): x, y, z, nx, ny, nz in the
    mesh's own coordinates. The same seed always gives the same points.
    --json prints one record: file (MESH), name, output, points (N), seed
    and seconds (reading, sampling and writing).

    \b
    Example:
      vptool sample bunny.ply -o bunny_points.npy --points 20000 --seed 0
      vptool sample bunny.ply -o bunny_points.npy --json
    """
    import numpy as np

    from vptoolkit.inputs import read_model
    from vptoolkit.points import sample_surface

    check_suffix(output, ".npy")
    check_output_folder(output, "--output")
    started = time.perf_counter()
    model = read_model(mesh, requires="surface")
    surface = sample_surface(model, n_points, seed=seed)
    table = np.hstack([surface.points, surface.normals]).astype(np.float32)
    with atomic_write(output) as handle:
        np.save(handle, table, allow_pickle=False)
    seconds = time.perf_counter() - started
    if as_json:
        click.echo(output_json({"file": str(mesh), "name": model.name, "output": str(output),
                                "points": len(table), "seed": seed,
                                "seconds": round(seconds, 3)}, indent=2))
        return
    click.echo(f"wrote {output} ({n_points} points with normals)")

COMMANDS = (measures, views, clean, sample)
"""The commands this module adds to ``vptool``."""
