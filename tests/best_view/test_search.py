"""The anytime best-view search: exhaustive agreement, its own coarse pass, orientation, errors;
other measures than the paper's four, those a few views cannot give refused, the command."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fixtures.builds import build_samples
from fixtures.environment import require_package
from vptoolkit.best_view.run import recorded_searchable, search_inputs
from vptoolkit.best_view.search import (
    SearchSettings,
    _Measuring,
    search_best_views,
    searchable_measures,
)
from vptoolkit.camera import Camera
from vptoolkit.cli import main
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.errors import InputError
from vptoolkit.evaluate.scores import evaluate_predictions
from vptoolkit.geometry import principal_frame
from vptoolkit.io import load_mesh
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.measures.registry import PAPER_MEASURES, get_measure
from vptoolkit.mesh import Mesh
from vptoolkit.predictions import read_predictions
from vptoolkit.rotations import fixed_rotations
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import coarse_directions

HIGHER_IS_BETTER = tuple(get_measure(name).higher_is_better for name in PAPER_MEASURES)


@pytest.fixture(scope="module")
def mug() -> Mesh:
    return load_mesh(sample_path("mug.obj"))


@pytest.fixture(scope="module")
def teapot() -> Mesh:
    return load_mesh(sample_path("teapot.stl"))


def test_a_budget_covering_every_view_finds_the_exhaustive_best(mug):
    directions = coarse_directions(mug, 120)
    exhaustive = compute_view_quality(mug, MeasureSettings(resolution=64),
                                      view_directions=directions)
    found = search_best_views(mug, SearchSettings(budget=120, resolution=64, coarse_views=120,
                                                   coarse_resolution=64))
    assert found.n_views == 120 and [s.name for s in found.stages] == ["coarse"]
    np.testing.assert_allclose(found.directions, exhaustive.best_views, rtol=0, atol=1e-12)
    best = exhaustive.raw[exhaustive.best_index, np.arange(4)]
    np.testing.assert_allclose(found.raw, best, rtol=1e-12)


def _better_or_equal(first, second):
    return [a >= b if higher else a <= b for a, b, higher in zip(first, second, HIGHER_IS_BETTER)]


@pytest.mark.parametrize("budget", [8, 16, 64])
def test_the_answer_is_never_worse_than_its_own_coarse_pass(teapot, budget):
    found = search_best_views(teapot, SearchSettings(budget=budget, resolution=256))
    coarse = next(stage for stage in found.stages if stage.name == "coarse")
    sphere = coarse_directions(teapot, coarse.n_views)
    renderer = _Measuring(teapot, Camera(), PAPER_MEASURES, 256)
    coarse_raw = renderer.measure(sphere, coarse.resolution, estimate_face_probability=True)
    coarse_best = compute_view_quality(teapot, MeasureSettings(resolution=coarse.resolution),
                                       view_directions=sphere).best_views
    again = renderer.measure(coarse_best, 256)  # the coarse pass's best, drawn at 256 px
    assert np.isfinite(coarse_raw).any()
    assert all(_better_or_equal(found.raw, np.diagonal(again)))
    assert found.n_views <= budget


def test_stages_spend_the_budget_and_decide_at_the_resolution(teapot):
    found = search_best_views(teapot, SearchSettings(budget=64, resolution=256))
    assert [s.name for s in found.stages] == ["coarse", "confirm", "refine"]
    assert found.n_views == 64 and found.stages[0].n_views == 32
    assert [s.resolution for s in found.stages] == [128, 256, 256]
    small = search_best_views(teapot, SearchSettings(budget=64, resolution=96))
    assert [(s.name, s.resolution) for s in small.stages] == [("coarse", 96), ("refine", 96)]
    flat = search_best_views(teapot, SearchSettings(budget=8, resolution=96))
    assert [(s.name, s.n_views, s.resolution) for s in flat.stages] == [("coarse", 8, 96)]
    np.testing.assert_allclose(np.linalg.norm(found.directions, axis=1), 1.0)
    summary = json.loads(json.dumps(found.summary()))
    assert list(summary["best"]) == list(PAPER_MEASURES) and summary["views"] == 64


def test_the_coarse_sphere_turns_with_the_mesh(teapot):
    turn = fixed_rotations("teapot", 1)[0]
    turned = Mesh(teapot.vertices @ turn.T, teapot.faces, name="teapot")
    axes, turned_axes = principal_frame(teapot), principal_frame(turned)
    # each axis turns with the mesh, up to its sign
    cosines = np.sum((axes @ turn.T) * turned_axes, axis=1)
    np.testing.assert_allclose(np.abs(cosines), 1.0, atol=1e-9)


def test_a_cloud_of_the_mesh_has_its_frame_and_is_searched_from_its_bounding_box(teapot):
    from vptoolkit.point_areas import point_areas
    from vptoolkit.point_cloud import PointCloud
    from vptoolkit.points import sample_surface

    sample = sample_surface(teapot, 20000, seed=0)
    cloud = PointCloud(sample.points, sample.normals, name="teapot")
    cosines = np.sum(principal_frame(teapot) * principal_frame(cloud, point_areas(cloud.points)),
                     axis=1)
    assert np.abs(cosines).min() > 0.99  # the same axes up to sampling and sign
    found = search_best_views(cloud, SearchSettings(budget=16, resolution=64))
    assert found.name == "teapot" and found.n_views == 16
    expected = Camera().look_at(cloud, found.directions, resolution=64)
    np.testing.assert_array_equal(found.poses.eyes, expected.eyes)
    again = search_best_views(np.concatenate([cloud.points, cloud.normals], axis=1),
                              SearchSettings(budget=16, resolution=64))
    np.testing.assert_array_equal(again.directions, found.directions)


def test_any_orientation_finds_views_as_good(teapot):
    """Under four rotations the answer, turned back, is nearly as good as the upright one's."""
    labels = compute_view_quality(teapot, MeasureSettings(views=500, resolution=96))
    from vptoolkit.sphere import nearest_view

    def score(directions):
        index = nearest_view(directions, labels.views)
        return labels.normalized[index, np.arange(4)]

    upright = score(search_best_views(teapot, SearchSettings(budget=64, resolution=96)).directions)
    turned = []
    for turn in fixed_rotations("teapot", 4):
        mesh = Mesh(teapot.vertices @ turn.T, teapot.faces, name="teapot")
        found = search_best_views(mesh, SearchSettings(budget=64, resolution=96))
        turned.append(score(found.directions @ turn))
    assert np.mean(turned, axis=0).min() > 0.85 and upright.min() > 0.85


