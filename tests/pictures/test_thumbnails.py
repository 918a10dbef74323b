"""Thumbnails of a collection: best views, prediction hooks, bad files skipped, resumed."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from fixtures.environment import require_package
from fixtures.meshes import primitive_mesh
from fixtures.paths import MALFORMED
from fixtures.pictures import decode_png, model_mask, started_renderer
from vptoolkit.best_view.search import SearchSettings
from vptoolkit.camera import Camera
from vptoolkit.errors import InputError, MissingDependencyError
from vptoolkit.mesh import Mesh
from vptoolkit.pictures.engine import open_renderer
from vptoolkit.settings import MeasureSettings

SIZE = 96


@pytest.fixture(scope="module")
def renderer():
    yield from started_renderer(SIZE)


@pytest.fixture()
def mesh_folder(tmp_path: Path) -> Path:
    from vptoolkit.io import save_mesh

    source = tmp_path / "meshes"
    (source / "nested").mkdir(parents=True)
    save_mesh(primitive_mesh("box", {"extents": (1.0, 0.5, 0.3)}, "cube"), source / "cube.obj")
    save_mesh(primitive_mesh("box", {}, "cube"), source / "cube.off")  # same picture name
    save_mesh(primitive_mesh("icosphere", {"subdivisions": 2}, "ball"),
              source / "nested" / "ball.stl")
    (source / "bad.off").write_text("OFF\n3 1 0\n0 0 0\n")
    shutil.copy(MALFORMED / "empty.obj", source / "empty.obj")
    (source / "notes.txt").write_text("not a mesh")
    return source


@pytest.mark.renderer
def test_thumbnails_of_a_folder_skip_and_report_bad_files(mesh_folder: Path, tmp_path: Path,
                                                          renderer):
    from vptoolkit.pictures.thumbnails import ThumbnailResult, render_thumbnails

    out = tmp_path / "thumbs"
    result = render_thumbnails(mesh_folder, out, measure="VR", workers=2,
                               settings=MeasureSettings(views=40, resolution=48), engine=renderer)
    assert isinstance(result, ThumbnailResult)
    assert result.done == [out / "cube.obj.png", out / "cube.off.png",
                           out / "nested" / "ball.stl.png"]
    for path in result.done:
        image = decode_png(path.read_bytes())
        assert image.shape == (SIZE, SIZE, 3) and model_mask(image).any()
    reasons = {failure.source: failure.reason for failure in result.failures}
    assert sorted(reasons) == ["bad.off", "empty.obj"]
    assert reasons["bad.off"].startswith("bad.off: ")
    index = json.loads(result.index.read_text())
    assert index["measure"] == "VR" and index["direction_from"] == "measures"
    assert index["settings"] == {"method": "measure",
                                 "settings": MeasureSettings(views=40, resolution=48).to_dict()}
    assert index["size"] == SIZE
    assert [r["source"] for r in index["thumbnails"]] == ["cube.obj", "cube.off",
                                                          "nested/ball.stl"]
    assert index["thumbnails"][0]["label"] == "best of 40 views"
    assert [f["source"] for f in index["failures"]] == ["bad.off", "empty.obj"]


def test_thumbnails_search_by_default_and_a_rerun_draws_nothing_done(mesh_folder: Path,
                                                                     tmp_path: Path):
    from vptoolkit.pictures.thumbnails import render_thumbnails

    out = tmp_path / "thumbs"
    search = SearchSettings(budget=12, resolution=32)
    with open_renderer(size=32) as engine:
        first = render_thumbnails(mesh_folder, out, search=search, engine=engine)
        assert first.n_drawn == 3
        index = json.loads(first.index.read_text())
        assert index["settings"]["method"] == "search"
        assert index["thumbnails"][0]["label"] == "searched VE (12 views)"
        picture = out / "nested" / "ball.stl.png"
        picture.unlink()  # drawn, yet staged: a rerun takes the record as it is
        again = render_thumbnails(mesh_folder, out, search=search, engine=engine)
    assert again.n_drawn == 0 and again.done == first.done
    assert again.index.read_bytes() == first.index.read_bytes()
    assert again.table is not None and again.table.read_bytes() == first.table.read_bytes()


def test_thumbnails_are_drawn_in_their_colours_and_indexed(tmp_path: Path):
    require_package("PIL")
    from vptoolkit.pictures.thumbnails import render_thumbnails
    from vptoolkit.samples import sample_path

    source = tmp_path / "models"
    source.mkdir()
    shutil.copy(sample_path("Duck.glb"), source / "Duck.glb")
    shutil.copy(sample_path("teapot.stl"), source / "teapot.stl")
    with open_renderer(size=64) as engine:
        result = render_thumbnails(source, tmp_path / "thumbs",
                                   search=SearchSettings(budget=12, resolution=32), engine=engine)
    duck = decode_png((tmp_path / "thumbs" / "Duck.glb.png").read_bytes()).astype(float)
    red, green, blue = duck[model_mask(duck.astype("uint8"))].mean(axis=0)
    assert red > 150 and green > 120 and blue < 80, (red, green, blue)  # its yellow texture
    teapot = decode_png((tmp_path / "thumbs" / "teapot.stl.png").read_bytes()).astype(float)
    grey = teapot[model_mask(teapot.astype("uint8"))]
    assert (grey[:, 2] >= grey[:, 0]).mean() > 0.95  # no colours: the blue-grey
    assert result.html == tmp_path / "thumbs" / "index.html"
    page = result.html.read_text()
    assert page.count('loading="lazy"') == 2
    assert 'src="Duck.glb.png"' in page and 'src="teapot.stl.png"' in page


@pytest.mark.renderer
def test_thumbnails_from_a_prediction_hook(mesh_folder: Path, tmp_path: Path, renderer):
    from vptoolkit.pictures.thumbnails import render_thumbnails

    seen = []

    def predict(mesh: Mesh) -> list[float]:
        seen.append(mesh.name)
        return [0.0, 0.0, 2.0]

    result = render_thumbnails(mesh_folder / "nested", tmp_path / "out", predictor=predict,
                               engine=renderer)
    assert seen == ["ball"] and result.done == [tmp_path / "out" / "ball.stl.png"]
    index = json.loads(result.index.read_text())
    assert index["thumbnails"] == [{"source": "ball.stl", "image": "ball.stl.png",
                                    "direction": [0.0, 0.0, 1.0], "label": "predicted VE"}]


def test_thumbnails_without_a_renderer_stop_before_any_work(mesh_folder: Path, tmp_path: Path,
                                                            monkeypatch):
    require_package("open3d")
    from vptoolkit.pictures.thumbnails import render_thumbnails

    for variable in ("VK_ICD_FILENAMES", "VK_DRIVER_FILES"):
        monkeypatch.setenv(variable, "/nonexistent/vptoolkit-test-icd.json")
    with pytest.raises(MissingDependencyError, match="^renderer: Open3D's offscreen renderer "
                                                     "could not start"):
        with open_renderer("open3d", size=32) as engine:
            render_thumbnails(mesh_folder, tmp_path / "out", engine=engine)
    assert not list((tmp_path / "out").rglob("*.png"))


def test_thumbnails_check_their_arguments(mesh_folder: Path, tmp_path: Path):
    from vptoolkit.pictures.thumbnails import render_thumbnails

    with pytest.raises(InputError, match="unknown measure"):
        render_thumbnails(mesh_folder, tmp_path / "out", measure="best")
    with pytest.raises(InputError, match="no such folder"):
        render_thumbnails(tmp_path / "missing", tmp_path / "out")
    with pytest.raises(InputError, match="workers"):
        render_thumbnails(mesh_folder, tmp_path / "out", workers=0)
    with pytest.raises(InputError, match="engine: expected an Engine"):
        render_thumbnails(mesh_folder, tmp_path / "out", engine="software")  # type: ignore[arg-type]
    mirrored = MeasureSettings(camera=Camera(cull_back_faces=False))
    with pytest.raises(InputError, match="engine: its camera differs from the camera"), \
            open_renderer(size=32) as engine:
        render_thumbnails(mesh_folder, tmp_path / "out", settings=mirrored, engine=engine)
    assert not list((tmp_path / "out").rglob("*.png"))


def test_view_set_thumbnails_draw_with_the_camera_of_the_settings(mesh_folder: Path,
                                                                  tmp_path: Path):
    from vptoolkit.pictures.thumbnails import render_thumbnails

    camera = Camera(fov_deg=30.0, distance_factor=2.0)
    settings = MeasureSettings(views=40, resolution=48, camera=camera)
    out = tmp_path / "out"
    with open_renderer(size=32, camera=camera) as engine:
        result = render_thumbnails(mesh_folder, out, settings=settings, engine=engine,
                                   view_set=2)
    assert result.done == [out / "cube.obj.png", out / "cube.off.png",
                           out / "nested" / "ball.stl.png"]
    record = json.loads(result.index.read_text())["thumbnails"][0]
    assert len(record["direction"]) == 2 and record["label"].startswith("view set of 2")


def _drawn(out: Path) -> dict[str, bytes]:
    """Every picture below ``out``, by its path there."""
    return {str(path.relative_to(out)): path.read_bytes() for path in sorted(out.rglob("*.png"))}


def _draw_seconds(out: Path) -> list[float]:
    """The seconds each entry spent drawing in its worker (the run's timings)."""
    (timings,) = out.rglob("timings.jsonl")
    return [json.loads(line)["draw"] for line in timings.read_text().splitlines()]


@pytest.mark.slow
@pytest.mark.usefixtures("taken_dashboard_port")
def test_pictures_drawn_by_workers_are_the_bytes_drawn_here(mesh_folder: Path, tmp_path: Path):
    require_package("distributed")
    from distributed import LocalCluster

    from fixtures.environment import DASK_DASHBOARD
    from vptoolkit.pictures.software_engine import SoftwareRenderer
    from vptoolkit.pictures.thumbnails import render_thumbnails
    from vptoolkit.samples import sample_path

    class HereRenderer(SoftwareRenderer):
        """The software engine, drawing in this process (only the software engine's own
        class is sent to the workers)."""

    shutil.copy(sample_path("Duck.glb"), mesh_folder / "Duck.glb")  # drawn in its colours
    search = SearchSettings(budget=12, resolution=32, up="auto")
    with HereRenderer(size=48) as engine:
        render_thumbnails(mesh_folder, tmp_path / "here", search=search, engine=engine)
    here = _drawn(tmp_path / "here")
    assert sorted(here) == ["Duck.glb.png", "cube.obj.png", "cube.off.png",
                            "nested/ball.stl.png"]
    assert set(_draw_seconds(tmp_path / "here")) == {0.0}
    with open_renderer(size=48) as engine:
        for workers in (1, 2):
            out = tmp_path / f"workers-{workers}"
            render_thumbnails(mesh_folder, out, search=search, engine=engine, workers=workers)
            assert _drawn(out) == here, workers
        assert max(_draw_seconds(out)) > 0  # drawn in the workers
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=DASK_DASHBOARD) as cluster:
            render_thumbnails(mesh_folder, tmp_path / "dask", search=search, engine=engine,
                              scheduler=cluster.scheduler_address)
    assert _drawn(tmp_path / "dask") == here
