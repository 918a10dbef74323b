"""--up (an axis or auto) and --elevation of render, best-view and thumbnails."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np

from fixtures.paths import ASSETS
from fixtures.pictures import decode_png
from vptoolkit.cli import main
from vptoolkit.samples import sample_path
from vptoolkit.sphere import elevation_deg

GAZEBO = ASSETS / "gazebo"


def test_best_view_keeps_every_answer_in_the_band(runner):
    result = runner.invoke(main, ["best-view", str(GAZEBO / "stop_sign.ply"), "--up", "0,0,1",
                                  "--elevation", "0,60", "--views", "24", "--resolution", "32",
                                  "--json"])
    assert result.exit_code == 0, result.output
    best = json.loads(result.stdout)["results"][0]["best"]
    directions = np.array([entry["direction"] for entry in best.values()])
    angles = elevation_deg(directions / np.linalg.norm(directions, axis=1, keepdims=True),
                           (0, 0, 1))
    assert (angles >= -1e-3).all() and (angles <= 60 + 1e-3).all()
    # the printed OpenCV poses put +z, the model's up, at the top: their y column points down
    poses = np.array([entry["pose"] for entry in best.values()])
    assert poses.shape == (4, 4, 4) and (poses[:, 2, 1] < 0).all()


def test_render_up_auto_stands_a_z_up_model_as_its_axis_does(runner, tmp_path):
    pictures = []
    for up in ("auto", "0,0,1"):
        output = tmp_path / f"{up.replace(',', '_')}.png"
        result = runner.invoke(main, ["render", str(GAZEBO / "bus.ply"), "--view", "1,-1,0.5",
                                      "--up", up, "--size", "64", "-o", str(output)])
        assert result.exit_code == 0, result.output
        pictures.append(decode_png(output.read_bytes()))
    np.testing.assert_array_equal(pictures[0], pictures[1])


def test_thumbnails_up_auto_draws_each_model_upright(runner, tmp_path):
    """A mixed folder: the z-up bus drawn as with --up 0,0,1, the y-up bunny as with 0,1,0."""
    folder = tmp_path / "mixed"
    folder.mkdir()
    shutil.copy(GAZEBO / "bus.ply", folder / "bus.ply")
    shutil.copy(sample_path("bunny.ply"), folder / "bunny.ply")
    common = ["--views", "16", "--resolution", "32", "--size", "48"]

    def draw(out: Path, *arguments: str) -> None:
        result = runner.invoke(main, ["thumbnails", str(folder), str(out), *common, *arguments])
        assert result.exit_code == 0, result.output

    draw(tmp_path / "auto", "--up", "auto")
    draw(tmp_path / "z", "--up", "0,0,1")
    draw(tmp_path / "y", "--up", "0,1,0")
    for name, axis in (("bus.ply.png", "z"), ("bunny.ply.png", "y")):
        auto = decode_png((tmp_path / "auto" / name).read_bytes()).astype(int)
        fixed = decode_png((tmp_path / axis / name).read_bytes()).astype(int)
        assert (np.abs(auto - fixed).max(axis=2) <= 2).mean() > 0.99  # the same picture


def test_bad_bands_and_auto_without_a_search_are_one_line(runner, tmp_path):
    mesh = str(GAZEBO / "stop_sign.ply")
    result = runner.invoke(main, ["best-view", mesh, "--elevation", "60,0"])
    assert result.exit_code == 2 and "elevation: expected (low, high)" in result.stderr
    result = runner.invoke(main, ["best-view", mesh, "--elevation", "up"])
    assert result.exit_code == 2 and "--elevation: expected two numbers" in result.stderr
    result = runner.invoke(main, ["thumbnails", str(GAZEBO), str(tmp_path / "t"), "--up", "auto",
                                  "--view-set", "2"])
    assert result.exit_code == 2 and "--up: auto needs the search" in result.stderr
