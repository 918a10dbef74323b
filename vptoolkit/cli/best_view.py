"""The ``best-view`` command: an anytime search for the best view of meshes, a dataset split
or a whole collection (a folder, a glob or ``@list.txt``, :mod:`vptoolkit.collection`)."""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import click

from vptoolkit.checks import check_suffix
from vptoolkit.cli.group import EXIT_BAD_INPUT, EXIT_FAILURE
from vptoolkit.cli.options import (
    DATASET,
    MESH,
    budget_option,
    cache_dir_option,
    elevation_option,
    face_limit_option,
    max_points_option,
    measures_option,
    scheduler_option,
    search_resolution_option,
    split_option,
    timeout_option,
    up_option,
    workers_option,
)
from vptoolkit.conventions import Split

if TYPE_CHECKING:
    from vptoolkit.best_view.search import SearchSettings
from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.files import check_output_folder, output_json


def _searchable(value: str) -> tuple[str, ...]:
    from vptoolkit.best_view.search import searchable_measures

    return searchable_measures(value)


_SHOWN_FAILURES = 20  # failure lines a collection run prints; the table holds them all


def is_collection(inputs: tuple[str, ...]) -> bool:
    """Whether the inputs name a collection: one folder, glob or ``@list.txt``."""
    if len(inputs) != 1:
        return False
    source = inputs[0]
    return (source.startswith("@") or Path(source).is_dir()
            or (any(mark in source for mark in "*?[") and not Path(source).is_file()))


@click.command("best-view")
@click.argument("inputs", nargs=-1)
@budget_option()
@search_resolution_option()
@click.option("--prior", default="none", show_default=True,
              help="none; unoccluded (the occlusion-free estimate from face normals, "
                   "no image drawn); default (the bundled network) or a checkpoint: "
                   "proposes the first candidates.")
@click.option("--dataset", "dataset_path", type=DATASET,
              help="Search the stored meshes of a dataset split (a path or a release's URL).")
@split_option("Split of --dataset.")
@measures_option("Measures to search: names (VE,NVT,SL) or 'paper' [default: with "
                 "--dataset, the measures it records that a search can evaluate; else "
                 "paper]. INS, DVS, SAL, EVMI and MS need all views of the sphere and are "
                 "refused.", default=None, resolve=_searchable)
@click.option("-o", "--output", type=click.Path(path_type=Path),
              help="Mesh files: write names, directions (N, M, 3) and the measures' names to "
                   "this .npz (scored by vptool evaluate). A collection: the output folder.")
@workers_option("Local worker processes (a collection).", default=1)
@scheduler_option()
@face_limit_option()
@timeout_option()
@click.option("--dry-run", is_flag=True, help="A collection: count its files and estimate "
              "hours and disk from a few, writing nothing.")
@click.option("--json", "as_json", is_flag=True,
              help="Print per mesh the directions, camera poses and intrinsics, views "
                   "drawn, resolutions and seconds.")
