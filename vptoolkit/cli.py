"""The ``vptool`` command line.

Each command parses its options, calls one library function and prints a
short result. Errors become one line on stderr and an exit code:
0 success, 1 a measurement or verification failure, 2 bad input or a missing
dependency. Heavy packages are imported inside the commands, so ``--help``
stays fast.
"""

from __future__ import annotations

import errno
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import click

from vptoolkit.errors import (
    InputError,
    MeasurementError,
    MissingDependencyError,
    VerificationError,
    VptoolkitError,
)
from vptoolkit.checks import check_npy_header, check_suffix, one_line
from vptoolkit.files import atomic_write, check_output_folder, write_text_atomic

EXIT_FAILURE = 1
EXIT_BAD_INPUT = 2


def _exit_code(error: BaseException) -> int:
    if isinstance(error, (InputError, MissingDependencyError)):
        return EXIT_BAD_INPUT
    if isinstance(error, VerificationError) and isinstance(error.__cause__, RuntimeError) \
            and "weights do not match the architecture" in str(error):
        return EXIT_BAD_INPUT  # a checkpoint whose JSON disagrees with its weights: a bad file
    if isinstance(error, (MeasurementError, VerificationError)):
        return EXIT_FAILURE
    return EXIT_FAILURE


class _Group(click.Group):
    """A click group that turns toolkit errors into one line and an exit code."""

    def main(self, args: Any = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True,
             **extra: Any) -> Any:
        """Run the command line; option errors become the same one line as every other error."""
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        try:
            returned = super().main(args, prog_name, complete_var, False, **extra)
        except click.UsageError as error:
            where = (f"{error.ctx.info_name}: "
                     if error.ctx is not None and error.ctx.parent is not None else "")
            click.echo(f"vptool: error: {where}{one_line(error.format_message())}", err=True)
            sys.exit(EXIT_BAD_INPUT)
        except click.ClickException as error:
            click.echo(f"vptool: error: {one_line(error.format_message())}", err=True)
            sys.exit(error.exit_code)
        except click.Abort:
            click.echo("vptool: error: aborted", err=True)
            sys.exit(EXIT_FAILURE)
        sys.exit(returned if isinstance(returned, int) else 0)

    def invoke(self, context: click.Context) -> Any:
        try:
            return super().invoke(context)
        except VptoolkitError as error:
            click.echo(f"vptool: error: {one_line_error(error)}", err=True)
            sys.exit(_exit_code(error))
        except ModuleNotFoundError as error:
            click.echo(f"vptool: error: {_missing_module_line(error)}", err=True)
            sys.exit(EXIT_BAD_INPUT)
        except OSError as error:
            where = f"{error.filename}: " if error.filename else ""
            click.echo(f"vptool: error: {where}{one_line(error.strerror or error)}", err=True)
            sys.exit(EXIT_BAD_INPUT)
        except MemoryError:
            click.echo(f"vptool: error: {context.invoked_subcommand or 'vptool'}: not enough "
                       "memory for these options; ask for less", err=True)
            sys.exit(EXIT_BAD_INPUT)


def one_line_error(error: BaseException) -> str:
    """The message of an error on one line, without the length cap of :func:`one_line`."""
    return " ".join(str(error).replace("<br>", " ").split()) or type(error).__name__


class _Path(click.Path):
    """click.Path that names a symlink loop instead of saying the path does not exist."""

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> Any:
        try:
            os.stat(os.fspath(value))
        except OSError as err:
            if err.errno == errno.ELOOP:
                self.fail(f"{os.fsdecode(value)}: symbolic link loop ({err.strerror})", param, ctx)
        return super().convert(value, param, ctx)


def _missing_module_line(error: ModuleNotFoundError) -> str:
    """One line for a package this install lacks: which one, and the extra that brings it.

    A plain ``pip install vptoolkit`` is the light reader; a command that needs
    a heavy stack (measures, cleaning, learning, pictures) lands here.
    """
    from vptoolkit.optional import install_hint

    module = error.name or "a package"
    return f"{module}: not installed; this command needs it: {install_hint(module)}"


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="vptoolkit")
def main() -> None:
    """Find good viewpoints on 3D models.

    \b
    Example:
      vptool measures bunny.ply --views 1000 --resolution 1024 -o bunny.npz
    """


_MESH = _Path(exists=True, dir_okay=False, path_type=Path)
_EXISTING = _Path(exists=True, path_type=Path)
def _direction(text: str | None, option: str) -> tuple[float, float, float] | None:
    """Parse ``x,y,z`` into three floats, or say which option is wrong."""
    if text is None:
        return None
    try:
        x, y, z = (float(part) for part in text.split(","))
    except ValueError:
        raise InputError(f"{option}: expected three numbers x,y,z, got {text!r}") from None
    return x, y, z