def test_same_inputs_give_the_same_answer(mug):
    first = search_best_views(mug, SearchSettings(budget=32, resolution=64))
    second = search_best_views(mug, SearchSettings(budget=32, resolution=64))
    assert first.directions.tobytes() == second.directions.tobytes()
    assert first.raw.tobytes() == second.raw.tobytes()


def test_a_prior_is_drawn_first_at_full_resolution(mug):
    found = search_best_views(mug, SearchSettings(budget=16, resolution=64),
                              prior=[[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    assert [(s.name, s.n_views, s.resolution) for s in found.stages][:2] == [
        ("coarse", 7, 64), ("prior", 2, 64)]
    assert found.n_views == 16


@pytest.mark.parametrize("options, message", [
    ({"budget": 0}, "budget: expected an integer from 1"),
    ({"budget": 2.5}, "budget: expected an integer"),
    ({"resolution": 0}, "resolution: expected an integer from 1"),
    ({"coarse_views": 99}, "coarse_views: expected an integer from 0 to 16"),
    ({"coarse_resolution": 1000}, "coarse_resolution: expected an integer from 1 to 64"),
    ({"prior": [[np.nan, 0, 1]]}, "prior: contains NaN"),
    ({"prior": [[0, 0, 0]]}, "prior: contains 1 zero-length"),
])
def test_bad_options_are_one_line_input_errors(mug, options, message):
    arguments = {"budget": 16, "resolution": 64, **options}
    prior = arguments.pop("prior", None)
    with pytest.raises(InputError, match=message):
        search_best_views(mug, SearchSettings(**arguments), prior=prior)


def test_settings_must_be_search_settings(mug):
    with pytest.raises(InputError, match="^settings: expected SearchSettings, got int"):
        search_best_views(mug, 16)


def test_a_mesh_of_zero_area_is_named_without_numpy_warnings():
    line = Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), np.array([[0, 1, 2]]),
                name="line")
    with pytest.raises(InputError, match="^line: the mesh has zero surface area$"):
        # pytest turns a RuntimeWarning into an error
        search_best_views(line, SearchSettings(budget=8, resolution=32))


# --- other measures than the paper's four -------------------------------------------------


UNSEARCHABLE = ("INS", "DVS", "SAL", "EVMI", "MS")


@pytest.mark.parametrize("measures", ["NVT,SL", "VE,NVT,I2,SS,MD,CE"])
def test_every_view_in_the_budget_finds_the_exhaustive_best_of_other_measures(mug, measures):
    """One flat sphere: every view competes with all the others at once, so each measure's
    answer is the best of compute_view_quality over the same views, raw value included
    (also I2 and SS, which compare a view with the other drawn views)."""
    directions = coarse_directions(mug, 120)
    exhaustive = compute_view_quality(mug, MeasureSettings(resolution=64),
                                      view_directions=directions, measures=measures)
    found = search_best_views(mug, SearchSettings(budget=120, resolution=64, coarse_views=120,
                                                   coarse_resolution=64),
                              measures=measures)
    assert found.measures == exhaustive.measures == tuple(measures.split(","))
    assert found.directions.shape == (len(found.measures), 3)
    np.testing.assert_allclose(found.directions, exhaustive.best_views, rtol=0, atol=1e-12)
    best = exhaustive.raw[exhaustive.best_index, np.arange(len(found.measures))]
    np.testing.assert_allclose(found.raw, best, rtol=1e-12)


def test_refinement_improves_on_the_coarse_sphere_for_registry_measures(mug):
    found = search_best_views(mug, SearchSettings(budget=64, resolution=64), measures="NVT,SL")
    coarse = next(stage for stage in found.stages if stage.name == "coarse")
    sphere = coarse_directions(mug, coarse.n_views)
    on_sphere = compute_view_quality(mug, MeasureSettings(resolution=64),
                                     view_directions=sphere, measures="NVT,SL")
    assert found.n_views == 64 and [s.name for s in found.stages] == ["coarse", "refine"]
    for column, name in enumerate(found.measures):  # both are higher-is-better
        assert get_measure(name).higher_is_better
        assert found.raw[column] >= on_sphere.raw[:, column].max()
    summary = json.loads(json.dumps(found.summary()))
    assert list(summary["best"]) == ["NVT", "SL"]
    assert found.camera_pose("sl").shape == (4, 4)
    with pytest.raises(InputError, match="'VE' was not searched"):
        found.camera_pose("VE")


def test_measures_a_few_views_cannot_give_are_refused_in_one_line(mug):
    with pytest.raises(InputError) as caught:
        search_best_views(mug, SearchSettings(budget=16, resolution=64), measures="VE,INS,SAL")
    text = str(caught.value)
    assert "\n" not in text and text.startswith("measures: INS (")
    assert "neighbouring views" in text and "SAL (a saliency computed from all views)" in text
    assert "VE" not in text.split("cannot")[0]
    assert searchable_measures(None) == PAPER_MEASURES
    for name in UNSEARCHABLE:
        with pytest.raises(InputError, match=f"measures: {name} "):
            searchable_measures(name)


def test_a_dataset_gives_its_searchable_measures():
    assert recorded_searchable(("VE", "INS", "NVT", "XX")) == ("VE", "NVT")
    with pytest.raises(InputError, match="store.zarr: records no measure a search can evaluate"):
        recorded_searchable(("INS", "DVS"), "store.zarr")


def test_the_command_searches_the_named_measures(mug, runner, tmp_path):
    out = tmp_path / "best.npz"
    result = runner.invoke(main, ["best-view", str(sample_path("mug.obj")), "--measures",
                                  "NVT,SL", "--views", "16", "--resolution", "64", "-o", str(out)])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert [line.split()[0] for line in lines[1:3]] == ["NVT", "SL"]
    names, directions, measures = read_predictions(out)
    assert names == ("mug",) and measures == ("NVT", "SL") and directions.shape == (1, 2, 3)
    expected = search_best_views(mug, SearchSettings(budget=16, resolution=64), measures="NVT,SL")
    np.testing.assert_allclose(directions[0], expected.directions)


@pytest.mark.parametrize(("value", "message"), [
    ("INS", "--measures: INS (the neighbouring views of each view) cannot be evaluated"),
    ("all", "--measures: INS"),
    ("VE,XX", "--measures: unknown measure 'XX'"),
], ids=["instability", "all", "unknown"])
def test_the_command_refuses_in_one_line(runner, tmp_path, value, message):
    result = runner.invoke(main, ["best-view", str(sample_path("mug.obj")), "--measures", value,
                                  "-o", str(tmp_path / "best.npz")])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vptool: error: ") and message in lines[0]
    assert not (tmp_path / "best.npz").exists()


def test_with_a_dataset_the_search_follows_its_recorded_measures(runner, tmp_path):
    require_package("zarr")
    options = BuildOptions(MeasureSettings(views=40, resolution=48), measures="SL,INS,NVT",
                           n_points=200, clean=False)
    built = build_samples(tmp_path, ("mug.obj", "teapot.stl"), category="things",
                          options=options)
    run = search_inputs(dataset=built, split=None,
                        settings=SearchSettings(budget=16, resolution=48))
    assert run.measures == ("SL", "NVT") and run.predictions.measures == ("SL", "NVT")
    out = tmp_path / "found.npz"
    result = runner.invoke(main, ["best-view", "--dataset", str(built), "--split", "all",
                                  "--views", "16", "--resolution", "48", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert read_predictions(out).measures == ("SL", "NVT")
    report = evaluate_predictions(built, out, split=None)
    assert report.measures == ("SL", "INS", "NVT") and report.scored_measures == ("SL", "NVT")
    assert (report.scores[:, [0, 2]] > 50.0).all()
