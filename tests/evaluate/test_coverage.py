"""Scoring predicted view sets: coverage against the greedy sets, from Python and the CLI."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from fixtures.environment import require_package
from vptoolkit.cli import main
from vptoolkit.errors import InputError
from vptoolkit.evaluate.coverage import evaluate_view_sets, score_view_sets
from vptoolkit.mesh import Mesh
from vptoolkit.settings import MeasureSettings
from vptoolkit.view_sets.search import best_view_set
from vptoolkit.view_sets.visibility import FaceVisibility


def greedy_directions(dataset, k: int) -> np.ndarray:
    sets = []
    for model, name in enumerate(dataset.names):
        vertices, faces = dataset.mesh(model)
        visibility = FaceVisibility.from_mesh(
            Mesh(vertices.astype(float), faces.astype(np.int64), name),
            MeasureSettings(resolution=int(dataset.attrs["resolution"])),
            view_directions=dataset.views)
        chosen = best_view_set(visibility, k).directions  # fewer when k views add nothing
        sets.append(np.concatenate([chosen, np.repeat(chosen[-1:], k - len(chosen), axis=0)]))
    return np.stack(sets)


def test_the_greedy_sets_score_100_percent_and_one_repeated_view_less(tiny_dataset):
    from vptoolkit.data import open_dataset

    with open_dataset(tiny_dataset) as dataset:
        directions = greedy_directions(dataset, 3)
        report = score_view_sets(dataset, directions)
        # the greedy coverage comes from the build's record, rounded to 6 decimals
        np.testing.assert_allclose(report.predicted, report.greedy, atol=1e-6)
        np.testing.assert_allclose(report.ratio, 100.0, atol=1e-3)
        repeated = score_view_sets(dataset, np.repeat(directions[:, :1], 3, axis=1))
        assert (repeated.predicted[:, 0] == repeated.predicted[:, -1]).all()
        assert (repeated.ratio < 100.0).all()
        assert report.to_dict()["k"] == 3 and len(report.to_dict()["models"]) == len(dataset)


def test_cli_scores_view_sets_from_an_npz(tiny_dataset, tmp_path):
    from vptoolkit.data import open_dataset

    with open_dataset(tiny_dataset) as dataset:
        names = dataset.names
        directions = greedy_directions(dataset, 2)
    path = tmp_path / "sets.npz"
    np.savez(path, names=np.array(names[::-1]), directions=directions[::-1])
    result = CliRunner().invoke(main, ["evaluate", str(path), "--dataset", str(tiny_dataset),
                                       "--split", "all", "--view-sets"])
    assert result.exit_code == 0, result.output
    mean_row = [line for line in result.stdout.splitlines() if line.startswith("mean")][0]
    assert mean_row.split()[-1] == "100.0"


def test_directions_near_the_largest_float_score_as_their_unit_vectors(tiny_dataset, tmp_path):
    import warnings

    from vptoolkit.data import open_dataset

    with open_dataset(tiny_dataset) as dataset:
        names = dataset.names
        directions = greedy_directions(dataset, 2)
    rows = []
    for scale in (1.0, 1.7e308):
        path = tmp_path / f"sets-{scale}.npz"
        np.savez(path, names=np.array(names), directions=directions * scale)
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)  # numpy's overflow warning
            result = CliRunner().invoke(main, ["evaluate", str(path), "--dataset",
                                               str(tiny_dataset), "--split", "all",
                                               "--view-sets"])
        assert result.exit_code == 0, result.output
        assert "overflow" not in result.output
        rows.append([line for line in result.stdout.splitlines() if line.startswith("mean")])
    assert rows[1] == rows[0] and rows[0][0].split()[-1] == "100.0"
    per_measure = tmp_path / "huge.npz"  # the per-measure evaluation reads them the same way
    np.savez(per_measure, names=np.array(names), measures=np.array(["VE", "VR", "VKL", "VMI"]),
             directions=np.repeat(directions[:, :1], 4, axis=1) * 1.7e308)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        result = CliRunner().invoke(main, ["evaluate", str(per_measure), "--dataset",
                                           str(tiny_dataset), "--split", "all"])
    assert result.exit_code == 0 and "overflow" not in result.output, result.output


def test_bad_view_set_files_are_one_line_errors(tiny_dataset, tmp_path):
    flat = tmp_path / "flat.npy"
    np.save(flat, np.ones((4, 3)))
    with pytest.raises(InputError, match=r"flat.npy: expected view sets of shape \(n_models, k"):
        evaluate_view_sets(tiny_dataset, flat, split=None)
    short = tmp_path / "short.npy"
    np.save(short, np.ones((1, 2, 3)))
    result = CliRunner().invoke(main, ["evaluate", str(short), "--dataset", str(tiny_dataset),
                                       "--split", "all", "--view-sets"])
    assert result.exit_code == 2
    assert "short.npy: holds 1 view sets" in result.stderr


def test_report_shows_each_models_view_set_and_marks_it_on_the_maps(tiny_dataset, tmp_path):
    require_package("matplotlib")
    import re

    from fixtures.pictures import read_png
    from vptoolkit.data import open_dataset
    from vptoolkit.evaluate.coverage import model_visibility
    from vptoolkit.pictures.report import write_report

    index = write_report(tiny_dataset, tmp_path / "report", thumbnails=False, view_set=3)
    page = index.read_text(encoding="utf-8")
    rows = re.findall(r"view set: (\d) views see ([\d.]+) % of the surface", page)
    with open_dataset(tiny_dataset) as dataset:
        assert len(rows) == len(dataset)
        for position, (n_views, seen) in enumerate(rows):
            expected = best_view_set(model_visibility(dataset, position), 3)
            assert int(n_views) == len(expected)
            assert float(seen) == pytest.approx(100 * expected.coverage[-1], abs=0.05)
    picture = read_png(next((tmp_path / "report" / "maps").glob("*.png")))[..., :3].astype(int)
    orange = (picture[..., 0] > 230) & (abs(picture[..., 1] - 165) < 25) & (picture[..., 2] < 60)
    assert orange.sum() > 20  # the numbered view-set circles


def test_the_build_stores_each_models_coverage_set_and_the_loader_reads_it(tiny_dataset):
    from vptoolkit.data import open_dataset
    from vptoolkit.dataset.builder.compute import VIEW_SET_VIEWS

    with open_dataset(tiny_dataset) as dataset:
        for position in range(len(dataset)):
            stored = dataset.view_set(position)
            assert 1 <= len(stored) <= VIEW_SET_VIEWS and stored.objective == "coverage"
            assert stored.indices[0] == dataset[position]["best_index"][1]  # the best VR view
            np.testing.assert_array_equal(stored.directions, dataset.views[stored.indices])
            assert np.all(np.diff(stored.coverage) > 0) and stored.coverage[-1] <= stored.reachable
            assert len(dataset.view_set(position, 2)) == min(2, len(stored))
            record = dataset.record(position)["view_set"]
            assert record["indices"] == stored.indices.tolist()


def test_a_store_without_view_sets_still_loads_and_reports(tiny_dataset, tmp_path):
    """Stores written before view sets have no view_set in their records."""
    import dataclasses

    from vptoolkit.data import open_dataset
    from vptoolkit.dataset.store.reader import open_store
    from vptoolkit.dataset.store.writer import write_dataset
    from vptoolkit.evaluate.coverage import model_view_set

    with open_store(next(tiny_dataset.glob("dataset.*"))) as reader:
        entries = [dataclasses.replace(reader.entry(i), view_set=None)
                   for i in range(reader.n_models)]
        attrs = {key: reader.attrs[key] for key in ("resolution", "backend", "camera", "cleaning",
                                                    "split_seed", "split_fractions", "source",
                                                    "toolkit_version", "created")}
        views = np.asarray(reader.array("views"))
    old = write_dataset(tmp_path / "old.zarr", entries, views=views, attrs=attrs, failures=[])
    with open_dataset(old) as dataset, open_dataset(tiny_dataset) as built:
        assert dataset.view_set(0) is None and "view_set" not in dataset.record(0)
        searched = model_view_set(dataset, 0, 2)  # searched from the stored mesh instead
        assert searched.indices[0] == built.view_set(0).indices[0]
