"""Commands over whole datasets: ``build-dataset``, ``split``, ``pack``, ``verify``, ``info``,
``import-authors`` and ``export-authors``."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Literal

import click

from vptoolkit.cli.group import EXIT_BAD_INPUT, EXIT_FAILURE, options_named
from vptoolkit.cli.options import (
    DATASET,
    EXISTING,
    ExistingPath,
    cache_dir_option,
    comma_list,
    max_faces_option,
    max_points_option,
    measures_option,
    points_option,
    resolution_option,
    scheduler_option,
    views_option,
    workers_option,
)
from vptoolkit.conventions import DATASET_VERSION, SEED
from vptoolkit.dataset.authors.importer import AUTHORS_RESOLUTION
from vptoolkit.dataset.builder.options import DEFAULT_FORMAT, FORMATS
from vptoolkit.dataset.builder.plan import CALIBRATION_MODELS
from vptoolkit.dataset.release.options import (
    DEFAULT_FORMATS,
    DEFAULT_LICENSE,
    DEFAULT_NAME,
    ReleaseOptions,
)
from vptoolkit.dataset.release.parquet import DEFAULT_SHARD_BYTES
from vptoolkit.errors import InputError
from vptoolkit.files import output_json
from vptoolkit.settings import MAX_RESOLUTION


@click.command("build-dataset")
@click.argument("src", type=ExistingPath(exists=True, file_okay=False, path_type=Path))
@click.argument("out", type=click.Path(file_okay=False, path_type=Path))
@click.option("--format", "store_format", type=click.Choice(list(FORMATS)),
              default=DEFAULT_FORMAT, show_default=True, help="Container of OUT/dataset.*.")
@click.option("--categories", help="Comma-separated categories to include (default: all).")
@views_option("Fibonacci view directions per model.")
@resolution_option("Triangle-ID image side in pixels.")
@measures_option(dest="measure_names",
                 help="Measures of every model, the columns of the quality arrays in this "
                      "order: comma-separated names (VE,NVT,SL), 'all' for every registered "
                      "measure, or 'paper' for VE, VR, VKL and VMI.")
@points_option("Surface points per model.")
@max_faces_option("Face budget of the cleaned meshes.")
@click.option("--no-clean", is_flag=True, help="Measure the meshes as they are.")
@click.option("--remesh", is_flag=True,
              help="Also remesh isotropically when cleaning (a tessellation-independent VE).")
@workers_option("Local worker processes.", default=1)
@scheduler_option()
@click.option("--split-seed", default=SEED, show_default=True, type=int,
              help="Seed of the train/val/test assignment (and of the point samples).")
@click.option("--splits", "split_file",
              type=ExistingPath(exists=True, dir_okay=False, path_type=Path),
              help="A published split instead of the seeded one: a CSV with the header "
              "name,split, or the paper authors' small.txt (their index % 10 rule over "
              "the lines of --categories).")
@click.option("--max-models", type=click.IntRange(1), help="Build only N models, taken in "
              "turn from each category in sorted order (OUT resumes with the same N only).")
@click.option("--dry-run", is_flag=True, help="Write nothing to OUT: list the models per "
              "category and split, and estimate hours and disk from a few models built "
              "in a temporary folder.")
@click.option("--calibrate", type=click.IntRange(0),
              help=f"Models --dry-run builds for its estimate (default: {CALIBRATION_MODELS}; "
              "0: count only).")
@max_points_option()
@click.option("--sampling", type=click.Choice(["uniform", "scan"]), default="uniform",
              show_default=True,
              help="A mesh's stored points: area-uniform on its surface, or a virtual scan "
                   "(3 seeded range images of 128 px, range noise 0.005 of the diagonal) "
                   "drawn to --points; the labels are the mesh's either way, so a network "
                   "trained on it learns from scanner-like points.")
def build_dataset(src: Path, out: Path, store_format: Literal["zarr", "hdf5"],
                  categories: str | None, n_views: int, resolution: int,
                  measure_names: tuple[str, ...], n_points: int, max_faces: int,
                  no_clean: bool, remesh: bool, workers: int, scheduler: str | None,
                  split_seed: int, split_file: Path | None, max_models: int | None,
                  dry_run: bool, calibrate: int | None, max_points: int,
                  sampling: str) -> None:
    """Build a viewpoint-quality dataset from the meshes and point clouds under SRC into OUT.

    SRC is a ModelNet40-style tree (<category>/<train|test>/<name>.off) or any
    folder of meshes and point clouds (category = parent folder; a model's
    name is its path under SRC without the suffix, folders joined by "__":
    a/teapot.stl is a__teapot). Each model is loaded, cleaned, sampled and
    measured (a point cloud is measured on its points and stores its own
    points, uncleaned and without faces); bad inputs are recorded as failures and the build
    goes on. Rerunning the same command resumes an interrupted build. Exit code
    1 when some inputs failed. --dry-run sizes the build first: the models per
    category and split, and the hours and disk estimated from --calibrate
    models. --measures chooses the measures of the survey by Bonaventura et al.
    (2018) the store holds (default: the paper's four); every reader of the
    store follows the names it records.

    \b
    Example:
      vptool build-dataset ModelNet40/ out/ --categories airplane,chair --dry-run
      vptool build-dataset ModelNet40/ out/ --categories airplane,chair --workers 2
      vptool build-dataset ModelNet40/ out/ --categories airplane --measures VE,NVT,SL
      vptool build-dataset meshes/ scans/ --sampling scan
      vptool build-dataset ModelNet40/ out/ --categories airplane,chair \\
          --splits data/ModelNet40/small.txt
    """
    from vptoolkit.dataset.builder.options import BuildOptions, SplitFile
    from vptoolkit.dataset.builder.run import build_dataset as build
    from vptoolkit.settings import MeasureSettings

    if remesh and no_clean:
        raise InputError("--remesh: remeshing is a cleaning step; drop --no-clean or --remesh")
    chosen = comma_list(categories)
    if calibrate is not None and not dry_run:
        raise InputError("--calibrate: only with --dry-run")
    options = BuildOptions(
        measure=MeasureSettings(views=n_views, resolution=resolution),
        measures=measure_names, n_points=n_points,
        max_faces=max_faces, clean=not no_clean, remesh=remesh, split_seed=split_seed,
        splits=None if split_file is None else SplitFile.read(split_file),
        max_models=max_models, format=store_format, max_points=max_points, sampling=sampling)
    if dry_run:
        from vptoolkit.dataset.builder.plan import plan_build

        plan = plan_build(src, out, options, categories=chosen, progress=True,
                          calibrate=CALIBRATION_MODELS if calibrate is None else calibrate,
                          workers=workers)
        for line in plan.lines():
            click.echo(line)
        return
    result = build(src, out, options, categories=chosen, workers=workers, scheduler=scheduler,
                   progress=True)
    click.echo(f"built {result.path}: {result.n_models} models, {result.n_failures} failures "
               f"({result.seconds:.1f} s)")
    if result.split_file is not None:
        report = result.split_file
        click.echo(f"split from {report.path}: placed {report.n_placed} models")
        if report.not_in_source:
            shown = ", ".join(report.not_in_source[:5])
            more = ", ..." if len(report.not_in_source) > 5 else ""
            click.echo(f"vptool: warning: {len(report.not_in_source)} names in {report.path} "
                       f"are not models of SRC: {shown}{more}", err=True)
    for failure in result.failures:
        click.echo(f"  failed {failure['source']}: {failure['reason']}", err=True)
    if result.n_failures:
        sys.exit(EXIT_FAILURE)


@click.command()
@click.argument("dataset", type=EXISTING)
@click.argument("release_dir", type=click.Path(file_okay=False, path_type=Path), required=False)
@click.option("--name", default=DEFAULT_NAME, show_default=True,
              help="Base name of the archives.")
@click.option("--license", "license_id", default=DEFAULT_LICENSE, show_default=True,
              help="Licence of the release and of every source mesh --licenses does not "
              "name: an SPDX identifier or expression (CC-BY-4.0, MIT OR Apache-2.0) or a URL; "
              "'other' states none. Refused where it contradicts the sources' own terms "
              "(ModelNet, ShapeNet, the paper authors' data, a --licenses row).")
@click.option("--force-license", is_flag=True,
              help="Release under --license even where it contradicts the sources' own "
              "terms; the card records that decision and what it contradicts.")
@click.option("--formats", default=",".join(DEFAULT_FORMATS), show_default=True,
              help="Containers to write, comma-separated: parquet, zarr, hdf5 (each a full "
              "copy of the data).")
@click.option("--shard-size", default=f"{DEFAULT_SHARD_BYTES // 1000**2}MB", show_default=True,
              help="Largest size of one Parquet shard's rows (Arrow bytes), e.g. 200KB, 1GB.")
@click.option("--version", "dataset_version", default=DATASET_VERSION, show_default=True,
              help="Dataset version MAJOR.MINOR.PATCH (attributes, card, Croissant; "
              "never file names).")
@click.option("--created", help="Release time, ISO 8601 (default: $SOURCE_DATE_EPOCH, else the "
              "build's). The same build and --created give byte-identical files.")
@click.option("--pretty-name", help="Title of the card and the Croissant name.")
@click.option("--source-url", help="Where the source meshes come from.")
@click.option("--url", help="Where the release is published (Croissant url).")
@click.option("--creator", help="Who made the release (Croissant creator).")
@click.option("--licenses", type=ExistingPath(exists=True, dir_okay=False, path_type=Path),
              help="CSV with the columns name, license, author, url: one row per model; "
              "each license an SPDX identifier or expression, or a URL.")
@click.option("--license-name", help="The hub's license_name when --license is other.")
@click.option("--license-link", help="The hub's license_link when --license is other.")
@click.option("--update-card", is_flag=True,
              help="DATASET is a release whose README.md was edited: rewrite croissant.json "
              "and SHA256SUMS to match it, leaving the archives as they are.")
def pack(dataset: Path, release_dir: Path | None, name: str, license_id: str,
         force_license: bool, formats: str, shard_size: str, dataset_version: str,
         created: str | None, pretty_name: str | None,
         source_url: str | None, url: str | None, creator: str | None,
         licenses: Path | None, license_name: str | None, license_link: str | None,
         update_card: bool) -> None:
    """Pack a built DATASET into RELEASE_DIR for publishing.

    Writes Parquet shards per split (data/train-00000-of-00012.parquet ...)
    and an HDF5 file with the same content (--formats adds a Zarr v3 zip),
    the dataset card README.md (with the hub's configs), croissant.json,
    SCHEMA.md and a SHA256SUMS manifest. RELEASE_DIR must be new or empty.
    With --update-card, DATASET is an existing release whose card a person
    edited; only croissant.json and SHA256SUMS are rewritten.

    \b
    Example:
      vptool pack out/ release/ --version 1.0.0 --created 2026-01-01T00:00:00Z \\
          --licenses licenses.csv --pretty-name "Viewpoints of my meshes"
      vptool pack out/ release/ --license CC-BY-4.0 --creator "Jane Doe" \\
          --shard-size 200MB
      vptool pack --update-card release/
    """
    if update_card:
        from vptoolkit.dataset.release.descriptions import update_card as rewrite

        if release_dir is not None:
            raise InputError("--update-card: takes the release folder only, no RELEASE_DIR")
        changed = rewrite(dataset)
        click.echo(f"updated {dataset}: {', '.join(changed)}")
        return
    if release_dir is None:
        raise InputError("RELEASE_DIR: missing (only --update-card takes one folder)")
    from vptoolkit.dataset.release.pack import pack_release

    chosen = [part.strip() for part in formats.split(",") if part.strip()]
    with options_named(shard_size="--shard-size", license="--license"):
        options = ReleaseOptions(
            name=name, license=license_id, formats=chosen, version=dataset_version,
            created=created, pretty_name=pretty_name, source_url=source_url, url=url,
            creator=creator, licenses=licenses, license_name=license_name,
            license_link=license_link, shard_size=shard_size, force_license=force_license,
        )
    result = pack_release(dataset, release_dir, options, progress=True)
    for line in result.warnings:
        click.echo(f"vptool: warning: {line}", err=True)
    top = sorted({name.split("/")[0] + ("/" if "/" in name else "") for name in result.files})
    click.echo(f"packed {result.n_models} models ({result.n_failures} failures), version "
               f"{result.version}, created {result.created}, into {result.path}: "
               f"{', '.join(top)}")


@click.command()
@click.argument("path", type=DATASET)
@click.option("--json", "as_json", is_flag=True, help="Print the full report as JSON.")
@cache_dir_option()
def verify(path: Path | str, as_json: bool, cache_dir: Path | None) -> None:
    """Re-hash a release folder or dataset store against its checksums.

    Every file is checked against SHA256SUMS and every array against the
    SHA-256 stored with it; each mismatch and each unlisted file is named.
    What cannot be read for lack of a package (a Zarr archive without zarr,
    the Parquet shards without pyarrow) is skipped and named in the summary.
    Exit code 0 when everything checked passed, 1 on any mismatch, 2 if
    nothing could be checked (the line says which package to install). PATH
    may be the URL of a release: every file is downloaded into --cache-dir,
    each refused unless it matches SHA256SUMS, and the copy is checked.

    \b
    Example:
      vptool verify release/
      vptool verify https://example.org/viewpoints/ --cache-dir cache/
    """
    from vptoolkit.data.remote import fetch_release, is_remote
    from vptoolkit.dataset.release.manifest import verify as verify_path

    # verifying reads every file: a URL is fetched whole, not read by open_dataset
    local = (fetch_release(str(path), cache_dir=cache_dir, everything=True) if is_remote(path)
             else path)
    report = verify_path(local)
    # The summary is printed once: on stdout when all is well, else as the error line.
    if as_json:
        click.echo(output_json(report.to_dict(), indent=2))
        if not report.ok:
            sys.exit(EXIT_FAILURE if report.problems else EXIT_BAD_INPUT)
        return
    if report.ok:
        click.echo(report.summary())
    report.raise_if_failed()


@click.command()
@click.argument("path", type=DATASET)
@click.option("--json", "as_json", is_flag=True, help="Print the information as JSON.")
@cache_dir_option()
def info(path: Path | str, as_json: bool, cache_dir: Path | None) -> None:
    """Show counts per category and split, conventions and failures of a dataset.

    PATH is a store, a build or release folder, or a release's URL
    (opened as vptoolkit.data.open_dataset opens it, cached in --cache-dir).

    \b
    Example:
      vptool info release/
      vptool info https://example.org/viewpoints/
    """
    from vptoolkit.data import open_dataset
    from vptoolkit.dataset.store.info import dataset_info, format_info

    with open_dataset(path, cache_dir=cache_dir, partial=False) as opened:
        details = dataset_info(opened.path)
    click.echo(output_json(details, indent=2) if as_json else format_info(details))


@click.command("import-authors")
@click.argument("tree", type=ExistingPath(exists=True, file_okay=False, path_type=Path))
@click.argument("out", type=click.Path(file_okay=False, path_type=Path))
@click.option("--categories", help="Comma-separated categories to import (default: all); the "
              "paper's split counts only their lines of small.txt.")
@click.option("--no-meshes", is_flag=True, help="Leave out objfiles/ (store empty meshes).")
@click.option("--check", "n_check", type=click.IntRange(1), help="Then measure N imported "
              "models with our pipeline and compare: rank correlation per measure and the "
              "angle between the best views.")
@click.option("--check-resolution", default=AUTHORS_RESOLUTION, show_default=True,
              type=click.IntRange(1, MAX_RESOLUTION), help="Image side in pixels of --check.")
def import_authors(tree: Path, out: Path, categories: str | None, no_meshes: bool,
                   n_check: int | None, check_resolution: int) -> None:
    """Import the paper authors' released data set TREE (data/<set>) into OUT.

    OUT/dataset.zarr is an ordinary store: their measures (vq5 = VE, vq4 = VR,
    vq7 = VKL, vq8 = VMI) as raw values and normalised per model, their points,
    normals and meshes, and the paper's split (index % 10 over the
    category-filtered lines of small.txt: 0-7 train, 8 validation, 9 test).
    A model with a missing or malformed file is a failure (exit code 1); a
    tree not in their layout is refused (exit code 2).

    \b
    Example:
      vptool import-authors data/ModelNet40 out/ \\
          --categories airplane,bench,bottle,car,chair,sofa,table,toilet --check 20
    """
    from vptoolkit.dataset.authors.importer import import_authors as run_import

    chosen = comma_list(categories)
    result = run_import(tree, out, categories=chosen, meshes=not no_meshes, progress=True)
    counts = ", ".join(f"{n} {split}" for split, n in result.split_counts.items())
    click.echo(f"imported {result.path}: {result.n_models} models ({counts}), "
               f"{result.n_failures} failures")
    for failure in result.failures:
        click.echo(f"  failed {failure['source']}: {failure['reason']}", err=True)
    if n_check is not None:
        from vptoolkit.dataset.authors.check import check_measures

        check = check_measures(result.path, n_check, resolution=check_resolution,
                               progress=True)
        click.echo(f"check: our measures at {check.resolution} px on {len(check.models)} "
                   "models against theirs")
        for measure, row in check.summary().items():
            correlation = row["mean_correlation"]
            angle = row["median_angle_deg"]
            click.echo(f"  {measure}: rank correlation "
                       f"{'-' if correlation is None else f'{correlation:.3f}'} (mean), best "
                       f"views {'-' if angle is None else f'{angle:.1f}'} deg apart (median)")
        for line in check.failures:
            click.echo(f"  not checked {line}", err=True)
    if result.n_failures:
        sys.exit(EXIT_FAILURE)


@click.command("export-authors")
@click.argument("dataset", type=EXISTING)
@click.argument("out", type=click.Path(file_okay=False, path_type=Path))
def export_authors(dataset: Path, out: Path) -> None:
    """Write DATASET in the paper authors' tree OUT (data/<set>) for their training code.

    small.txt is ordered so that the paper's rule (index % 10 over its lines)
    gives each model its split; the models it cannot place are listed. The
    store needs the 1000 Fibonacci views of the paper and its four measures
    (VE, VR, VKL, VMI: the only ones the authors' tree has folders for; any
    other measure the store holds is left out).

    \b
    Example:
      vptool export-authors out/ viewpoint_learning/data/mine
    """
    from vptoolkit.dataset.authors.export import export_authors as run_export

    result = run_export(dataset, out, progress=True)
    click.echo(f"exported {result.n_models} models into {result.path}")
    if result.mismatched:
        click.echo(f"vptool: warning: the paper's rule over small.txt gives "
                   f"{len(result.mismatched)} models another split than ours (the split "
                   f"sizes do not fit 8:1:1): {', '.join(result.mismatched)}", err=True)
    if result.n_meshless:
        click.echo(f"vptool: warning: {result.n_meshless} models have no stored mesh; "
                   "their objfiles/ entry is not written", err=True)
    if result.n_unseen_values:
        click.echo(f"vptool: warning: {result.n_unseen_values} raw values of views that see "
                   "nothing were written as their measure's worst value", err=True)


@click.command("split")
@click.argument("src", type=ExistingPath(exists=True, file_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The name,split CSV to write.")
@click.option("--validation", "fraction", type=click.FloatRange(0, 1, min_open=True,
              max_open=True), default=0.1, show_default=True,
              help="Share of each category that goes to validation.")
@click.option("--seed", default=SEED, show_default=True, type=int,
              help="Seed of the order within each category.")
@click.option("--categories", help="Comma-separated categories to include (default: all).")
def split(src: Path, output: Path, fraction: float, seed: int, categories: str | None) -> None:
    """Write a train/validation split of the meshes under SRC, stratified by category.

    Files whose name or category build-dataset refuses, or whose name has a
    space at one end or starts with a spreadsheet formula character (= + - @),
    are left out with a warning each. Within each category (folder) a seeded
    hash orders the models and the first --validation share (at least one,
    when the category has two or more models) goes to validation. The file is
    what build-dataset --splits reads; publish it beside your results so the
    split can be rebuilt.

    \b
    Example:
      vptool split meshes/ -o splits.csv --validation 0.1
      vptool build-dataset meshes/ out/ --splits splits.csv --workers 2
    """
    from vptoolkit.dataset.builder.sources import discover_models
    from vptoolkit.dataset.builder.split_files import (
        class_split,
        split_file_problem,
        write_split_file,
    )

    chosen = comma_list(categories)
    models = []
    for model in discover_models(src, chosen):
        problem = split_file_problem(model.category, model.name)
        if problem is None:
            models.append(model)
        else:  # as build-dataset would fail them, or a spreadsheet run them
            click.echo(f"vptool: warning: left out {model.source}: {problem}", err=True)
    if not models:
        raise InputError(f"{src}: no mesh file that a split file can list")
    splits = class_split([(model.category, model.name) for model in models],
                         fraction=fraction, seed=seed)
    write_split_file(output, splits)
    n_val = sum(1 for value in splits.values() if value == "validation")
    n_categories = len({model.category for model in models})
    click.echo(f"wrote {output}: {len(splits) - n_val} train, {n_val} validation "
               f"models in {n_categories} categories")


COMMANDS = (build_dataset, split, pack, verify, info, import_authors, export_authors)
"""The commands this module adds to ``vptool``."""