_MEASURE_CHOICE = click.Choice(["VE", "VR", "VKL", "VMI"], case_sensitive=False)
_MODEL_HELP = "Checkpoint (folder or .safetensors), or 'default' for the bundled network."
_UP_HELP = "Model direction shown upwards in pictures, x,y,z (0,0,1 for z-up models)."
_ENGINE_CHOICE = click.Choice(["software", "open3d"])
_ENGINE_HELP = ("software: the measures' rasteriser, fast on any CPU; open3d: Filament's "
                "shading via Vulkan (erratic frame times on software Vulkan).")


def _style(up: str) -> Any:
    """A RenderStyle with the image up of ``--up``."""
    from vptoolkit.render import RenderStyle

    return RenderStyle(up=_direction(up, "--up"))


@main.command()
@click.argument("mesh", type=_MESH)
@click.option("--views", "n_views", default=1000, show_default=True, type=click.IntRange(1),
              help="Number of Fibonacci-sphere view directions.")
@click.option("--resolution", default=1024, show_default=True, type=click.IntRange(1, 16384),
              help="Side of the triangle-ID image in pixels.")
@click.option("--backend", type=click.Choice(["raster", "raycast"]), default="raster",
              show_default=True, help="raster: fast numba z-buffer; raycast: Open3D reference.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write views, raw and normalised measures and the camera to this .npz.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def measures(mesh: Path, n_views: int, resolution: int, backend: str,
             output: Path | None, as_json: bool) -> None:
    """Compute VE, VR, VKL and VMI of MESH for every view; print the best views.

    VE and VR: higher is better; VKL and VMI: lower is better. Directions point
    from the model centre to the camera, in the mesh's own coordinates.

    \b
    Example:
      vptool measures bunny.ply --views 1000 --resolution 512 -o bunny.npz
    """
    from vptoolkit.io import load_mesh
    from vptoolkit.measures import compute_view_quality

    if output is not None:
        check_suffix(output, ".npz")
    if output is not None:
        check_output_folder(output, "--output")  # before the work, not after
    loaded = load_mesh(mesh)
    started = time.perf_counter()
    quality = compute_view_quality(
        loaded, n_views=n_views, resolution=resolution, backend=backend,  # type: ignore[arg-type]
        progress=True,
    )
    seconds = time.perf_counter() - started
    if output is not None:
        quality.save_npz(output)
    summary = quality.summary()
    summary["seconds"] = round(seconds, 3)
    if as_json:
        click.echo(json.dumps(summary, indent=2))
        return
    click.echo(
        f"{quality.name}: {quality.n_faces} faces, {len(quality.views)} views at "
        f"{quality.resolution} px ({quality.backend}, {seconds:.2f} s)"
    )
    click.echo(f"{'measure':<8} {'view':>5}  {'direction (x, y, z)':<26} {'raw':>9}")
    for name, best in summary["best"].items():
        x, y, z = best["direction"]
        click.echo(f"{name:<8} {best['view_index']:>5}  ({x:+.3f}, {y:+.3f}, {z:+.3f})     "
                   f"{best['raw']:>9.4f}")
    if output is not None:
        click.echo(f"wrote {output}")


@main.command()
@click.argument("mesh", type=_MESH)
@click.option("--k", "k", type=click.IntRange(1),
              help="Number of views [default: 4, or no limit with --coverage].")
@click.option("--objective", type=click.Choice(["coverage", "information", "quality"]),
              default="coverage", show_default=True,
              help="coverage: area seen; information: entropy of the views' joint face "
                   "distribution; quality: coverage, preferring good --measure views.")
@click.option("--coverage", "target", type=click.FloatRange(0, 1, min_open=True),
              help="Add views until the set sees this fraction of what all views see.")
@click.option("--measure", default="VE", show_default=True, type=_MEASURE_CHOICE,
              help="Measure of the quality objective (its best view is the first pick).")
@click.option("--views", "n_views", default=1000, show_default=True, type=click.IntRange(1),
              help="Number of Fibonacci-sphere view directions.")
@click.option("--resolution", default=1024, show_default=True, type=click.IntRange(1, 16384),
              help="Side of the triangle-ID image in pixels.")
@click.option("--min-pixels", default=1, show_default=True, type=click.IntRange(1),
              help="Pixels a face needs in a view to count as seen.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write indices, directions and cumulative coverage to this .npz.")
