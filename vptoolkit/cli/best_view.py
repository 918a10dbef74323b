"""The ``best-view`` command: an anytime search for the best view of meshes or a dataset split."""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path

import click

from vptoolkit.checks import check_suffix
from vptoolkit.cli.group import EXIT_BAD_INPUT, EXIT_FAILURE
from vptoolkit.cli.options import (
    DATASET,
    MESH,
    budget_option,
    cache_dir_option,
    measures_option,
    search_resolution_option,
    split_option,
)
from vptoolkit.conventions import Split
from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.files import check_output_folder, output_json


def _searchable(value: str) -> tuple[str, ...]:
    from vptoolkit.best_view.search import searchable_measures

    return searchable_measures(value)


@click.command("best-view")
@click.argument("meshes", nargs=-1, type=MESH)
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
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write names, directions (N, M, 3) and the measures' names to this .npz "
                   "(scored by vptool evaluate).")
@click.option("--json", "as_json", is_flag=True,
              help="Print per mesh the directions, views drawn, resolutions and seconds.")
@cache_dir_option()
def best_view(meshes: tuple[Path, ...], budget: int, resolution: int, prior: str,
              dataset_path: Path | str | None, split: Split, measures: tuple[str, ...] | None,
              output: Path | None, as_json: bool, cache_dir: Path | None) -> None:
    """Find the best view per measure of MESHES within a budget of drawn views.

    A Fibonacci sphere of half the budget (at 128 px when --resolution is
    larger, its best candidates then drawn again at --resolution), then rings
    around each measure's best that narrow every round; budgets below 16 are
    one sphere. Any orientation of the input works. Cost, for meshes of
    1k-16k faces on two cores, loading aside: about 3 ms for 8 views and 10 ms
    for 64 at 128 px; a view at --resolution 1024 costs about 1 ms.
    Directions point from the model centre to the camera, in each mesh's own
    coordinates; VE and VR: higher is better, VKL and VMI: lower is better
    (vptool measures --measures all lists every measure's direction).

    \b
    Example:
      vptool best-view bunny.ply
      vptool best-view *.off --views 256 --resolution 256 -o best.npz
      vptool best-view bunny.ply --measures NVT,SL,MD
      vptool best-view scan.ply --views 8 --prior unoccluded
      vptool best-view --dataset release/ --split test --prior default -o test.npz
    """
    from vptoolkit.best_view.run import search_inputs
    from vptoolkit.best_view.search import SearchSettings
    from vptoolkit.data import open_dataset

    if output is not None:
        check_suffix(output, ".npz")
        check_output_folder(output, "--output")
    if not meshes and dataset_path is None:
        raise InputError("inputs: give mesh files or --dataset")
    with contextlib.ExitStack() as stack:
        dataset = (None if dataset_path is None
                   else stack.enter_context(open_dataset(dataset_path, cache_dir=cache_dir)))
        run = search_inputs(meshes, settings=SearchSettings(budget=budget, resolution=resolution),
                            dataset=dataset, split=split, prior=prior, measures=measures,
                            progress=True)
    if output is not None and run.results:
        run.predictions.save_npz(output)
    if as_json:
        click.echo(output_json({"results": [result.summary() for result in run.results],
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


COMMANDS = (best_view,)
"""The commands this module adds to ``vptool``."""
