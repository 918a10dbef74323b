"""A collection run: the same table bytes whatever the workers or a resume; failures, limits."""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fixtures.environment import DASK_DASHBOARD, require_package
from fixtures.paths import MALFORMED
from vptoolkit.best_view.search import SearchSettings
from vptoolkit.collection.methods import Answer, SearchMethod
from vptoolkit.collection.runner import MAX_MODEL_FACES, run_collection
from vptoolkit.collection.table import ROWS_PER_GROUP, write_table_predictions
from vptoolkit.errors import InputError
from vptoolkit.mesh import Mesh
from vptoolkit.point_cloud import PointCloud
from vptoolkit.predictions import read_predictions
from vptoolkit.samples import sample_path

METHOD = SearchMethod(SearchSettings(budget=12, resolution=32))


@pytest.fixture()
def collection(tmp_path: Path) -> Path:
    root = tmp_path / "coll"
    (root / "a").mkdir(parents=True)
    (root / "b").mkdir()
    shutil.copy(sample_path("teapot.stl"), root / "a" / "teapot.stl")
    shutil.copy(sample_path("torus.STL"), root / "b" / "teapot.stl")  # the same stem
    shutil.copy(sample_path("ballA.off"), root / "ballA.off")
    shutil.copy(MALFORMED / "empty.obj", root / "empty.obj")
    (root / "cloud.xyz").write_text("0 0 0\n1 0 0\n0 1 0\n")
    return root


def _rows(table: Path) -> list[dict[str, Any]]:
    import pyarrow.parquet as pq

    return pq.read_table(table).to_pylist()


def test_every_entry_gets_a_row_with_its_answer_or_reason(collection: Path, tmp_path: Path):
    run = run_collection(collection, tmp_path / "out", METHOD)
    rows = {row["key"]: row for row in _rows(run.table)}
    assert list(rows) == ["a/teapot.stl", "b/teapot.stl", "ballA.off", "cloud.xyz", "empty.obj"]
    assert rows["a/teapot.stl"]["VE_direction"] != rows["b/teapot.stl"]["VE_direction"]
    teapot = rows["a/teapot.stl"]
    assert teapot["status"] == "ok" and teapot["views"] == 12 and teapot["reason"] == ""
    assert np.isclose(np.linalg.norm(teapot["VE_direction"]), 1.0)
    pose = np.asarray(teapot["VE_pose"]).reshape(4, 4)
    assert np.allclose(pose[3], [0, 0, 0, 1]) and np.allclose(pose[:3, :3].T @ pose[:3, :3],
                                                              np.eye(3))
    intrinsics = np.asarray(teapot["intrinsics"]).reshape(3, 3)
    assert intrinsics[0, 2] == intrinsics[1, 2] == 16.0  # the centre of a 32 px image
    assert teapot["sha256"] == __import__("hashlib").sha256(
        (collection / "a" / "teapot.stl").read_bytes()).hexdigest()
    assert rows["cloud.xyz"]["status"] == "failed"
    # a cloud is searched like a mesh, and three points are too few for their spacing
    assert rows["cloud.xyz"]["reason"].startswith("cloud: points: 3 points, need more than k = 8")
    assert rows["empty.obj"]["reason"].startswith("empty.obj: ")
    assert rows["empty.obj"]["VE_direction"] is None
    assert run.failures == (("cloud.xyz", rows["cloud.xyz"]["reason"]),
                            ("empty.obj", rows["empty.obj"]["reason"]))
    assert (run.n_entries, run.n_done, run.n_resumed) == (5, 3, 0)
    timings = [json.loads(line) for line in (run.folder / "timings.jsonl").read_text().splitlines()]
    assert sorted(line["key"] for line in timings) == sorted(rows)
    for line in timings:  # the stages add up to the entry's seconds
        assert set(line) == {"key", "seconds", "read", "answer", "draw", "finish", "stage"}
        assert min(line["read"], line["answer"], line["finish"], line["stage"]) >= 0
        assert line["draw"] == 0  # nothing drawn in the workers
        assert line["seconds"] == pytest.approx(
            line["read"] + line["answer"] + line["finish"] + line["stage"], abs=1e-3)
    assert next(line for line in timings if line["key"] == "ballA.off")["read"] > 0
    npz = write_table_predictions(run.table, tmp_path / "predictions.npz")
    assert npz is not None
    assert read_predictions(npz).names == ("a/teapot.stl", "b/teapot.stl", "ballA.off")