@click.option("--json", "as_json", is_flag=True, help="Print the set as JSON.")
def views(mesh: Path, k: int | None, objective: str, target: float | None, measure: str,
          n_views: int, resolution: int, min_pixels: int, output: Path | None,
          as_json: bool) -> None:
    """Choose views of MESH that together show the whole model.

    A greedy search over the sampled views: each pick adds the view that best
    complements the ones before. Prints, per pick, the view, its direction and
    the area-weighted fraction of the surface seen so far.

    \b
    Example:
      vptool views bunny.ply --k 4 -o bunny_views.npz
      vptool views chair.off --coverage 0.95 --objective quality
    """
    from vptoolkit.io import load_mesh
    from vptoolkit.view_sets import measure_view_set

    if output is not None:
        check_suffix(output, ".npz")
    loaded = load_mesh(mesh)
    started = time.perf_counter()
    _, view_set = measure_view_set(
        loaded, 4 if k is None and target is None else k, n_views=n_views,
        resolution=resolution, progress=True, objective=objective, until_coverage=target,
        measure=measure, min_pixels=min_pixels)
    seconds = time.perf_counter() - started
    if output is not None:
        view_set.save_npz(output)
    if as_json:
        click.echo(json.dumps({**view_set.summary(), "seconds": round(seconds, 3)}, indent=2))
        return
    click.echo(f"{loaded.name}: {loaded.n_faces} faces, {n_views} views at {resolution} px, "
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


@main.command()
@click.argument("source", type=_MESH)
@click.argument("target", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--max-faces", default=10000, show_default=True, type=click.IntRange(4),
              help="Face budget after decimation.")
@click.option("--remesh", is_flag=True, help="Also remesh isotropically after decimation.")
@click.option("--report", "report_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Write the cleaning report as JSON to this file.")
def clean(source: Path, target: Path, max_faces: int, remesh: bool,
          report_path: Path | None) -> None:
    """Clean SOURCE in the paper's three steps and write it to TARGET.

    Repair (duplicates, non-manifold parts, self-intersections), remove faces
    no view sees, then decimate to at most --max-faces faces. TARGET's suffix
    picks the format (.off, .ply, .obj, .stl).

    \b
    Example:
      vptool clean airplane_0001.off airplane_0001_clean.ply --report report.json
    """
    from vptoolkit.clean import clean_mesh
    from vptoolkit.io import load_mesh, save_mesh

    check_output_folder(target, "TARGET")
    if report_path is not None:
        check_output_folder(report_path, "--report")  # before writing the mesh
    cleaned, report = clean_mesh(load_mesh(source), max_faces=max_faces, remesh=remesh)
    save_mesh(cleaned, target)
    record = report.to_dict()
    if report_path is not None:
        write_text_atomic(report_path, json.dumps(record, indent=2) + "\n")
    for step in record["steps"]:
        click.echo(f"{step['name']:<14} faces {step['faces_before']:>8} -> {step['faces_after']:<8}"
                   f" {step['seconds']:7.2f} s")
    click.echo(f"wrote {target} ({cleaned.n_faces} faces)")


@main.command()
@click.argument("mesh", type=_MESH)
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Write the points to this .npy file.")
@click.option("--points", "n_points", default=20000, show_default=True,
              type=click.IntRange(1, 100_000_000), help="Number of points.")
@click.option("--seed", default=0, show_default=True, type=click.IntRange(0),
              help="Random seed.")
def sample(mesh: Path, output: Path, n_points: int, seed: int) -> None:
    """Sample points uniformly by area on MESH, with face normals.

    OUTPUT is a float32 .npy array of shape (N, 6): x, y, z, nx, ny, nz in the
    mesh's own coordinates. The same seed always gives the same points.

    \b
    Example:
      vptool sample bunny.ply -o bunny_points.npy --points 20000 --seed 0
    """
    import numpy as np

    from vptoolkit.io import load_mesh
    from vptoolkit.points import sample_surface

    check_suffix(output, ".npy")
    check_output_folder(output, "--output")
    surface = sample_surface(load_mesh(mesh), n_points, seed=seed)
    table = np.hstack([surface.points, surface.normals]).astype(np.float32)
    with atomic_write(output) as handle:
        np.save(handle, table, allow_pickle=False)
    click.echo(f"wrote {output} ({n_points} points with normals)")



@main.command("build-dataset")
@click.argument("src", type=_Path(exists=True, file_okay=False, path_type=Path))
@click.argument("out", type=click.Path(file_okay=False, path_type=Path))
@click.option("--format", "store_format", type=click.Choice(["zarr", "hdf5"]), default="zarr",
              show_default=True, help="Container of OUT/dataset.*.")
@click.option("--categories", help="Comma-separated categories to include (default: all).")
@click.option("--views", "n_views", default=1000, show_default=True, type=click.IntRange(1),
              help="Fibonacci view directions per model.")
@click.option("--resolution", default=1024, show_default=True, type=click.IntRange(1, 16384),
              help="Triangle-ID image side in pixels.")
@click.option("--points", "n_points", default=20000, show_default=True, type=click.IntRange(1),
              help="Surface points per model.")
@click.option("--max-faces", default=10000, show_default=True, type=click.IntRange(4),
              help="Face budget of the cleaned meshes.")
@click.option("--no-clean", is_flag=True, help="Measure the meshes as they are.")
@click.option("--remesh", is_flag=True,
              help="Also remesh isotropically when cleaning (a tessellation-independent VE).")
@click.option("--workers", default=1, show_default=True, type=click.IntRange(1),
              help="Local worker processes.")
@click.option("--scheduler", help="Address of a running Dask distributed scheduler.")
@click.option("--split-seed", default=0, show_default=True, type=int,
              help="Seed of the train/val/test assignment.")
def build_dataset(src: Path, out: Path, store_format: str, categories: str | None,
                  n_views: int, resolution: int, n_points: int, max_faces: int,
                  no_clean: bool, remesh: bool, workers: int, scheduler: str | None, split_seed: int) -> None:
    """Build a viewpoint-quality dataset from the meshes under SRC into OUT.

    SRC is a ModelNet40-style tree (<category>/<train|test>/<name>.off) or any
    folder of meshes (category = parent folder). Each model is loaded, cleaned,
    sampled and measured; bad inputs are recorded as failures and the build
    goes on. Rerunning the same command resumes an interrupted build. Exit code
    1 when some inputs failed.

    \b
    Example:
      vptool build-dataset ModelNet40/ out/ --categories airplane,chair --workers 2
    """
    from vptoolkit.dataset.build import build_dataset as build

    chosen = [c.strip() for c in categories.split(",") if c.strip()] if categories else None
    result = build(src, out, format=store_format, categories=chosen, n_views=n_views,
                   resolution=resolution, n_points=n_points, max_faces=max_faces,
                   clean=not no_clean, remesh=remesh, workers=workers, scheduler=scheduler,
                   split_seed=split_seed, progress=True)
    click.echo(f"built {result.path}: {result.n_models} models, {result.n_failures} failures "
               f"({result.seconds:.1f} s)")
    for failure in result.failures:
        click.echo(f"  failed {failure['source']}: {failure['reason']}", err=True)
    if result.n_failures:
        sys.exit(EXIT_FAILURE)



@main.command()
@click.argument("dataset", type=_EXISTING)
@click.argument("release_dir", type=click.Path(file_okay=False, path_type=Path), required=False)
@click.option("--name", help="Base name of the archives (default: vptoolkit-viewpoints).")
@click.option("--license", "license_id", default="other", show_default=True,
              help="Licence identifier for the card (that of the source meshes).")
@click.option("--formats", default="parquet,zarr,hdf5", show_default=True,
              help="Containers to write, comma-separated: parquet, zarr, hdf5.")
@click.option("--version", "dataset_version", default="1.0.0", show_default=True,
              help="Dataset version MAJOR.MINOR.PATCH (attributes, card, Croissant, file names).")
@click.option("--created", help="Release time, ISO 8601 (default: $SOURCE_DATE_EPOCH, else the "
              "build's). The same build and --created give byte-identical files.")
@click.option("--pretty-name", help="Title of the card and the Croissant name.")
@click.option("--source-url", help="Where the source meshes come from.")
@click.option("--url", help="Where the release is published (Croissant url).")
@click.option("--creator", help="Who made the release (Croissant creator).")
@click.option("--licenses", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="CSV with the columns name, license, author, url: one row per model.")
@click.option("--license-name", help="The hub's license_name when --license is other.")
@click.option("--license-link", help="The hub's license_link when --license is other.")
@click.option("--update-card", is_flag=True,
              help="DATASET is a release whose README.md was edited: rewrite croissant.json "
              "and SHA256SUMS to match it, leaving the archives as they are.")
def pack(dataset: Path, release_dir: Path | None, name: str | None, license_id: str,
         formats: str, dataset_version: str, created: str | None, pretty_name: str | None,
         source_url: str | None, url: str | None, creator: str | None,
         licenses: Path | None, license_name: str | None, license_link: str | None,
         update_card: bool) -> None:
    """Pack a built DATASET into RELEASE_DIR for publishing.

    Writes Parquet shards per split, a Zarr v3 zip and an HDF5 file with the
    same content, the dataset card README.md (with the hub's configs),
    croissant.json, SCHEMA.md and a SHA256SUMS manifest. RELEASE_DIR must be
    new or empty. With --update-card, DATASET is an existing release whose
    card a person edited; only croissant.json and SHA256SUMS are rewritten.

    \b
    Example:
      vptool pack out/ release/ --version 1.0.0 --created 2026-01-01T00:00:00Z \\
          --licenses licenses.csv --pretty-name "Viewpoints of my meshes"
      vptool pack --update-card release/
    """
    if update_card:
        from vptoolkit.dataset.release import update_card as rewrite

        if release_dir is not None:
            raise InputError("--update-card: takes the release folder only, no RELEASE_DIR")
        changed = rewrite(dataset)
        click.echo(f"updated {dataset}: {', '.join(changed)}")
        return
    if release_dir is None:
        raise InputError("RELEASE_DIR: missing (only --update-card takes one folder)")
    from vptoolkit.dataset.release import pack_release

    chosen = [part.strip() for part in formats.split(",") if part.strip()]
    result = pack_release(
        dataset, release_dir, name=name, license=license_id, progress=True, formats=chosen,
        version=dataset_version, created=created, pretty_name=pretty_name,
        source_url=source_url, url=url, creator=creator, licenses=licenses,
        license_name=license_name, license_link=license_link,
    )
    for line in result.warnings:
        click.echo(f"vptool: warning: {line}", err=True)
    top = sorted({name.split("/")[0] + ("/" if "/" in name else "") for name in result.files})
    click.echo(f"packed {result.n_models} models ({result.n_failures} failures), version "
               f"{result.version}, created {result.created}, into {result.path}: "
               f"{', '.join(top)}")


@main.command()
@click.argument("path", type=_EXISTING)
@click.option("--json", "as_json", is_flag=True, help="Print the full report as JSON.")
def verify(path: Path, as_json: bool) -> None:
    """Re-hash a release folder or dataset store against its checksums.

    Every file is checked against SHA256SUMS and every array against the
    SHA-256 stored with it; each mismatch and each unlisted file is named.
    Exit code 1 on any mismatch; 2 if an archive could not be checked because
    a package is missing (the line says which to install).

    \b
    Example:
      vptool verify release/
    """
    from vptoolkit.dataset.manifest import verify as verify_path

    report = verify_path(path)
    # The summary is printed once: on stdout when all is well, else as the error line.
    if as_json:
        click.echo(json.dumps(report.to_dict(), indent=2))
        if not report.ok:
            sys.exit(EXIT_FAILURE if report.problems else EXIT_BAD_INPUT)
        return
    if report.ok:
        click.echo(report.summary())
    report.raise_if_failed()


@main.command()
@click.argument("path", type=_EXISTING)
@click.option("--json", "as_json", is_flag=True, help="Print the information as JSON.")
def info(path: Path, as_json: bool) -> None:
    """Show counts per category and split, conventions and failures of a dataset.

    \b
    Example:
      vptool info release/
    """
    from vptoolkit.dataset.card import dataset_info, format_info

    details = dataset_info(path)
    click.echo(json.dumps(details, indent=2) if as_json else format_info(details))



@main.command()
@click.argument("predictions", type=_Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--dataset", "dataset_path", required=True, type=_EXISTING,
              help="Dataset built by build-dataset (store, build folder or release folder).")
@click.option("--split", default="test", show_default=True,
              type=click.Choice(["train", "validation", "val", "test", "all"]), help="Models to score.")
@click.option("--measure", type=click.Choice(["VE", "VR", "VKL", "VMI"], case_sensitive=False),
              help="The measure of an (N, 3) predictions.npy, or the only one to score.")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
@click.option("--view-sets", is_flag=True,
              help="PREDICTIONS holds k directions per model, (N, k, 3): report the coverage "
                   "they reach against the greedy k-view set's.")
def evaluate(predictions: Path, dataset_path: Path, split: str, measure: str | None,
             as_json: bool, view_sets: bool) -> None:
    """Score predicted view directions against a dataset.

    PREDICTIONS is a predictions.npz (names, directions (N, 4, 3), measures;
    matched by name) or a .npy of shape (N, 4, 3), or (N, 3) with --measure, in
    the split's order. The score of a direction is the normalised quality of
    the nearest sampled view (100 % = the best view), per category and measure.

    \b
    Example:
      vptool evaluate predictions.npz --dataset release/ --split test
      vptool evaluate sets.npz --dataset release/ --view-sets
    """
    from vptoolkit.evaluate import evaluate_predictions, evaluate_view_sets

    if view_sets:
        sets = evaluate_view_sets(dataset_path, predictions, split=split)
        click.echo(json.dumps(sets.to_dict(), indent=2) if as_json else sets.format_table())
        return
    report = evaluate_predictions(dataset_path, predictions, split=split, measure=measure)
    click.echo(json.dumps(report.to_dict(), indent=2) if as_json else report.format_table())



@main.command()
@click.argument("dataset", type=_EXISTING)
@click.option("-o", "--output", required=True, type=click.Path(path_type=Path),
              help="Checkpoint: a folder, or a path ending in .safetensors.")
@click.option("--labels", type=click.Choice(["sl", "ml", "gl", "ml+gl", "sr", "dldl"]),
              default="ml+gl", show_default=True, help="Label method.")
@click.option("--epochs", default=3000, show_default=True, type=click.IntRange(1),
              help="Total epochs (the paper's 3000; far fewer already help).")
@click.option("--batch-size", default=8, show_default=True, type=click.IntRange(2))
@click.option("--lr", default=1e-3, show_default=True, type=click.FloatRange(min=0, min_open=True),
              help="Initial learning rate (x0.75 fifteen times over the run, as the paper's schedule).")
@click.option("--seed", default=0, show_default=True, type=int)
@click.option("--val-split", default="validation", show_default=True,
              type=click.Choice(["train", "validation", "val", "test"]), help="Split that picks the best epoch.")
@click.option("--per-category", is_flag=True,
              help="One network per category (the paper's set-up) in OUTPUT/<category>/.")
@click.option("--categories", help="Comma-separated categories to train on (default: all).")
@click.option("--fps-pool", default=8, show_default=True, type=click.IntRange(0),
              help="Farthest-point subsets kept per model (0: sample anew for every input, slower).")
@click.option("--device", default="auto", show_default=True, type=click.Choice(["auto", "cpu", "cuda"]),
              help="auto: CUDA when torch sees it, else the CPU.")
@click.option("--threads", type=click.IntRange(1, 1024), help="Torch threads (default: torch's).")
@click.option("--resume", is_flag=True, help="Continue the run stored at --output.")
def train(dataset: Path, output: Path, labels: str, epochs: int, batch_size: int, lr: float,
          seed: int, val_split: str, per_category: bool, categories: str | None, fps_pool: int,
          device: str, threads: int | None, resume: bool) -> None:
    """Train a viewpoint network on the train split of DATASET.

    Inputs are put in their canonical principal-axis frame, so the network's
    answer turns with the model. Keeps the checkpoint with the best mean
    validation score (normalised quality of the nearest sampled view, under
    fixed rotations); the checkpoint is safetensors plus a JSON config, never
    a pickle.

    \b
    Example:
      vptool train release/ -o model.safetensors --labels ml+gl --epochs 200
      vptool train release/ -o per_category/ --per-category --epochs 300
    """
    from vptoolkit.learn.train import train_model, train_per_category

    from vptoolkit.dataset.store import find_store, open_store
    from vptoolkit.points import N_FPS_POINTS

    most_threads = 8 * (os.cpu_count() or 1)
    if threads is not None and threads > most_threads:
        raise InputError(f"--threads: at most {most_threads} (8 per CPU of this machine), "
                         f"got {threads}")
    with open_store(find_store(dataset)) as store:
        n_points = int(store.attrs["n_points"])
    if n_points < N_FPS_POINTS:  # the network input takes that many by farthest point sampling
        raise InputError(f"{dataset}: models have {n_points} points; training needs at least "
                         f"{N_FPS_POINTS} per model (build with --points {N_FPS_POINTS} "
                         "or more; the paper uses 20000)")
    options = {"labels": labels, "epochs": epochs, "batch_size": batch_size, "lr": lr, "seed": seed,
               "resume": resume, "progress": True, "threads": threads, "val_split": val_split,
               "fps_pool": fps_pool, "device": device, "command": " ".join(["vptool", *sys.argv[1:]])}
    chosen = [name.strip() for name in categories.split(",")] if categories else None
    try:
        if per_category:
            results = train_per_category(dataset, output, categories=chosen, **options)
        else:
            results = {"": train_model(dataset, output, categories=chosen, **options)}
    except InputError as error:
        if "already holds a training run" not in str(error):
            raise
        raise InputError(f"{output}: already holds a training run; add --resume to continue it, "
                         "or give another -o (or delete it) to start afresh") from error
    for category, result in results.items():
        scores = ", ".join(f"{m} {100 * v:.1f}%" for m, v in result.best_scores.items())
        click.echo(f"{category + ': ' if category else ''}best epoch {result.best_epoch} of {result.epochs}: "
                   f"{scores}; wrote {result.checkpoint}")


@main.command("predict")
@click.argument("inputs", nargs=-1, type=_EXISTING)
@click.option("-m", "--model", default="default", show_default=True, help=_MODEL_HELP)
@click.option("--dataset", "dataset_path", type=_EXISTING, help="Predict the models of a dataset.")
@click.option("--split", default="test", show_default=True,
              type=click.Choice(["train", "validation", "val", "test", "all"]), help="Split of --dataset.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write names, directions (N, 4, 3) and measures to this .npz.")
@click.option("--seed", default=0, show_default=True, type=int,
              help="Seed of the surface sampling and input point choice.")
@click.option("--category", help="Category of mesh and point-file inputs, for a per-category model folder.")
@click.option("--device", default="auto", show_default=True, type=click.Choice(["auto", "cpu", "cuda"]),
              help="auto: CUDA when torch sees it, else the CPU.")
def predict_command(inputs: tuple[Path, ...], model: str, dataset_path: Path | None, split: str,
                    output: Path | None, seed: int, category: str | None, device: str) -> None:
    """Predict the best view per measure of meshes, point files or a dataset.

    INPUTS are mesh files or .npy point files ((N, 3) or (N, 6) as written by
    vptool sample). Directions come back in each input's own frame, from the
    model centre towards the camera. Without --model the network bundled with
    vptoolkit predicts (trained on procedural shapes; see docs/results.md).

    \b
    Example:
      vptool predict chair.off table.ply
      vptool predict -m model.safetensors --dataset release/ --split test -o test.npz
    """
    from vptoolkit.learn.predict import predict

    if output is not None:
        check_suffix(output, ".npz")
    if output is not None:
        check_output_folder(output, "--output")
    sources: list[Path] = list(inputs) + ([dataset_path] if dataset_path is not None else [])
    if not sources:
        raise InputError("inputs: give mesh or point files, or --dataset")
    for source in sources:
        if source.suffix.lower() == ".npy" and source.is_file():
            _check_point_file(source)
    predictions = predict(model, sources, split=None if split == "all" else split, seed=seed,
                          progress=True, category=category, device=device)
    if output is not None:
        predictions.save_npz(output)
    for name, directions in zip(predictions.names[:10], predictions.directions[:10]):
        cells = "  ".join(f"{m} ({x:+.2f}, {y:+.2f}, {z:+.2f})"
                          for m, (x, y, z) in zip(predictions.measures, directions))
        click.echo(f"{name}: {cells}")
    if len(predictions) > 10:
        click.echo(f"... and {len(predictions) - 10} more")
    if output is not None:
        click.echo(f"wrote {output} ({len(predictions)} models)")



def _check_point_file(path: Path) -> None:
    """Refuse a point file whose header lies or whose points have no extent, before predicting."""
    import numpy as np

    with open(path, "rb") as stream:
        check_npy_header(stream, path.name, path.stat().st_size)
    try:
        table = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as err:
        raise InputError(f"{path.name}: cannot read a numpy array ({one_line(err)})") from err
    if table.ndim == 2 and table.shape[1] in (3, 6) and np.issubdtype(table.dtype, np.number):
        points = table[:, :3]
        if len(points) < 2 or np.ptp(points, axis=0).max() == 0:
            raise InputError(f"{path.name}: its {len(points)} point(s) do not span any extent; "
                             "a view can only be predicted for a shape (at least 2 distinct points)")


# --------------------------------------------------------------------------- pictures


@main.command()
@click.argument("mesh", type=_MESH)
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="PNG file to write.")
@click.option("--view", help="Direction x,y,z from the model centre towards the camera.")
@click.option("--best", type=_MEASURE_CHOICE, help="Draw the best sampled view of this measure.")
@click.option("--model", "model_path", help=_MODEL_HELP + " Draws its predicted view.")
@click.option("--view-set", "view_set_k", type=click.IntRange(1),
              help="Draw the K-view coverage set as one contact sheet, --size per tile.")
