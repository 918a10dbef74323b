"""Commands that draw pictures: ``render``, ``sphere-map``, ``report`` and ``thumbnails``.

Picture functions are imported from :mod:`vptoolkit.pictures` inside each
command, so ``--help`` does not load a renderer.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from vptoolkit.checks import check_suffix
from vptoolkit.cli.group import EXIT_FAILURE
from vptoolkit.cli.options import (
    DATASET,
    MEASURE_NAME,
    MESH,
    MODEL_HELP,
    Direction,
    ExistingPath,
    budget_option,
    cache_dir_option,
    elevation_option,
    engine_option,
    face_limit_option,
    margin_option,
    max_points_option,
    parse_measures,
    resolution_option,
    scheduler_option,
    search_resolution_option,
    size_option,
    split_option,
    timeout_option,
    up_option,
    views_option,
    workers_option,
)
from vptoolkit.conventions import Split
from vptoolkit.errors import InputError
from vptoolkit.files import check_output_folder, output_json
from vptoolkit.pictures.report import REPORT_SIZE

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from vptoolkit.mesh import Mesh
    from vptoolkit.pictures.engine import Engine
    from vptoolkit.point_cloud import PointCloud

Vector = tuple[float, float, float]


@click.command()
@click.argument("mesh", type=MESH)
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="PNG file to write.")
@click.option("--view", type=Direction(),
              help="Direction x,y,z from the model centre towards the camera.")
@click.option("--best", type=MEASURE_NAME, help="Draw the best sampled view of this measure.")
@click.option("--model", "model_path", help=MODEL_HELP + " Draws its predicted view.")
@click.option("--view-set", "view_set_k", type=click.IntRange(1),
              help="Draw the K-view coverage set as one contact sheet, --size per tile.")
@click.option("--measure", default="VE", show_default=True, type=MEASURE_NAME,
              help="Measure whose prediction --model draws.")
@size_option()
@views_option("Views sampled for --best.")
@resolution_option("Triangle-ID resolution of the measures for --best.")
@up_option(allow_auto=True)
@margin_option()
@engine_option()
@click.option("--json", "as_json", is_flag=True,
              help="Print the file, name, views drawn (direction, camera pose, intrinsics) and "
                   "the PNG written as JSON.")
@max_points_option()
def render(mesh: Path, output: Path, view: Vector | None, best: str | None, model_path: str | None,
           view_set_k: int | None, measure: str, size: int, n_views: int, resolution: int,
           up: Vector | str, margin: float, engine: str, as_json: bool, max_points: int) -> None:
    """Draw MESH (a mesh or a point cloud) through the measures' camera into a PNG picture.

    Give exactly one of --view, --best, --model or --view-set. The picture shows
    what the measures score for that direction (same eye, target and up; the
    picture is magnified until the model fills it up to --margin), in the
    model's own colours and texture where the file has them; --view-set K
    draws the K views that together see the most of the surface as one
    captioned contact sheet. A point cloud is drawn as the measures' splats
    (a disc per point, sized by the local spacing), in its points' colours,
    lit along its normals where it has them (--engine software only; --model
    takes meshes). --json prints the file, the model's name, each view drawn
    (direction, camera pose and intrinsics of the picture) and the PNG
    written, as best-view --json does.

    \b
    Example:
      vptool render bunny.ply --best VE -o bunny_ve.png
      vptool render chair.off --model default -o chair.png
      vptool render chair.off --view 1,-1,1 --size 256 -o corner.png
      vptool render bunny.ply --view-set 4 --size 256 -o bunny_sheet.png
      vptool render bus.ply --view 1,-1,0.5 --up auto -o bus.png
      vptool render scan.ply --best VE --views 200 --json -o scan.png
    """
    from vptoolkit.io import load_with_appearance, require_surface
    from vptoolkit.pictures.engine import open_renderer
    from vptoolkit.pictures.png import save_png
    from vptoolkit.pictures.shading import RenderStyle
    from vptoolkit.pictures.views import RenderedView, render_best, render_predicted, render_view
    from vptoolkit.settings import MeasureSettings
    from vptoolkit.sphere import as_directions

    if sum(choice is not None for choice in (view, best, model_path, view_set_k)) != 1:
        raise InputError("render: give exactly one of --view, --best, --model or --view-set")
    check_suffix(output, ".png")
    check_output_folder(output, "--output")
    settings = MeasureSettings(views=n_views, resolution=resolution)
    loaded, appearance = load_with_appearance(mesh, max_points=max_points)
    if model_path is not None:  # the network reads surfaces
        loaded = require_surface(loaded, mesh.name)
    if up == "auto":
        from vptoolkit.upright import auto_up

        up = auto_up(loaded, mesh)
    assert not isinstance(up, str)  # "auto" is resolved above
    with open_renderer(engine, size=size, style=RenderStyle(up=up, margin=margin)) as drawing:
        if view_set_k is not None:
            from vptoolkit.pictures.contact_sheet import view_set_sheet

            sheet, chosen = view_set_sheet(loaded, view_set_k, settings=settings, engine=drawing,
                                           appearance=appearance)
            save_png(sheet, output)
            if as_json:
                labels = [f"view set pick {pick + 1} (view {index})"
                          for pick, index in enumerate(chosen.indices.tolist())]
                click.echo(output_json(_picture_record(mesh, loaded, output, drawing,
                                                       chosen.directions, labels)))
            else:
                click.echo(f"wrote {output} ({len(chosen)} views, views "
                           f"{chosen.indices.tolist()}, {100 * chosen.coverage[-1]:.1f} % of "
                           "the surface seen)")
            return
        if best is not None:
            picture = render_best(loaded, measure=best, settings=settings, engine=drawing,
                                  appearance=appearance)
        elif model_path is not None:
            from vptoolkit.learn.predict import MeshPredictor

            picture = render_predicted(loaded, MeshPredictor(model_path), measure=measure,
                                       engine=drawing, appearance=appearance)
        else:
            assert view is not None  # exactly one choice, checked above
            direction = as_directions(view, name="--view")[0]
            picture = RenderedView(render_view(loaded, direction, engine=drawing,
                                               appearance=appearance), direction, "--view")
        save_png(picture.image, output)
        if as_json:
            click.echo(output_json(_picture_record(mesh, loaded, output, drawing,
                                                   picture.direction[None, :], [picture.label])))
            return
    x, y, z = picture.direction
    click.echo(f"wrote {output} ({picture.label}, direction ({x:+.3f}, {y:+.3f}, {z:+.3f}))")


def _picture_record(source: Path, model: Mesh | PointCloud, output: Path, engine: Engine,
                    directions: NDArray[np.float64], labels: list[str]) -> dict[str, Any]:
    """``render --json``'s record: the file, the model, the picture written, and per view
    drawn its label, direction, camera pose (:func:`vptoolkit.best_view.answer.view_records`,
    the picture's roll) and the pinhole matrix of the picture (``size`` pixels, the framing's
    magnification in its focal length)."""
    from vptoolkit.best_view.answer import view_records
    from vptoolkit.pictures.shading import picture_poses

    poses, zoom = picture_poses(engine.camera, engine.style, model, directions, engine.size)
    views = view_records(poses, directions, engine.style.up)
    for record, label, factor in zip(views, labels, zoom):
        intrinsics = poses.intrinsics()
        intrinsics[:2, :2] *= factor
        record.update(label=label, intrinsics=intrinsics.tolist())
    return {"file": str(source), "name": model.name, "output": str(output),
            "size": engine.size, "up": list(engine.style.up), "views": views}


@click.command("sphere-map")
@click.argument("source", type=ExistingPath(exists=True, dir_okay=False, path_type=Path))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="PNG file to write.")
@click.option("--measure", type=MEASURE_NAME,
              help="Draw this one measure [default: the first the .npz records].")
@click.option("--measures", "measures_text",
              help="Draw these measures on one figure, four maps to a row: names (VE,SL,MD), "
                   "'paper' or 'all' (of an .npz: every measure it records; of a mesh: every "
                   "registered measure, computed) [default for a mesh: paper].")
@click.option("--predicted", type=Direction(),
              help="A predicted direction x,y,z to mark with a cross.")
@views_option("Views sampled when SOURCE is a mesh.")
@resolution_option("Triangle-ID image side when SOURCE is a mesh.")
@click.option("--dpi", default=100, show_default=True, type=click.IntRange(20, 600),
              help="Pixels per inch of the PNG (a row of four maps is 12 x 3.4 inches).")
@click.option("--json", "as_json", is_flag=True,
              help="Print the file, name, best view of each measure drawn (direction, camera "
                   "pose, intrinsics) and the PNG written as JSON.")
@max_points_option()
def sphere_map(source: Path, output: Path, measure: str | None, measures_text: str | None,
               predicted: Vector | None, n_views: int, resolution: int, dpi: int,
               as_json: bool, max_points: int) -> None:
    """Draw measures over the view sphere as Mercator maps.

    SOURCE is the .npz of vptool measures -o (drawn as recorded), or a mesh
    or point cloud (its measures computed first, --views at --resolution; a
    cloud's measures are those defined on points). --measure draws
    one map; --measures draws several on one figure, titled by the measures'
    names. Colours: normalised quality (1 = best); the star marks the best
    sampled view, the cross --predicted. --json prints, as best-view --json
    does, the best view of each measure drawn: its direction, raw value and
    camera pose (image up +y) with the intrinsics at --resolution; of an
    .npz, which holds no model to place a camera, the directions only (raw,
    pose, resolution and intrinsics null).

    \b
    Example:
      vptool measures bunny.ply -o bunny.npz
      vptool sphere-map bunny.npz --measure VMI -o bunny_vmi.png
      vptool sphere-map bunny.npz --measures all -o bunny_maps.png
      vptool sphere-map bunny.ply --measures all --views 500 --resolution 128 -o all.png
      vptool sphere-map scan.ply --measure VE --views 200 --json -o scan_ve.png
    """
    from vptoolkit.conventions import PICTURE_UP
    from vptoolkit.pictures.sphere_map import save_figure, sphere_map_file
    from vptoolkit.pictures.sphere_panels import sphere_maps, sphere_maps_file

    if measure is not None and measures_text is not None:
        raise InputError("sphere-map: give --measure or --measures, not both")
    check_suffix(output, ".png")
    check_output_folder(output, "--output")
    marked = None if predicted is None else list(predicted)
    if source.suffix.lower() == ".npz":
        every = measures_text is not None and measures_text.strip().lower() == "all"
        if measures_text is None:
            sphere_map_file(source, output, measure=measure, predicted=predicted, dpi=dpi)
        else:
            sphere_maps_file(source, output, predicted=predicted, dpi=dpi,
                             measures=None if every else parse_measures(measures_text))
        if not as_json:
            click.echo(f"wrote {output}")
            return
        import numpy as np

        from vptoolkit.measures.registry import measure_index
        from vptoolkit.pictures.sphere_map import read_quality_maps

        views, normalized, recorded, name = read_quality_maps(source)
        drawn = (recorded if every else recorded[:1] if measure is None and measures_text is None
                 else (measure,) if measure is not None else parse_measures(measures_text or ""))
        best: dict[str, dict[str, Any]] = {}
        for drawn_measure in drawn:
            column = measure_index(drawn_measure, recorded)
            direction = views[int(np.nanargmax(normalized[:, column]))]
            best[recorded[column]] = {"direction": [round(float(c), 6) for c in direction],
                                      "raw": None, "pose": None}
        click.echo(output_json({"file": str(source), "name": name, "output": str(output),
                                "views": len(views), "resolution": None,
                                "up": list(PICTURE_UP), "intrinsics": None, "best": best,
                                "predicted": marked}))
        return
    from vptoolkit.best_view.answer import view_records
    from vptoolkit.inputs import read_model
    from vptoolkit.measures.quality import compute_view_quality
    from vptoolkit.pictures.sphere_map import sphere_map as one_map
    from vptoolkit.settings import MeasureSettings

    names = (measure,) if measure is not None else parse_measures(measures_text or "paper")
    loaded = read_model(source, max_points=max_points)
    quality = compute_view_quality(loaded, MeasureSettings(views=n_views, resolution=resolution),
                                   measures=names, progress=True)
    title = f"{quality.name}: {len(quality.views)} views at {quality.resolution} px"
    if measure is not None:
        figure = one_map(quality.views, quality.normalized, measures=quality.measures,
                         predicted=predicted, title=title)
    else:
        figure = sphere_maps(quality.views, quality.normalized, measures=quality.measures,
                             predicted=predicted, title=title)
    save_figure(figure, output, dpi=dpi)
    if not as_json:
        click.echo(f"wrote {output} ({', '.join(quality.measures)})")
        return
    directions = quality.views[quality.best_index]
    poses = quality.camera.look_at(loaded, directions, resolution=quality.resolution)
    views_drawn = view_records(poses, directions, PICTURE_UP)
    best = {name: {"direction": view["direction"],
                   "raw": float(quality.raw[quality.best_index[column], column]),
                   "pose": view["pose"]}
            for column, (name, view) in enumerate(zip(quality.measures, views_drawn))}
    click.echo(output_json({"file": str(source), "name": quality.name, "output": str(output),
                            "views": len(quality.views), "resolution": quality.resolution,
                            "up": list(PICTURE_UP), "intrinsics": poses.intrinsics().tolist(),
                            "best": best, "predicted": marked}))


@click.command()
@click.argument("dataset", type=DATASET)
@click.option("-o", "--output", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for index.html and its pictures.")
@split_option("Report one split only, or all models.", default="all")
@click.option("--predictions", type=ExistingPath(exists=True, dir_okay=False, path_type=Path),
              help="Predictions (.npz of vptool predict) to score and draw.")
@size_option(REPORT_SIZE)
@click.option("--no-pictures", is_flag=True, help="Maps and tables only; needs no renderer.")
@click.option("--view-set", "view_set_k", default=4, show_default=True, type=click.IntRange(0),
              help="Views in each model's coverage view set (0 leaves it out).")
@up_option()
@engine_option()
@cache_dir_option()
def report(dataset: Path | str, output: Path, split: Split, predictions: Path | None, size: int,
           no_pictures: bool, view_set_k: int, up: Vector, engine: str,
           cache_dir: Path | None) -> None:
    """Write a static HTML page with one card per model of DATASET.

    DATASET is a store, a build or release folder, or a release's URL.
    Pictures from each measure's best view, the quality maps of every
    measure DATASET records (the paper's four unless it was built with
    others), the scores of --predictions, filters by category and split, and
    a summary table. Open OUTPUT/index.html in any browser; no server is
    needed.

    \b
    Example:
      vptool predict --model default --dataset release/ -o test.npz
      vptool report release/ --split test --predictions test.npz -o report/
    """
    from vptoolkit.data import open_dataset
    from vptoolkit.pictures.engine import open_renderer
    from vptoolkit.pictures.report import write_report
    from vptoolkit.pictures.shading import RenderStyle

    with open_dataset(dataset, cache_dir=cache_dir) as opened, open_renderer(
            engine, size=size, camera=opened.camera, style=RenderStyle(up=up)) as drawing:
        index = write_report(opened, output, split=split, predictions=predictions,
                             thumbnails=not no_pictures, engine=drawing, progress=True,
                             view_set=view_set_k or None)
    click.echo(f"wrote {index}")


@click.command()
@click.argument("src")
@click.argument("out", type=click.Path(file_okay=False, path_type=Path))
@click.option("--measure", default="VE", show_default=True, type=MEASURE_NAME,
              help="Measure whose best (or predicted) view is drawn.")
@click.option("--model", "model_path", help=MODEL_HELP + " Uses its predictions, measures nothing.")
@click.option("--view-set", "view_set_k", type=click.IntRange(1),
              help="Draw each mesh's K-view coverage set, chosen from --views measured views, "
                   "as a contact sheet instead.")
@size_option()
@workers_option("Local worker processes finding the views and, with --engine software, "
                "drawing the pictures.", default=1)
@scheduler_option()
@budget_option()
@search_resolution_option()
@face_limit_option()
@timeout_option()
@up_option(allow_auto=True)
@elevation_option("0,60")
@margin_option()
@engine_option()
@click.option("--dry-run", is_flag=True, help="Count the files of SRC and estimate hours and "
              "disk from a few, drawing and writing nothing.")
@max_points_option()
def thumbnails(src: str, out: Path, measure: str, model_path: str | None,
               view_set_k: int | None, size: int, workers: int, scheduler: str | None,
               budget: int, resolution: int, max_faces: int, timeout: float,
               up: Vector | str, elevation: tuple[float, float] | None, margin: float,
               engine: str, dry_run: bool, max_points: int) -> None:
    """Draw a thumbnail of every model of SRC from its best view into OUT.

    SRC is a folder (walked recursively), a quoted glob, one model file or
    @list.txt, meshes and point clouds mixed (a cloud is drawn as the
    measures' splats in its own colours; --model takes meshes only).
    SRC/a/b.off becomes OUT/a/b.off.png. Each best view comes from
    the anytime search with a budget of --views (--views 1000 and more measure
    every view of a Fibonacci sphere instead: the exhaustive answer, at
    --resolution). Each model is drawn in its own colours and texture where
    its file has them, magnified until it fills the picture up to --margin.
    OUT/thumbnails.json records directions and the files skipped with their
    reasons (exit status 1 if any); OUT/index.html shows the pictures, a page
    at a time; rerunning the command draws only what is missing. The software
    engine draws in the workers (--workers, --scheduler); --engine open3d and
    --model draw in this process. --up auto
    stands each model on the side it rests on (+y or +z, docs/conventions.md).
    The search keeps the camera within --elevation of the horizon of --up
    (default 0 to 60 degrees: at or above the horizon, as product pictures
    are taken; --elevation full searches the whole sphere); --views 1000 and
    more, --model and --view-set do not search and ignore it.

    \b
    Example:
      vptool thumbnails models/ thumbs/ --measure VKL --size 256
      vptool thumbnails models/ thumbs/ --workers 4 --views 1000 --resolution 1024
      vptool thumbnails models/ thumbs/ --model default
      vptool thumbnails models/ sheets/ --view-set 4 --size 192
      vptool thumbnails @models.txt thumbs/ --dry-run
      vptool thumbnails gazebo_models/ thumbs/ --up 0,0,1 --elevation 0,45
      vptool thumbnails scans/ thumbs/ --up auto
    """
    from vptoolkit.best_view.search import SearchSettings
    from vptoolkit.conventions import N_VIEWS
    from vptoolkit.pictures.engine import open_renderer
    from vptoolkit.pictures.shading import RenderStyle
    from vptoolkit.pictures.thumbnails import render_thumbnails, thumbnail_method
    from vptoolkit.settings import MeasureSettings

    if model_path is not None and view_set_k is not None:
        raise InputError("--view-set: --model gives one view per mesh; drop one of them")
    search = settings = None
    if view_set_k is not None or model_path is not None or budget >= N_VIEWS:
        settings = MeasureSettings(views=budget, resolution=resolution)
    else:
        search = SearchSettings(budget=budget, resolution=resolution,
                                up="auto" if isinstance(up, str) else up,
                                elevation=elevation)
    predictor = None
    if model_path is not None:
        from vptoolkit.learn.predict import MeshPredictor

        predictor = MeshPredictor(model_path)
    if dry_run:
        from vptoolkit.collection.plan import plan_collection

        method = thumbnail_method(measure, search, settings, predictor, model_path or "",
                                  view_set_k)
        # a shaded PNG takes about a byte per pixel of the picture (a sheet: per tile)
        pixels = size * size * (view_set_k or 1)
        for line in plan_collection(src, method, workers=workers, extra_bytes_per_file=pixels,
                                    max_faces=max_faces, timeout=timeout,
                                    max_points=max_points).lines():
            click.echo(line)
        return
    if up == "auto" and search is None:
        raise InputError("--up: auto needs the search (no --model, no --view-set, --views "
                         "under 1000); give the axis x,y,z")
    picture_up = (0.0, 1.0, 0.0) if isinstance(up, str) else up  # auto: each model turned to +y
    with open_renderer(engine, size=size, style=RenderStyle(up=picture_up, margin=margin)) \
            as drawing:
        result = render_thumbnails(src, out, measure=measure, search=search, settings=settings,
                                   predictor=predictor, predictor_name=model_path or "",
                                   view_set=view_set_k, workers=workers, scheduler=scheduler,
                                   engine=drawing, max_faces=max_faces,
                                   max_points=max_points, timeout=timeout, progress=True)
    click.echo(f"wrote {result.n_drawn} thumbnails to {out} ({len(result.done)} in all), "
               f"{len(result.failures)} skipped")
    for failure in result.failures:
        click.echo(f"  skipped {failure.source}: {failure.reason}", err=True)
    if result.failures:
        sys.exit(EXIT_FAILURE)


COMMANDS = (render, sphere_map, report, thumbnails)
"""The commands this module adds to ``vptool``."""