def test_the_table_has_the_same_bytes_with_one_and_two_workers(collection: Path, tmp_path: Path):
    one = run_collection(collection, tmp_path / "one", METHOD, workers=1)
    two = run_collection(collection, tmp_path / "two", METHOD, workers=2)
    assert one.folder.name == two.folder.name
    assert one.table.read_bytes() == two.table.read_bytes()


def test_a_rerun_after_losing_entries_does_only_those_and_gives_the_same_bytes(
        collection: Path, tmp_path: Path):
    whole = run_collection(collection, tmp_path / "whole", METHOD).table.read_bytes()
    first = run_collection(collection, tmp_path / "out", METHOD)
    staged = sorted((first.folder / "staging").rglob("*.json"))
    assert len(staged) == 5  # answers and lasting failures are staged
    for path in staged[:2]:  # as a kill -9 leaves it: some entries never written
        path.unlink()
    first.table.unlink()
    again = run_collection(collection, tmp_path / "out", METHOD)
    assert again.n_resumed == 3 and again.table.read_bytes() == whole
    unchanged = run_collection(collection, tmp_path / "out", METHOD)
    assert unchanged.n_resumed == 5 and unchanged.table.read_bytes() == whole


def test_changed_settings_or_content_are_answered_again(collection: Path, tmp_path: Path):
    first = run_collection(collection, tmp_path / "out", METHOD)
    other = run_collection(collection, tmp_path / "out",
                           SearchMethod(SearchSettings(budget=8, resolution=32)))
    assert other.folder != first.folder and other.n_resumed == 0
    settings = json.loads((other.folder / "settings.json").read_text())
    assert settings["method"]["settings"]["budget"] == 8
    shutil.copy(sample_path("bunny.ply"), collection / "ballA.off.ply")
    shutil.copy(sample_path("table.obj"), collection / "a" / "teapot.stl.obj")
    (collection / "ballA.off").write_bytes(sample_path("ballA.off").read_bytes() + b"\n")
    again = run_collection(collection, tmp_path / "out", METHOD)
    assert again.n_entries == 7 and again.n_resumed == 4  # ballA.off changed, two new files


def test_a_model_over_the_face_limit_is_refused(collection: Path, tmp_path: Path):
    run = run_collection(collection, tmp_path / "out", METHOD, max_faces=100)
    reasons = dict(run.failures)
    assert "more than the limit of 100 (--max-faces)" in reasons["a/teapot.stl"]


@dataclass(frozen=True)
class _Sleeping:
    """A method that takes longer than any limit (in this process)."""

    names: tuple[str, ...] = ("VE",)
    in_process: bool = True

    def record(self) -> dict[str, Any]:
        return {"method": "sleeping"}

    def __call__(self, mesh: Mesh) -> Answer:
        try:
            time.sleep(600)  # far beyond the limit: only the timer ends it
        except Exception:  # a library's broad handler lets the timer through
            pass
        raise AssertionError("the time limit should have stopped it")


def test_an_entry_over_the_time_limit_fails_and_is_tried_again(collection: Path,
                                                                tmp_path: Path):
    (collection / "b" / "teapot.stl").unlink()
    for name in ("a/teapot.stl", "cloud.xyz", "empty.obj"):
        (collection / name).unlink()
    # a generous limit: reading the file ends well within it, however busy the machine
    run = run_collection(collection, tmp_path / "out", _Sleeping(), timeout=5)
    assert run.failures == (("ballA.off", "ballA.off: took longer than 5 s (--timeout)"),)
    assert not list((run.folder / "staging").rglob("*.json"))  # not staged: tried again


def test_bad_options_are_refused(collection: Path, tmp_path: Path):
    with pytest.raises(InputError, match="workers: give either"):
        run_collection(collection, tmp_path / "out", METHOD, workers=2,
                       scheduler="tcp://127.0.0.1:8786")
    with pytest.raises(InputError, match="timeout"):
        run_collection(collection, tmp_path / "out", METHOD, timeout=0)
    with pytest.raises(InputError, match="workers: this method runs in this process"):
        run_collection(collection, tmp_path / "out", _Sleeping(), workers=2)


@pytest.mark.slow
@pytest.mark.usefixtures("taken_dashboard_port")
def test_a_dask_cluster_gives_the_same_bytes(collection: Path, tmp_path: Path):
    require_package("distributed")
    from distributed import LocalCluster

    local = run_collection(collection, tmp_path / "local", METHOD)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=DASK_DASHBOARD) as cluster:
        remote = run_collection(collection, tmp_path / "dask", METHOD,
                                scheduler=cluster.scheduler_address)
    assert remote.table.read_bytes() == local.table.read_bytes()