@click.option("--measure", default="VE", show_default=True, type=_MEASURE_CHOICE,
              help="Measure whose prediction --model draws.")
@click.option("--size", default=512, show_default=True, type=click.IntRange(16, 4096),
              help="Picture side in pixels.")
@click.option("--views", "n_views", default=1000, show_default=True, type=click.IntRange(1),
              help="Views sampled for --best.")
@click.option("--resolution", default=1024, show_default=True, type=click.IntRange(1, 16384),
              help="Triangle-ID resolution of the measures for --best.")
@click.option("--up", default="0,1,0", show_default=True, help=_UP_HELP)
@click.option("--engine", default="software", show_default=True, type=_ENGINE_CHOICE,
              help=_ENGINE_HELP)
def render(mesh: Path, output: Path, view: str | None, best: str | None, model_path: str | None,
           view_set_k: int | None, measure: str, size: int, n_views: int, resolution: int,
           up: str, engine: str) -> None:
    """Draw MESH through the measures' camera into a PNG picture.

    Give exactly one of --view, --best, --model or --view-set. The picture shows
    what the measures score for that direction (same eye, target, up and field
    of view); --view-set K draws the K views that together see the most of the
    surface as one captioned contact sheet.

    \b
    Example:
      vptool render bunny.ply --best VE -o bunny_ve.png
      vptool render chair.off --model default -o chair.png
      vptool render chair.off --view 1,-1,1 --size 256 -o corner.png
      vptool render bunny.ply --view-set 4 --size 256 -o bunny_sheet.png
    """
    from vptoolkit.io import load_mesh
    from vptoolkit.render import RenderedView, render_best, render_predicted, render_view, save_png
    from vptoolkit.sphere import as_directions

    if sum(choice is not None for choice in (view, best, model_path, view_set_k)) != 1:
        raise InputError("render: give exactly one of --view, --best, --model or --view-set")
    check_suffix(output, ".png")
    check_output_folder(output, "--output")
    style = _style(up)
    loaded = load_mesh(mesh)
    if view_set_k is not None:
        from vptoolkit.contact_sheet import view_set_sheet

        sheet, chosen = view_set_sheet(loaded, view_set_k, size=size, n_views=n_views,
                                       resolution=resolution, style=style, engine=engine)
        save_png(sheet, output)
        click.echo(f"wrote {output} ({len(chosen)} views, views {chosen.indices.tolist()}, "
                   f"{100 * chosen.coverage[-1]:.1f} % of the surface seen)")
        return
    if best is not None:
        picture = render_best(loaded, measure=best, size=size, n_views=n_views,
                              resolution=resolution, style=style, engine=engine)
    elif model_path is not None:
        from vptoolkit.learn.predict import MeshPredictor

        picture = render_predicted(loaded, MeshPredictor(model_path), measure=measure, size=size,
                                   style=style, engine=engine)
    else:
        direction = as_directions(_direction(view, "--view"), name="--view")[0]
        picture = RenderedView(render_view(loaded, direction, size=size, style=style,
                                           engine=engine), direction, "--view")
    save_png(picture.image, output)
    x, y, z = picture.direction
    click.echo(f"wrote {output} ({picture.label}, direction ({x:+.3f}, {y:+.3f}, {z:+.3f}))")


