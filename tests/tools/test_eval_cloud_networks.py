"""tools/eval_cloud_networks.py: both bundled networks scored on a point benchmark folder's
uniform clouds and scans, paired, and written into their section of a results file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from fixtures.environment import require_package
from fixtures.scripts import RunTool

require_package("torch")
require_package("scipy")


def _bench_folder(root: Path, build: Path) -> Path:
    """A point benchmark folder over a build: each model's stored points turned a quarter turn
    about z, as its uniform cloud and, thinned to every other point, as its scan."""
    from vptoolkit.data import open_dataset

    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    (root / "clouds").mkdir(parents=True)
    with open_dataset(build) as dataset:
        names = list(dataset.names)
        for row, name in enumerate(names):
            points = np.asarray(dataset[row]["points"], np.float64) @ turn.T
            normals = np.asarray(dataset[row]["normals"], np.float64) @ turn.T
            for kind, step in (("uniform", 1), ("scan", 2)):
                np.savez(root / "clouds" / f"{name}_r0_{kind}.npz", points=points[::step],
                         normals=normals[::step], rotation=turn)
    (root / "manifest.json").write_text(json.dumps(
        {"labels": str(build), "rotations": 1, "models": names}))
    return root


def test_the_networks_are_scored_on_both_kinds_paired_and_written(
        tmp_path: Path, run_tool: RunTool, features_dataset: Path) -> None:
    import dataclasses

    from fixtures.networks import TINY_CONFIG
    from vptoolkit.learn.model import ViewpointNet, save_model
    from vptoolkit.point_features import CLOUD_FEATURES

    folder = _bench_folder(tmp_path / "bench", features_dataset)
    checkpoint = tmp_path / "cloud_net"
    save_model(ViewpointNet(dataclasses.replace(TINY_CONFIG, point_features=CLOUD_FEATURES),
                            seed=0), checkpoint, metadata={"input": {"n_points": 512,
                                                                     "n_fps": 128}})
    results = tmp_path / "results.md"
    result = run_tool("eval_cloud_networks.py", str(folder), "--results", str(results),
                      "--model", str(checkpoint), "--versus", "cloud_net",
                      "--json", str(tmp_path / "scores.json"), timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    scores = json.loads((tmp_path / "scores.json").read_text())
    assert set(scores) == {f"{kind} / {network}" for kind in ("uniform", "scan")
                           for network in ("points: coordinates alone",
                                           "default: spacing area as face area", "cloud_net")}
    for entry in scores.values():
        values = np.array(entry["scores"])
        assert values.shape == (2, 4) and len(entry["names"]) == 2
        assert ((values >= 0.0) & (values <= 100.0)).all()
    text = results.read_text()
    assert "<!-- cloud_networks:start -->" in text and "### scan clouds" in text
    assert "| network minus points: coordinates alone |" in text
    assert "| network minus cloud_net |" in text


def test_an_unknown_versus_row_is_one_line(tmp_path: Path, run_tool: RunTool,
                                           features_dataset: Path) -> None:
    folder = _bench_folder(tmp_path / "bench", features_dataset)
    result = run_tool("eval_cloud_networks.py", str(folder), "--versus", "nothing")
    assert result.returncode == 2
    assert result.stderr.strip().endswith("--versus: nothing is not a row; rows: "
                                          "points: coordinates alone, default: spacing area "
                                          "as face area")
