"""tools/score_held_out.py: its arguments are checked first, each in one line, and a
per-category folder scores each mesh with its category's network."""

from __future__ import annotations

import importlib
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from fixtures.environment import require_package


@pytest.fixture()
def tool(monkeypatch) -> ModuleType:
    """The script, with its build replaced by one that must not run before the checks."""
    for module in ("torch", "safetensors", "zarr"):
        require_package(module)
    module = importlib.import_module("score_held_out")

    def no_build(*args, **kwargs):
        raise AssertionError("built before the arguments were checked")

    monkeypatch.setattr(module, "build_dataset", no_build)
    return module


@pytest.mark.parametrize("case", ["missing-folder", "rotations-0", "views-0", "out-is-a-file",
                                  "out-holds-no-build", "json-in-a-missing-folder",
                                  "not-an-integer", "inputs-0", "inputs-text", "inputs-twice"])
def test_bad_arguments_are_one_line_with_exit_2(tool: ModuleType, tmp_path: Path, capsys,
                                                case: str) -> None:
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    (tmp_path / "file").write_text("x")
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    argv = {
        "missing-folder": [str(tmp_path / "nowhere")],
        "rotations-0": [str(meshes), "--rotations", "0"],
        "views-0": [str(meshes), "--views", "0"],
        "out-is-a-file": [str(meshes), "--out", str(tmp_path / "file")],
        "out-holds-no-build": [str(meshes), "--out", str(tmp_path / "other")],
        "json-in-a-missing-folder": [str(meshes), "--json", str(tmp_path / "no" / "s.json")],
        "not-an-integer": [str(meshes), "--views", "many"],
        "inputs-0": [str(meshes), "--inputs", "0,8"],
        "inputs-text": [str(meshes), "--inputs", "eight"],
        "inputs-twice": [str(meshes), "--inputs", "8,8"],
    }[case]
    with pytest.raises(SystemExit) as caught:
        tool.main(argv)
    assert caught.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("score_held_out.py: error: "), err
    assert "Traceback" not in err


def test_a_per_category_folder_is_routed_by_category(tool: ModuleType, small_build: Path,
                                                     monkeypatch) -> None:
    from vptoolkit.data import open_dataset

    with open_dataset(small_build) as dataset:
        expected = dict(zip(dataset.names, dataset.categories))
    seen = {}

    def network_predictor(model, *, categories=None, n_inputs=None, dataset=None):
        assert dataset is not None  # the features of a network that reads them come from it
        seen.update(categories or {})

        def predictor(points, names):
            assert all(name in seen for name in names)  # every mesh has its category
            return np.tile([0.0, 0.0, 1.0], (len(names), 4, 1))

        return predictor

    monkeypatch.setattr(tool, "network_predictor", network_predictor)
    rows = tool.score(small_build, "per-category", rotations=1)
    assert seen == expected and len(rows["network"].names) == len(expected)


def test_consistency_compares_a_mesh_with_its_resampled_rotated_copy(tool: ModuleType,
                                                                     tiny_dataset: Path) -> None:
    """Angles per mesh and measure for each count of inputs, and a table that reports them; the
    network's answers are unit directions, so every angle lies in [0, 180]."""
    angles = tool.consistency(tiny_dataset, "default", [1, 16])
    assert set(angles) == {1, 16}
    for found in angles.values():
        assert found.angles.shape == found.gaps.shape == (4, 4)
        assert np.all((found.angles >= 0.0) & (found.angles <= 180.0))
        assert np.all((found.gaps >= 0.0) & (found.gaps <= 100.0))
        assert np.all(found.gaps[found.angles < 1e-6] == 0.0)  # one answer, one score
    rows = tool.score(tiny_dataset, "default", rotations=1, inputs=[1, 16], others=["points"],
                      searches=[(4, 16)])
    assert list(rows)[:3] == ["network, 1 input", "network, 16 inputs", "network points, 16 inputs"]
    assert "plain search 4 @ 16" in rows
    text = tool.table(rows, "network, 16 inputs", angles)
    assert "| network, 16 inputs minus |" in text and "Rotation consistency" in text
    assert "| network points, 16 inputs |" in text and "| plain search 4 @ 16 |" in text
    assert text.count("\n| 1 |") == 1 and text.count("\n| 16 |") == 1
