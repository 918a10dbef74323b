"""The best-view search for other measures than the paper's four: the registry's values on
the drawn views, the measures a few views cannot give refused, the command and its file."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fixtures.builds import build_samples
from fixtures.environment import require_package
from vptoolkit.best_view import SearchSettings, coarse_directions, search_best_views
from vptoolkit.best_view.run import recorded_searchable, search_inputs
from vptoolkit.best_view.search import searchable_measures
from vptoolkit.cli import main
from vptoolkit.dataset.build.options import BuildOptions
from vptoolkit.errors import InputError
from vptoolkit.evaluate.scores import evaluate_predictions
from vptoolkit.io import load_mesh
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.measures.registry import PAPER_MEASURES, get_measure
from vptoolkit.mesh import Mesh
from vptoolkit.predictions import read_predictions
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings

UNSEARCHABLE = ("INS", "DVS", "SAL", "EVMI", "MS")


@pytest.fixture(scope="module")
def mug() -> Mesh:
    return load_mesh(sample_path("mug.obj"))


@pytest.mark.parametrize("measures", ["NVT,SL", "VE,NVT,I2,SS,MD,CE"])
def test_a_budget_covering_every_view_finds_the_exhaustive_best(mug, measures):
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
    report = evaluate_predictions(built, out, split="all")
    assert report.measures == ("SL", "INS", "NVT") and report.scored_measures == ("SL", "NVT")
    assert (report.scores[:, [0, 2]] > 50.0).all()
