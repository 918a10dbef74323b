"""The authors' tree has folders for the paper's four measures only: a store holding them
among others exports those four; one lacking any is refused in one line."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from vptoolkit.cli import main
from vptoolkit.dataset.authors.export import export_authors
from vptoolkit.dataset.authors.importer import import_authors
from vptoolkit.dataset.build.options import BuildOptions
from vptoolkit.dataset.store.reader import open_store
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings

FIVE = ("SL", "VMI", "VE", "VKL", "VR")
"""The paper's four among another measure, in an order of the store's own."""


def _build(root: Path, measures: str, views: int) -> Path:
    from vptoolkit.dataset.build.run import build_dataset

    src = root / "src"
    for category, sample in (("bottle", "bottle.obj"), ("mug", "mug.obj")):
        (src / category).mkdir(parents=True)
        shutil.copy(sample_path(sample), src / category / sample)
    options = BuildOptions(MeasureSettings(views=views, resolution=32), measures=measures,
                           n_points=64, clean=False)
    result = build_dataset(src, root / "out", options)
    assert result.n_failures == 0
    return result.path


@pytest.fixture(scope="module")
def five(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two samples measured with :data:`FIVE` over the authors' 1000 views."""
    return _build(tmp_path_factory.mktemp("five"), ",".join(FIVE), 1000)


def test_the_paper_four_are_exported_from_among_more(five: Path, tmp_path: Path) -> None:
    exported = export_authors(five, tmp_path / "set")
    assert exported.n_models == 2
    imported = import_authors(tmp_path / "set", tmp_path / "back")
    columns = [FIVE.index(measure) for measure in PAPER_MEASURES]
    with open_store(five) as ours, open_store(imported.path) as back:
        assert back.measures == PAPER_MEASURES
        ours_by_name = {r["name"]: row for row, r in enumerate(ours.models())}
        for row, record in enumerate(back.models()):
            mine = ours_by_name[record["name"]]
            np.testing.assert_array_equal(back.array("quality_raw")[row],
                                          ours.array("quality_raw")[mine][:, columns])
            np.testing.assert_array_equal(back.array("best_index")[row],
                                          ours.array("best_index")[mine][columns])


def test_the_measures_check_follows_the_stores_names(five: Path) -> None:
    from vptoolkit.dataset.authors.check import check_measures

    check = check_measures(five, 1, resolution=32)
    assert check.measures == FIVE and list(check.summary()) == list(FIVE)
    # our own pipeline at the same settings: the same order of views, up to the float32
    # rounding of the stored quality among near ties
    for measure, row in check.summary().items():
        assert row["mean_correlation"] > 0.9999, measure
        assert row["median_angle_deg"] == pytest.approx(0.0, abs=1e-6), measure


def test_a_store_without_the_paper_four_is_refused_in_one_line(tmp_path: Path) -> None:
    store = _build(tmp_path, "VE,NVT,SL", 40)
    result = CliRunner().invoke(main, ["export-authors", str(store), str(tmp_path / "set")])
    assert result.exit_code == 2
    assert result.stderr == (
        f"vptool: error: {store}: the authors' tree holds VE, VR, VKL, VMI; this store "
        "records VE, NVT, SL, without VR, VKL, VMI\n")
    assert not (tmp_path / "set").exists()