def test_max_points_names_another_folder_and_the_default_keeps_its_name():
    from vptoolkit.collection.runner import settings_digest
    from vptoolkit.point_cloud import MAX_POINTS

    default, record = settings_digest(METHOD, MAX_MODEL_FACES)
    assert "max_points" not in record
    assert settings_digest(METHOD, MAX_MODEL_FACES, MAX_POINTS)[0] == default
    thinned, record = settings_digest(METHOD, MAX_MODEL_FACES, 5000)
    assert thinned != default and record["max_points"] == 5000


def test_two_runs_never_write_one_folder_at_once(collection: Path, tmp_path: Path):
    from vptoolkit.collection.runner import settings_digest
    from vptoolkit.files import exclusive_lock

    folder = tmp_path / "out" / settings_digest(METHOD, MAX_MODEL_FACES)[0]
    folder.mkdir(parents=True)
    with exclusive_lock(folder / ".lock", "held"), \
            pytest.raises(InputError, match="another run is writing this folder"):
        run_collection(collection, tmp_path / "out", METHOD)


@pytest.mark.slow
def test_a_run_killed_with_sigkill_resumes_to_the_same_bytes(collection: Path, tmp_path: Path):
    for number in range(6):
        shutil.copy(sample_path("bunny.ply"), collection / f"bunny_{number}.ply")
    arguments = ["best-view", str(collection), "-o", str(tmp_path / "out"), "--views", "12",
                 "--resolution", "32"]
    script = "import sys; from vptoolkit.cli import main; sys.argv[0] = 'vptool'; main()"
    process = subprocess.Popen([sys.executable, "-c", script, *arguments],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    staged: list[Path] = []
    while process.poll() is None and len(staged) < 2:
        time.sleep(0.05)
        staged = list((tmp_path / "out").glob("*/staging/*/*.json"))
    process.send_signal(signal.SIGKILL)
    process.wait()
    resumed = run_collection(collection, tmp_path / "out", METHOD)
    assert resumed.n_resumed >= 2
    whole = run_collection(collection, tmp_path / "whole", METHOD)
    assert resumed.table.read_bytes() == whole.table.read_bytes()


def test_a_list_naming_a_file_twice_gives_two_rows_and_one_prediction(collection: Path,
                                                                       tmp_path: Path):
    listing = tmp_path / "models.txt"
    listing.write_text(f"{collection}/ballA.off\n{collection}/ballA.off\n")
    run = run_collection(f"@{listing}", tmp_path / "out", METHOD)
    assert [row["status"] for row in _rows(run.table)] == ["ok", "ok"]
    npz = write_table_predictions(run.table, tmp_path / "predictions.npz")
    assert npz is not None and read_predictions(npz).names == (f"{collection}/ballA.off",)


@pytest.mark.slow
def test_a_run_over_thousands_of_listed_entries_keeps_memory_flat(tmp_path: Path):
    import tracemalloc

    model = tmp_path / "tetrahedron.off"
    model.write_text("OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
                     "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n")
    peaks = []
    # the first run loads what any run needs once; both others hold a full row group
    for n_lines in (100, ROWS_PER_GROUP + 100, 4 * ROWS_PER_GROUP):
        listing = tmp_path / f"models_{n_lines}.txt"
        listing.write_text("tetrahedron.off\n" * n_lines)
        tracemalloc.start()
        try:
            run = run_collection(f"@{listing}", tmp_path / f"out_{len(peaks)}", METHOD)
            peaks.append(tracemalloc.get_traced_memory()[1])
        finally:
            tracemalloc.stop()
        assert run.n_entries == n_lines and not run.failures
    assert peaks[2] - peaks[1] < 1_000_000  # bytes: 3000 more entries cost nothing held


def test_a_point_cloud_is_searched_and_read_for_a_picture(tmp_path: Path):
    from vptoolkit.collection.runner import read_model
    from vptoolkit.io import load_mesh
    from vptoolkit.points import sample_surface

    sample = sample_surface(load_mesh(sample_path("torus.STL")), 3000, seed=0)
    root = tmp_path / "clouds"
    root.mkdir()
    np.save(root / "torus.npy", np.concatenate([sample.points, sample.normals], axis=1))
    run = run_collection(root, tmp_path / "out", METHOD)
    (row,) = _rows(run.table)
    assert row["status"] == "ok" and row["VE_direction"] is not None
    assert not run.failures
    cloud = read_model(str(root / "torus.npy"))  # what a run that draws hands its drawer
    assert isinstance(cloud, PointCloud) and cloud.n_points == 3000