@main.command("sphere-map")
@click.argument("quality", type=_Path(exists=True, dir_okay=False, path_type=Path))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="PNG file to write.")
@click.option("--measure", default="VE", show_default=True, type=_MEASURE_CHOICE)
@click.option("--predicted", help="A predicted direction x,y,z to mark with a cross.")
def sphere_map(quality: Path, output: Path, measure: str, predicted: str | None) -> None:
    """Draw a measure over the view sphere as a Mercator map.

    QUALITY is the .npz of vptool measures -o. Colours: normalised quality
    (1 = best); the star marks the best sampled view, the cross --predicted.

    \b
    Example:
      vptool measures bunny.ply -o bunny.npz
      vptool sphere-map bunny.npz --measure VMI -o bunny_vmi.png
    """
    from vptoolkit.sphere_map import sphere_map_file

    check_output_folder(output, "--output")
    sphere_map_file(quality, output, measure=measure, predicted=_direction(predicted, "--predicted"))
    click.echo(f"wrote {output}")


@main.command()
@click.argument("dataset", type=_EXISTING)
@click.option("-o", "--output", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for index.html and its pictures.")
@click.option("--split", type=click.Choice(["train", "validation", "val", "test"]),
              help="Report one split only (default: every model).")
@click.option("--predictions", type=_Path(exists=True, dir_okay=False, path_type=Path),
              help="Predictions (.npz of vptool predict) to score and draw.")
@click.option("--size", default=256, show_default=True, type=click.IntRange(16, 4096),
              help="Picture side in pixels.")
@click.option("--no-pictures", is_flag=True, help="Maps and tables only; needs no renderer.")
@click.option("--view-set", "view_set_k", default=4, show_default=True, type=click.IntRange(0),
              help="Views in each model's coverage view set (0 leaves it out).")
@click.option("--up", default="0,1,0", show_default=True, help=_UP_HELP)
@click.option("--engine", default="software", show_default=True, type=_ENGINE_CHOICE,
              help=_ENGINE_HELP)
def report(dataset: Path, output: Path, split: str | None, predictions: Path | None, size: int,
           no_pictures: bool, view_set_k: int, up: str, engine: str) -> None:
    """Write a static HTML page with one card per model of DATASET.

    Pictures from each measure's best view, the four quality maps, the scores
    of --predictions, filters by category and split, and a summary table.
    Open OUTPUT/index.html in any browser; no server is needed.

    \b
    Example:
      vptool predict --model default --dataset release/ -o test.npz
      vptool report release/ --split test --predictions test.npz -o report/
    """
    from vptoolkit.report import write_report

    index = write_report(dataset, output, split=split, predictions=predictions, size=size,
                         thumbnails=not no_pictures, style=_style(up), engine=engine,
                         progress=True, view_set=view_set_k or None)
    click.echo(f"wrote {index}")


@main.command()
@click.argument("src", type=_EXISTING)
@click.argument("out", type=click.Path(file_okay=False, path_type=Path))
@click.option("--measure", default="VE", show_default=True, type=_MEASURE_CHOICE,
              help="Measure whose best (or predicted) view is drawn.")
@click.option("--model", "model_path", help=_MODEL_HELP + " Uses its predictions, measures nothing.")
@click.option("--view-set", "view_set_k", type=click.IntRange(1),
              help="Draw each mesh's K-view coverage set as a contact sheet instead.")
@click.option("--size", default=512, show_default=True, type=click.IntRange(16, 4096),
              help="Picture side in pixels.")
@click.option("--workers", type=click.IntRange(1), help="Measuring processes (default: CPUs).")
@click.option("--views", "n_views", default=1000, show_default=True, type=click.IntRange(1))
@click.option("--resolution", default=1024, show_default=True, type=click.IntRange(1, 16384))
@click.option("--up", default="0,1,0", show_default=True, help=_UP_HELP)
@click.option("--engine", default="software", show_default=True, type=_ENGINE_CHOICE,
              help=_ENGINE_HELP)
def thumbnails(src: Path, out: Path, measure: str, model_path: str | None,
               view_set_k: int | None, size: int, workers: int | None, n_views: int,
               resolution: int, up: str, engine: str) -> None:
    """Draw a thumbnail of every mesh under SRC from its best view into OUT.

    SRC/a/b.off becomes OUT/a/b.png; OUT/thumbnails.json records directions
    and the files skipped with their reasons (exit status 1 if any).

    \b
    Example:
      vptool thumbnails models/ thumbs/ --measure VKL --size 256
      vptool thumbnails models/ thumbs/ --model default
      vptool thumbnails models/ sheets/ --view-set 4 --size 192
    """
    from vptoolkit.thumbnails import render_thumbnails

    predictor = None
    if model_path is not None:
        from vptoolkit.learn.predict import MeshPredictor

        predictor = MeshPredictor(model_path)
    result = render_thumbnails(src, out, measure=measure, predictor=predictor, size=size,
                               workers=workers, n_views=n_views, resolution=resolution,
                               style=_style(up), engine=engine, progress=True,
                               view_set=view_set_k)
    click.echo(f"wrote {len(result.done)} thumbnails to {out}, {len(result.failures)} skipped")
    for failure in result.failures:
        click.echo(f"  skipped {failure.source}: {failure.reason}", err=True)
    if result.failures:
        sys.exit(EXIT_FAILURE)
