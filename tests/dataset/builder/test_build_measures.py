"""``vptool build-dataset --measures``: a store of the chosen measures, computed by the
pipeline, named in the store and followed by the reader, ``vptool info`` and the loader."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from vptoolkit.cli import main
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.dataset.store.reader import open_store
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings

THREE = ("VE", "NVT", "SL")
DRAW = ["--views", "80", "--resolution", "64", "--points", "200", "--no-clean"]
SETTINGS = MeasureSettings(views=80, resolution=64)


@pytest.fixture(scope="module")
def src(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two bundled samples, one per category."""
    root = tmp_path_factory.mktemp("src")
    for category, sample in (("bottle", "bottle.obj"), ("mug", "mug.obj")):
        (root / category).mkdir()
        shutil.copy(sample_path(sample), root / category / sample)
    return root


def _build(src: Path, out: Path, *extra: str) -> Path:
    result = CliRunner().invoke(main, ["build-dataset", str(src), str(out), *DRAW, *extra])
    assert result.exit_code == 0, result.output
    return out


@pytest.fixture(scope="module")
def three(src: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The build folder of ``--measures VE,NVT,SL``."""
    return _build(src, tmp_path_factory.mktemp("three") / "out", "--measures", ",".join(THREE))


@pytest.fixture(scope="module")
def paper(src: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The build folder of the same models with the default measures."""
    return _build(src, tmp_path_factory.mktemp("paper") / "out")


def test_the_store_records_the_chosen_measures_with_one_column_each(three: Path) -> None:
    with open_store(three / "dataset.zarr") as store:
        assert store.attrs["measures"] == list(THREE)
        assert store.attrs["higher_is_better"] == [True, True, True]
        assert store.measures == THREE
        assert store.array("quality").shape == (2, 80, 3)
        assert store.array("quality_raw").shape == (2, 80, 3)
        for name in ("best_index", "best_value", "worst_index", "worst_value"):
            assert store.array(name).shape == (2, 3), name


def test_stored_values_are_the_measures_of_the_stored_meshes(three: Path) -> None:
    from vptoolkit.measures.quality import compute_view_quality
    from vptoolkit.mesh import Mesh

    with open_store(three / "dataset.zarr") as store:
        for entry in store.entries():
            mesh = Mesh(entry.vertices.astype(np.float64), entry.faces.astype(np.int64),
                        name=entry.name)  # built without cleaning: the measured mesh
            expected = compute_view_quality(mesh, SETTINGS, measures=THREE)
            np.testing.assert_allclose(entry.quality_raw, expected.raw, rtol=1e-6)
            np.testing.assert_allclose(entry.quality, expected.normalized, atol=1e-6)
            np.testing.assert_array_equal(entry.best_index, expected.best_index)
            np.testing.assert_array_equal(entry.best_value,
                                          entry.quality_raw[entry.best_index, [0, 1, 2]])
            silhouette = entry.quality_raw[:, 2]
            assert np.all(silhouette[np.isfinite(silhouette)] > 0)  # SL drew contours


def test_a_measure_both_builds_hold_agrees_and_so_does_the_view_set(three: Path,
                                                                     paper: Path) -> None:
    with open_store(three / "dataset.zarr") as ours, open_store(paper / "dataset.zarr") as four:
        assert four.measures == PAPER_MEASURES
        assert four.attrs["higher_is_better"] == [True, True, False, False]
        assert four.array("quality").shape == (2, 80, 4)
        # VE is column 0 of both: the registry's VE and the streamed one of the paper's four
        np.testing.assert_allclose(ours.array("quality_raw")[:, :, 0],
                                   four.array("quality_raw")[:, :, 0], rtol=1e-5)
        np.testing.assert_allclose(ours.array("quality")[:, :, 0],
                                   four.array("quality")[:, :, 0], atol=1e-5)
        # the coverage view set reads the same pixel counts whatever the measures
        assert ([r["view_set"] for r in ours.models()]
                == [r["view_set"] for r in four.models()])


def test_info_and_the_loader_report_the_recorded_names(three: Path) -> None:
    from vptoolkit.data import open_dataset

    text = CliRunner().invoke(main, ["info", str(three)])
    assert text.exit_code == 0, text.output
    assert ("measures: VE (higher is better), NVT (higher is better), SL (higher is better)"
            in text.output)
    assert text.output.count("\nSL ") == 1  # one best-value row per measure
    report = json.loads(CliRunner().invoke(main, ["info", str(three), "--json"]).output)
    assert report["measures"]["order"] == list(THREE)
    assert report["measures"]["names"] == {"VE": "viewpoint entropy",
                                           "NVT": "number of visible triangles",
                                           "SL": "silhouette length"}
    assert list(report["statistics"]["best_value"]) == list(THREE)
    with open_dataset(three) as dataset:
        assert dataset.measures == THREE
        assert dataset.higher_is_better == (True, True, True)
        item = dataset[0]
        assert item["quality"].shape == (80, 3) and item["best_index"].shape == (3,)
        assert dataset.array("worst_value").shape == (2, 3)
        assert dataset.quality_of(0, [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]).shape == (2, 3)


@pytest.mark.parametrize(("value", "message"), [
    ("VE,XYZ", "--measures: unknown measure 'XYZ'; known: NVT, PA"),
    ("SL,VE,SL", "--measures: SL named twice"),
    (",", "--measures: no measure named"),
])
def test_bad_measures_are_one_line_and_exit_2(src: Path, tmp_path: Path, value: str,
                                              message: str) -> None:
    result = CliRunner().invoke(main, ["build-dataset", str(src), str(tmp_path / "out"),
                                       "--measures", value])
    assert result.exit_code == 2
    assert result.stderr.startswith(f"vptool: error: {message}")
    assert result.stderr.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_resuming_with_other_measures_is_refused(src: Path, tmp_path: Path) -> None:
    out = _build(src, tmp_path / "out", "--measures", "SL,VE")
    again = CliRunner().invoke(main, ["build-dataset", str(src), str(out), *DRAW])
    assert again.exit_code == 2
    assert "measures=['SL', 'VE'] (now ['VE', 'VR', 'VKL', 'VMI'])" in again.stderr
    assert again.stderr.count("\n") == 1
    with open_store(out / "dataset.zarr") as store:
        assert store.measures == ("SL", "VE")


def test_the_options_record_the_measures_and_default_to_the_paper_four() -> None:
    default = BuildOptions()
    assert default.measures == PAPER_MEASURES == BuildOptions(measures="paper").measures
    assert default.store_attrs()["measures"] == list(PAPER_MEASURES)
    chosen = BuildOptions(measures="VE, NVT ,SL")
    assert chosen.measures == THREE and chosen.to_dict()["measures"] == list(THREE)
    assert BuildOptions.from_dict(chosen.to_dict()) == chosen
    assert BuildOptions(measures="all").measures[:3] == ("NVT", "PA", "HM")
    earlier = default.to_dict()
    del earlier["measures"]  # a staging record written before builds chose measures
    assert BuildOptions.from_dict(earlier) == default


def test_help_shows_the_option_and_an_example() -> None:
    result = CliRunner().invoke(main, ["build-dataset", "--help"])
    assert "--measures" in result.output and "--measures VE,NVT,SL" in result.output
