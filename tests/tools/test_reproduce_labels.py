"""tools/reproduce_labels.py on a built dataset (``--dataset``): train, select and score on
its validation split, beside the plain searches and the per-category networks."""

from __future__ import annotations

import importlib
import json
from dataclasses import replace
from pathlib import Path
from types import ModuleType

import pytest

from fixtures.environment import require_package


@pytest.fixture(scope="module")
def tool() -> ModuleType:
    """``tools/reproduce_labels.py`` (tools/ is on the tests' path, see pyproject.toml)."""
    for module in ("torch", "safetensors", "zarr"):
        require_package(module)
    return importlib.import_module("reproduce_labels")


def test_searches_are_parsed(tool: ModuleType) -> None:
    assert tool.parse_searches("16@32, 64@64") == [(16, 32), (64, 64)]
    assert tool.parse_searches("") == []
    with pytest.raises(SystemExit, match="expected N@R"):
        tool.parse_searches("16x32")


@pytest.mark.slow
def test_a_built_dataset_is_trained_and_scored_on_its_validation_split(
        tool: ModuleType, tmp_path: Path) -> None:
    from vptoolkit.conventions import model_name
    from vptoolkit.dataset.builder.options import BuildOptions, SplitFile
    from vptoolkit.dataset.builder.run import build_dataset
    from vptoolkit.dataset.builder.split_files import class_split, write_split_file
    from vptoolkit.settings import MeasureSettings
    from vptoolkit.synthetic import write_collection

    shapes = tmp_path / "shapes"
    write_collection(shapes, n_per_category=3, categories=("bottle", "table"), seed=0,
                     layout="flat")
    split = class_split([(category, model_name(f"{category}/{category}_{i:04d}.off"))
                         for category in ("bottle", "table") for i in range(1, 4)])
    write_split_file(tmp_path / "splits.csv", split)
    options = BuildOptions(MeasureSettings(views=40, resolution=32), n_points=600, clean=False,
                           splits=SplitFile.read(tmp_path / "splits.csv"))
    built = build_dataset(shapes, tmp_path / "build", options).path
    sizes = replace(tool.QUICK, epochs=1, n_views=40, resolution=32, n_points=600)
    table = tool.run(tmp_path / "out", sizes, methods=("sr",), category_methods=("sr",),
                     searches=[(4, 16)], dataset=built, jobs=1,
                     command="python tools/reproduce_labels.py --dataset build")
    assert "## Table 2 on real meshes: `shapes`" in table
    assert "(train 4, validation 2)" in table
    for row in ("| SR |", "| SR, one network per category |", "| plain search 4 @ 16 |",
                "| PCA axis |", "| random view (expectation) |"):
        assert row in table, row
    numbers = json.loads((tmp_path / "out" / "table2.json").read_text())
    assert numbers["sizes"] == {"train": 4, "validation": 2, "test": 0}
    assert len(numbers["rotated"]["SR"]["per_model"]) == 2  # the validation models
    # the networks read each point's face area, and their folders say so
    assert "512 input points with face_area" in table
    record = json.loads((tmp_path / "out" / "models" / "sr_face_area" / "model.json").read_text())
    assert record["architecture"]["point_features"] == ["face_area"]