@up_option(allow_auto=True)
@elevation_option(None)
@cache_dir_option()
@max_points_option()
def best_view(inputs: tuple[str, ...], budget: int, resolution: int, prior: str,
              dataset_path: Path | str | None, split: Split, measures: tuple[str, ...] | None,
              output: Path | None, as_json: bool, cache_dir: Path | None, workers: int,
              scheduler: str | None, max_faces: int, timeout: float, dry_run: bool,
              up: tuple[float, float, float] | str, elevation: tuple[float, float] | None,
              max_points: int) -> None:
    """Find the best view per measure of INPUTS within a budget of drawn views.

    INPUTS are mesh files, or one collection: a folder (walked recursively),
    a quoted glob ('models/**/*.off') or @list.txt (a path or URL per line),
    meshes and point clouds mixed. A collection is searched into -o OUT:
    OUT/<settings digest>/table.parquet (one row per file: directions, camera
    poses and intrinsics, or the reason it failed) and predictions.npz;
    --workers N or --scheduler ADDR as for build-dataset; rerunning the same
    command does only what is missing; exit status 1 when any file failed.

    A Fibonacci sphere of half the budget (at 128 px when --resolution is
    larger, its best candidates then drawn again at --resolution), then rings
    around each measure's best that narrow every round; budgets below 16 are
    one sphere. Any orientation of the input works. Cost, for meshes of
    1k-16k faces on two cores, loading aside: about 3 ms for 8 views and 10 ms
    for 64 at 128 px; a view at --resolution 1024 costs about 1 ms.
    Directions point from the model centre to the camera, in each mesh's own
    coordinates; --up is the model's up axis (the top of the exported camera
    poses, +y by default as Open3D and trimesh) and --elevation MIN,MAX keeps
    every searched view within that band of degrees above its horizon
    (default: the whole sphere); VE and VR: higher is better, VKL and VMI: lower is better
    (vptool measures --measures all lists every measure's direction).

    \b
    Example:
      vptool best-view bunny.ply
      vptool best-view *.off --views 256 --resolution 256 -o best.npz
      vptool best-view bunny.ply --measures NVT,SL,MD
      vptool best-view scan.ply --views 8 --prior unoccluded
      vptool best-view --dataset release/ --split test --prior default -o test.npz
      vptool best-view models/ -o views/ --workers 4
      vptool best-view @models.txt -o views/ --dry-run
      vptool best-view bus.ply --up 0,0,1 --elevation 0,60
    """
    from vptoolkit.best_view.search import SearchSettings

    search = SearchSettings(budget=budget, resolution=resolution,
                            up="auto" if isinstance(up, str) else up, elevation=elevation)
    if is_collection(inputs):
        _search_collection(inputs[0], output, search, prior, measures, workers,
                           scheduler, max_faces, max_points, timeout, dry_run, dataset_path,
                           as_json)
        return
    if workers != 1 or scheduler is not None or dry_run:
        raise InputError("--workers: --workers, --scheduler and --dry-run take a collection "
                         "(one folder, glob or @list.txt)")
    context = click.get_current_context()
    argument = next(param for param in context.command.params if param.name == "inputs")
    meshes = tuple(MESH.convert(value, argument, context) for value in inputs)
    from vptoolkit.best_view.run import search_inputs
    from vptoolkit.data import open_dataset

    if output is not None:
        check_suffix(output, ".npz")
        check_output_folder(output, "--output")
    if not meshes and dataset_path is None:
        raise InputError("inputs: give mesh files, a collection (a folder, a glob or "
                         "@list.txt) or --dataset")
    with contextlib.ExitStack() as stack:
        dataset = (None if dataset_path is None
                   else stack.enter_context(open_dataset(dataset_path, cache_dir=cache_dir)))
        run = search_inputs(meshes, settings=search,
                            dataset=dataset, split=split, prior=prior, measures=measures,
                            max_points=max_points, progress=True)
    if output is not None and run.results:
        run.predictions.save_npz(output)
    if as_json:
        dataset_name = None if dataset_path is None else str(dataset_path)
        click.echo(output_json({"results": [
                                   {"file": file,
                                    "dataset": None if file is not None else dataset_name,
                                    **result.summary()}
                                   for file, result in zip(run.files, run.results)],
                               "failures": [{"input": where, "error": why}
                                            for where, why in run.failures]}, indent=2))
    else:
        for result in run.results:
            stages = ", ".join(f"{s.n_views} {s.name} @ {s.resolution}" for s in result.stages)
            click.echo(f"{result.name}: {result.n_views} views ({stages}), "
                       f"{1000 * result.seconds:.0f} ms")
            for measure, direction, raw in zip(result.measures, result.directions, result.raw):
                x, y, z = direction
                click.echo(f"  {measure:<4} ({x:+.3f}, {y:+.3f}, {z:+.3f})  raw {raw:.4f}")
        if output is not None and run.results:
            click.echo(f"wrote {output} ({len(run.results)} meshes)")
    for where, why in run.failures:  # the reason names the file or the mesh, else say where
        named = why.startswith((Path(where).name, f"{Path(where).stem}:"))
        click.echo(f"vptool: error: {why}" if named else f"vptool: error: {where}: {why}",
                   err=True)
    if run.failures and not run.results:  # nothing searched: each failure said in its own line
        sys.exit(EXIT_BAD_INPUT if run.is_bad_input else EXIT_FAILURE)
    if run.failures:
        raise MeasurementError(f"{len(run.failures)} of {len(run.failures) + len(run.results)} "
                               "inputs failed")


def _search_collection(source: str, output: Path | None, search: SearchSettings, prior: str,
                       measures: tuple[str, ...] | None, workers: int,
                       scheduler: str | None, max_faces: int, max_points: int, timeout: float,
                       dry_run: bool, dataset_path: Path | str | None, as_json: bool) -> None:
    """``best-view`` of a collection (see the command's help)."""
    from vptoolkit.best_view.search import searchable_measures
    from vptoolkit.collection.methods import SearchMethod

    if dataset_path is not None:
        raise InputError("--dataset: give a collection or --dataset, not both")
    method = SearchMethod(search,
                          measures or searchable_measures(None), prior)
    if dry_run:
        from vptoolkit.collection.plan import plan_collection

        for line in plan_collection(source, method, workers=workers, max_faces=max_faces,
                                    timeout=timeout, max_points=max_points).lines():
            click.echo(line)
        return
    if output is None:
        raise InputError("--output: a collection needs -o OUT, the output folder")
    from vptoolkit.collection.runner import run_collection
    from vptoolkit.collection.table import write_table_predictions

    run = run_collection(source, output, method, max_faces=max_faces, max_points=max_points,
                         timeout=timeout, workers=workers, scheduler=scheduler, progress=True)
    write_table_predictions(run.table, run.folder / "predictions.npz")
    if as_json:
        click.echo(output_json({"table": str(run.table), "entries": run.n_entries,
                               "done": run.n_done, "resumed": run.n_resumed,
                               "failures": [{"input": key, "error": reason}
                                            for key, reason in run.failures]}, indent=2))
    else:
        click.echo(f"searched {run.n_entries} files ({run.n_resumed} from an earlier run), "
                   f"{len(run.failures)} failed: {run.table}")
    for key, reason in run.failures[:_SHOWN_FAILURES]:
        click.echo(f"  failed {key}: {reason}", err=True)
    if len(run.failures) > _SHOWN_FAILURES:
        click.echo(f"  ... and {len(run.failures) - _SHOWN_FAILURES} more (the table's "
                   "status and reason columns)", err=True)
    if run.failures:
        sys.exit(EXIT_FAILURE)


COMMANDS = (best_view,)
"""The commands this module adds to ``vptool``."""
