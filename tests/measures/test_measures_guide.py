"""docs/guide/measures.md, "All measures": its table lists exactly the registry's measures, with
their title, family, direction, source, cost and the value of a view that sees nothing."""

from __future__ import annotations

import numpy as np
import pytest

from fixtures.paths import REPO
from vptoolkit.measures.measure import Measure
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.measures.registry import all_measures
from vptoolkit.mesh import Mesh
from vptoolkit.settings import MeasureSettings

GUIDE = REPO / "docs" / "guide" / "measures.md"
COLUMNS = ["name", "title", "family", "formula", "better", "sees nothing", "source", "cost"]


def cost_class(measure: Measure) -> str:
    """The guide's cost class: the dearest of what the measure needs beyond pixel counts."""
    if "neighbours" in measure.needs:
        return "+ neighbours"
    if measure.needs & {"curvature", "saliency"}:
        return "+ per-mesh curvature or saliency"
    if measure.needs & {"depth", "silhouette"}:
        return "+ depth-silhouette pass"
    return "pixels only"


@pytest.fixture(scope="module")
def rows() -> dict[str, dict[str, str]]:
    """The table's rows by measure name, in the guide's order."""
    text = GUIDE.read_text(encoding="utf-8")
    section = text[text.index("\n## All measures\n"):]
    section = section[:section.index("\n## ", 1)]
    lines = [line for line in section.splitlines() if line.startswith("|")]
    header = [cell.strip() for cell in lines[0].strip("|").split("|")]
    assert header == COLUMNS
    table = {}
    for line in lines[2:]:
        cells = dict(zip(COLUMNS, (cell.strip() for cell in line.strip("|").split("|"))))
        assert len(cells) == len(COLUMNS) and cells["name"].startswith("`"), line
        table[cells["name"].strip("`")] = cells
    return table


def test_the_table_names_every_registered_measure_in_the_registry_order(rows) -> None:
    assert list(rows) == list(all_measures())


def test_each_row_says_what_the_registry_says(rows) -> None:
    for name, measure in all_measures().items():
        row = rows[name]
        assert (row["title"], row["family"], row["source"]) == (
            measure.title, measure.family, measure.source), name
        assert row["better"] == ("higher" if measure.higher_is_better else "lower"), name
        assert row["cost"] == cost_class(measure), name


def test_the_value_of_a_view_that_sees_nothing_is_the_computed_one(rows) -> None:
    square = Mesh(np.array([[-1.0, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]),
                  np.array([[0, 1, 2], [0, 2, 3]]), "square")
    quality = compute_view_quality(square, MeasureSettings(resolution=48),
                                   view_directions=[[0.1, 0.2, 1.0], [0, 0, 1], [1, 0, 0]],
                                   measures="all")
    edge_on = quality.raw[2]
    for name, value in zip(quality.measures, edge_on):
        assert rows[name]["sees nothing"] == ("NaN" if np.isnan(value) else f"{value:g}"), name


def test_the_point_cloud_table_says_which_measures_are_defined_on_points() -> None:
    text = GUIDE.read_text(encoding="utf-8")
    section = text[text.index("\n## On point clouds\n"):]
    section = section[:section.index("\n## ", 1)]
    lines = [line for line in section.splitlines() if line.startswith("| `")]
    table = {cells[0].strip("`"): cells[1] for cells in
             ([cell.strip() for cell in line.strip("|").split("|")] for line in lines)}
    assert list(table) == list(all_measures())
    assert table == {name: "yes" if measure.on_points else "no"
                     for name, measure in all_measures().items()}
