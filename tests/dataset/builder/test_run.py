"""The resumable dataset build: one full build, resume, failures, workers and Dask.

Every build here runs the real pipeline (load, clean, sample, measure) on the
bundled sample meshes at tiny sizes: 60 views at 64 px, 300 points, at most
2000 faces.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fixtures.builds import make_tree
from fixtures.environment import DASK_DASHBOARD, require_package
from fixtures.paths import MALFORMED
from vptoolkit import parallel
from vptoolkit.dataset.builder import compute
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.dataset.builder.run import BuildResult, build_dataset
from vptoolkit.dataset.builder.sources import assign_split, model_name
from vptoolkit.dataset.builder.staging import STAGING_DIR
from vptoolkit.dataset.store.reader import open_store
from vptoolkit.dataset.store.schema import ARRAY_NAMES, STRING_ARRAYS, string_values
from vptoolkit.errors import InputError, MissingDependencyError
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere

SMALL = BuildOptions(MeasureSettings(views=60, resolution=64), n_points=300, max_faces=2000)

# category/train|test/file: the ModelNet-style tree every build test starts from.
TREE = {
    "cup/train/mug.obj": sample_path("mug"),
    "cup/train/bottle.obj": sample_path("bottle"),
    "cup/test/teapot.stl": sample_path("teapot"),
    "shape/train/angle_block.STL": sample_path("angle_block"),
    "shape/train/table.obj": sample_path("table"),
    "shape/test/suzanne.ply": sample_path("suzanne"),
    "shape/train/empty.obj": MALFORMED / "empty.obj",
    "shape/test/ply_empty_header.ply": MALFORMED / "ply_empty_header.ply",
}
GOOD = ["cup__test__teapot", "cup__train__bottle", "cup__train__mug", "shape__test__suzanne",
        "shape__train__angle_block", "shape__train__table"]  # (category, name) order
BAD = {"shape/test/ply_empty_header.ply", "shape/train/empty.obj"}


def read_store(path: Path) -> dict[str, Any]:
    """Everything in a store: attributes, every array, records and failures."""
    with open_store(path) as store:
        return {
            "attrs": dict(store.attrs),
            "arrays": {name: np.array(string_values(store.array(name)) if name in STRING_ARRAYS
                                      else store.array(name)[...]) for name in ARRAY_NAMES},
            "sha256": {name: store.stored_sha256(name) for name in ARRAY_NAMES},
            "models": store.models(),
            "failures": store.failures(),
        }


def assert_same_dataset(first: dict[str, Any], second: dict[str, Any], *,
                        same_created: bool = False) -> None:
    skip = set() if same_created else {"created"}
    attrs_a = {k: v for k, v in first["attrs"].items() if k not in skip}
    attrs_b = {k: v for k, v in second["attrs"].items() if k not in skip}
    assert attrs_a == attrs_b
    for name in ARRAY_NAMES:
        a, b = first["arrays"][name], second["arrays"][name]
        assert a.dtype == b.dtype and a.shape == b.shape, name
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), name
    assert first["sha256"] == second["sha256"]
    assert first["models"] == second["models"]
    assert first["failures"] == second["failures"]


@pytest.fixture(scope="module")
def src(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_tree(tmp_path_factory.mktemp("build") / "modelnet", TREE)


@pytest.fixture(scope="module")
def reference(src: Path,
              tmp_path_factory: pytest.TempPathFactory) -> tuple[BuildResult, dict[str, Any]]:
    """One uninterrupted single-process build with cleaning, the baseline of the comparisons."""
    require_package("pymeshlab")
    result = build_dataset(src, tmp_path_factory.mktemp("reference") / "out", SMALL)
    return result, read_store(result.path)


def test_build_stores_every_model_with_records_splits_and_failures(src, reference):
    result, stored = reference
    assert result.path == result.path.parent / "dataset.zarr" and result.path.is_dir()
    assert (result.n_models, result.n_failures, result.n_resumed) == (6, 2, 0)
    models = stored["models"]
    assert [m["name"] for m in models] == GOOD
    by_name = {m["name"]: m for m in models}
    for relative in TREE:
        name = model_name(relative)
        if relative in BAD:
            continue
        record = by_name[name]
        category, folder, _ = relative.split("/")
        assert record["category"] == category and record["source"] == relative
        assert record["source_sha256"] == hashlib.sha256((src / relative).read_bytes()).hexdigest()
        assert record["split"] == assign_split(category, name, seed=0, folder_split=folder)
        if folder == "test":
            assert record["split"] == "test"
        else:
            assert record["split"] in ("train", "val")
        cleaning = record["cleaning"]
        assert ([step["name"] for step in cleaning["steps"]]
                == ["repair", "remove_hidden", "simplify"])
        assert "seconds" not in cleaning and all("seconds" not in s for s in cleaning["steps"])
        assert cleaning["faces_after"] == record["n_faces"] <= 2000

    failures = stored["failures"]
    assert [f["source"] for f in failures] == sorted(BAD)
    assert failures == [dict(f) for f in result.failures]
    assert failures[1] == {"source": "shape/train/empty.obj", "category": "shape",
                           "reason": "empty.obj: no geometry (no vertices, no faces)"}
    assert failures[0]["reason"].startswith("ply_empty_header.ply: ")

    attrs = stored["attrs"]
    assert attrs["n_models"] == 6 and attrs["n_failures"] == 2
    assert (attrs["n_views"], attrs["n_points"], attrs["resolution"]) == (60, 300, 64)
    assert attrs["cleaning"] == {"enabled": True, "max_faces": 2000, "remesh": False}
    assert attrs["split_seed"] == 0 and attrs["source"] == "modelnet"
    assert attrs["split_fractions"] == {"train": 0.8, "val": 0.1, "test": 0.1}
    assert attrs["backend"] == "raster" and attrs["camera"]["fov_deg"] == 45.0
    import vptoolkit

    assert attrs["toolkit_version"] == vptoolkit.__version__
    staged = json.loads((result.path.parent / STAGING_DIR / "build.json").read_text())
    assert attrs["created"] == staged["created"]


def test_build_arrays_have_schema_shapes_and_agree_with_the_records(reference):
    _, stored = reference
    arrays = stored["arrays"]
    assert np.array_equal(arrays["views"], fibonacci_sphere(60))
    assert arrays["points"].shape == arrays["normals"].shape == (6, 300, 3)
    assert arrays["points"].dtype == np.float32
    assert np.allclose(np.linalg.norm(arrays["normals"], axis=2), 1.0, atol=1e-5)
    assert arrays["quality"].shape == arrays["quality_raw"].shape == (6, 60, 4)
    assert ((arrays["quality"] >= 0) & (arrays["quality"] <= 1)).all()
    rows = np.arange(6)[:, None]
    columns = np.arange(4)[None, :]
    assert np.array_equal(arrays["best_value"],
                          arrays["quality_raw"][rows, arrays["best_index"], columns])
    assert np.array_equal(arrays["worst_value"],
                          arrays["quality_raw"][rows, arrays["worst_index"], columns])
    assert (arrays["quality"][rows, arrays["best_index"], columns] == 1).all()
    n_vertices = [m["n_vertices"] for m in stored["models"]]
    n_faces = [m["n_faces"] for m in stored["models"]]
    assert np.array_equal(arrays["mesh_vertex_offsets"],
                          np.concatenate([[0], np.cumsum(n_vertices)]))
    assert np.array_equal(arrays["mesh_face_offsets"], np.concatenate([[0], np.cumsum(n_faces)]))


def test_build_measures_what_the_pipeline_measures(src, reference):
    """The stored quality of a model equals load -> clean -> measure done by hand."""
    from vptoolkit.clean import clean_mesh
    from vptoolkit.io import load_mesh
    from vptoolkit.measures.quality import compute_view_quality

    _, stored = reference
    row = GOOD.index("shape__train__table")
    cleaned, _ = clean_mesh(load_mesh(src / "shape/train/table.obj"), max_faces=2000)
    quality = compute_view_quality(cleaned, MeasureSettings(views=60, resolution=64))
    assert np.array_equal(stored["arrays"]["quality_raw"][row], quality.raw.astype(np.float32),
                          equal_nan=True)
    assert np.array_equal(stored["arrays"]["best_index"][row], quality.best_index)
    offsets = stored["arrays"]["mesh_vertex_offsets"]
    assert np.array_equal(stored["arrays"]["mesh_vertices"][offsets[row]:offsets[row + 1]],
                          cleaned.vertices.astype(np.float32))


@pytest.mark.slow
def test_killed_build_resumes_to_the_same_dataset(src, reference, tmp_path):
    out = tmp_path / "out"
    staging = out / STAGING_DIR
    code = (
        "import json\n"
        "from vptoolkit.dataset.builder.run import build_dataset\n"
        "from vptoolkit.dataset.builder.options import BuildOptions\n"
        f"options = BuildOptions.from_dict(json.loads({json.dumps(SMALL.to_dict())!r}))\n"
        f"build_dataset({str(src)!r}, {str(out)!r}, options)\n"
    )
    process = subprocess.Popen([sys.executable, "-c", code], stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 300
        while len(list(staging.glob("m-*.npz"))) < 2:
            assert process.poll() is None, process.stderr.read().decode() if process.stderr else ""
            assert time.monotonic() < deadline, "the build staged fewer than 2 models in 300 s"
            time.sleep(0.02)
    finally:
        if process.poll() is None:
            os.kill(process.pid, signal.SIGKILL)
        process.wait()
        if process.stderr:
            process.stderr.close()
    assert process.returncode == -signal.SIGKILL
    assert not (out / "dataset.zarr").exists()
    n_staged = len(list(staging.glob("m-*.npz"))) + len(list(staging.glob("m-*.failed.json")))
    assert 2 <= n_staged < 8
    created = json.loads((staging / "build.json").read_text())["created"]
    # what a kill in the middle of a write leaves behind is never read
    (staging / ".m-cup__mug-0000.npz.0123abcd.partial").write_bytes(b"PK\x03\x04 half a zip")

    result = build_dataset(src, out, SMALL)
    assert result.n_resumed == n_staged and (result.n_models, result.n_failures) == (6, 2)
    assert not list(staging.glob(".*.partial"))
    resumed = read_store(result.path)
    assert resumed["attrs"]["created"] == created
    assert_same_dataset(resumed, reference[1])


def test_resuming_with_other_options_is_refused(src, reference, tmp_path):
    out = reference[0].path.parent
    for option, options in [
        ("measure.views", replace(SMALL, measure=replace(SMALL.measure, views=30))),
        ("measure.resolution", replace(SMALL, measure=replace(SMALL.measure, resolution=32))),
        ("n_points", replace(SMALL, n_points=200)), ("max_faces", replace(SMALL, max_faces=1000)),
        ("clean", replace(SMALL, clean=False)), ("split_seed", replace(SMALL, split_seed=1)),
        ("format", replace(SMALL, format="hdf5")),
    ]:
        with pytest.raises(InputError,
                           match=rf"{option}=.*use a new OUT folder or the same options"):
            build_dataset(src, out, options)
    assert read_store(reference[0].path)["models"] == reference[1]["models"]


def test_rerun_reuses_staged_models_and_adding_a_model_moves_nothing(src, tmp_path):
    grown = tmp_path / "grown"
    shutil.copytree(src, grown)
    options = replace(SMALL, clean=False)
    first = build_dataset(src, tmp_path / "first", options)
    before = read_store(first.path)

    out = tmp_path / "incremental"
    build_dataset(grown, out, options)
    shutil.copyfile(sample_path("torus"), grown / "shape/train/torus.STL")
    shutil.copyfile(sample_path("lego"), grown / "cup/test/lego.obj")
    result = build_dataset(grown, out, options)
    assert result.n_models == 8 and result.n_resumed == 8  # 6 models and 2 failures reused
    after = read_store(result.path)
    old = {m["name"]: m for m in before["models"]}
    new = {m["name"]: m for m in after["models"]}
    assert set(new) == set(old) | {"shape__train__torus", "cup__test__lego"}
    for name, record in old.items():
        assert new[name]["split"] == record["split"]
        row_old = GOOD.index(name)
        row_new = [m["name"] for m in after["models"]].index(name)
        for array in ("points", "normals", "quality", "quality_raw", "best_index"):
            assert np.array_equal(before["arrays"][array][row_old], after["arrays"][array][row_new],
                                  equal_nan=True)

    # a changed source file is measured again, not taken from the staging folder,
    # and so is a staged file that cannot be read
    os.utime(grown / "cup/train/mug.obj", ns=(1, 1))
    (staging,) = (out / STAGING_DIR).glob("m-shape__shape__train__table-*.npz")
    staging.write_bytes(b"PK\x03\x04 not a zip")
    again = build_dataset(grown, out, options)
    assert again.n_resumed == 8
    assert_same_dataset(read_store(again.path), after, same_created=True)


def test_unexpected_error_is_a_failure_and_the_batch_goes_on(src, tmp_path, monkeypatch):
    measure = compute._measure_model

    def broken_on_mug(task):
        if task.name == "cup__train__mug":
            raise ZeroDivisionError("something\nnobody expected")
        return measure(task)

    monkeypatch.setattr(compute, "_measure_model", broken_on_mug)
    result = build_dataset(src, tmp_path / "out", replace(SMALL, clean=False))
    assert result.n_models == 5 and result.n_failures == 3
    reasons = {f["source"]: f["reason"] for f in result.failures}
    assert reasons["cup/train/mug.obj"] == (
        "cup/train/mug.obj: unexpected ZeroDivisionError: something nobody expected"
    )
    assert [m["name"] for m in read_store(result.path)["models"]] == [
        n for n in GOOD if n != "cup__train__mug"]


def test_a_missing_package_in_a_worker_is_retried_on_the_next_run(src, tmp_path, monkeypatch):
    measure = compute._measure_model

    def no_pymeshlab_for_teapot(task):
        if task.name == "cup__test__teapot":
            raise MissingDependencyError("pymeshlab: not importable; install it with pip")
        return measure(task)

    out = tmp_path / "out"
    options = replace(SMALL, clean=False)
    monkeypatch.setattr(compute, "_measure_model", no_pymeshlab_for_teapot)
    first = build_dataset(src, out, options)
    assert "cup/test/teapot.stl" in {f["source"] for f in first.failures}
    assert not list((out / STAGING_DIR).glob("*teapot*"))
    monkeypatch.setattr(compute, "_measure_model", measure)
    second = build_dataset(src, out, options)
    assert (second.n_models, second.n_failures, second.n_resumed) == (6, 2, 7)


def test_a_missing_package_stops_the_build_before_any_work(src, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pymeshlab", None)  # makes the import fail
    with pytest.raises(MissingDependencyError, match="vptoolkit\\[clean\\]"):
        build_dataset(src, tmp_path / "out", SMALL)
    assert not (tmp_path / "out").exists()
    build_dataset(src, tmp_path / "out", replace(SMALL, clean=False), categories=["cup"])


def test_files_that_give_one_name_are_failures_not_overwrites(tmp_path):
    root = make_tree(tmp_path / "src", {
        "cup/train/a.obj": sample_path("table"),
        "cup/train/a.off": sample_path("ballA"),
        "cup/b.obj": sample_path("bottle"),
        "cup__b.obj": sample_path("bottle"),
        "plate/train/b.ply": sample_path("suzanne"),
        "plate/train/c.stl": sample_path("teapot"),
    })
    result = build_dataset(root, tmp_path / "out", replace(SMALL, clean=False))
    assert result.n_models == 2 and result.n_failures == 4
    assert [m["name"] for m in read_store(result.path)["models"]] == [
        "plate__train__b", "plate__train__c"]
    reasons = {f["source"]: f["reason"] for f in result.failures}
    assert set(reasons) == {"cup/train/a.obj", "cup/train/a.off", "cup/b.obj", "cup__b.obj"}
    assert reasons["cup/train/a.off"] == (
        "cup/train/a.off: duplicate model name 'cup__train__a' (2 files: cup/train/a.obj, "
        "cup/train/a.off); names must be unique, rename all but one"
    )
    assert "2 files: cup/b.obj, cup__b.obj" in reasons["cup__b.obj"]


@pytest.fixture(scope="module")
def two_teapots(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The teapot twice, as ``a/teapot.stl`` and ``b/teapot.stl``, and the mug beside them."""
    return make_tree(tmp_path_factory.mktemp("teapots") / "src", {
        "a/teapot.stl": sample_path("teapot"),
        "b/teapot.stl": sample_path("teapot"),
        "b/mug.obj": sample_path("mug"),
    })


def test_equal_stems_in_two_folders_are_two_models(two_teapots, tmp_path):
    options = replace(SMALL, clean=False)
    first = build_dataset(two_teapots, tmp_path / "one", options)
    assert (first.n_models, first.n_failures) == (3, 0)
    stored = read_store(first.path)
    assert [(m["name"], m["category"], m["source"]) for m in stored["models"]] == [
        ("a__teapot", "a", "a/teapot.stl"), ("b__mug", "b", "b/mug.obj"),
        ("b__teapot", "b", "b/teapot.stl")]
    assert stored["attrs"]["class_names"] == ["a", "b"]
    # one file, two names: the same measures, its own seeded point sample
    assert np.array_equal(stored["arrays"]["quality_raw"][0], stored["arrays"]["quality_raw"][2],
                          equal_nan=True)
    assert not np.array_equal(stored["arrays"]["points"][0], stored["arrays"]["points"][2])

    again = build_dataset(two_teapots, tmp_path / "one", options)
    assert again.n_resumed == 3
    assert_same_dataset(read_store(again.path), stored, same_created=True)
    two = build_dataset(two_teapots, tmp_path / "two", options, workers=2)
    assert_same_dataset(read_store(two.path), stored)


def test_a_name_no_store_can_hold_is_a_failure_not_a_failed_build(tmp_path):
    """A file stem with a backslash or a control character is legal on Linux, not in a store."""
    root = make_tree(tmp_path / "src", {
        "cup/train/a\\b.obj": sample_path("table"),
        "cup/train/tab\tname.obj": sample_path("bottle"),
        "cup/train/c.stl": sample_path("teapot"),
    })
    result = build_dataset(root, tmp_path / "out", replace(SMALL, clean=False))
    assert result.n_models == 1 and result.n_failures == 2
    reasons = sorted(f["reason"] for f in result.failures)
    assert all("model name" in reason and "cannot name a file or folder" in reason
               for reason in reasons), reasons


def _die_on_bottle(task):
    """A task that kills its worker process for one model (a segfault in a native library)."""
    if task.name == "bottle":
        os._exit(11)
    return compute.MeasuredModel(task.model_id, task.signature, {"pid": os.getpid()}, {}, {})


def test_a_dying_worker_process_fails_only_its_model(tmp_path):
    options = BuildOptions(MeasureSettings(views=1, resolution=1), n_points=1, max_faces=4,
                           clean=False)
    tasks = [compute.ModelTask(f"/c/{name}.obj", f"c/{name}.obj", "c", name, options, 0, {})
             for name in ("apple", "bottle", "cherry", "date", "elder", "fig")]
    results = list(parallel.run_tasks(_die_on_bottle, tasks, workers=2,
                                      crashed=compute.worker_died))
    by_name = {r.model_id: r for r in results}
    assert len(results) == len(tasks)
    assert sorted(by_name) == [f"c/{t.name}" for t in tasks]
    bottle = by_name["c/bottle"]
    assert isinstance(bottle, compute.FailedModel) and not bottle.is_staged
    assert bottle.failure["reason"] == "c/bottle.obj: the worker process died while processing it"
    assert all(isinstance(r, compute.MeasuredModel)
               for name, r in by_name.items() if name != "c/bottle")


def test_zarr_and_hdf5_hold_the_same_dataset(src, tmp_path):
    options = replace(SMALL, clean=False)
    zarr_build = build_dataset(src, tmp_path / "zarr", options, categories=["shape"])
    hdf5_build = build_dataset(src, tmp_path / "hdf5", replace(options, format="hdf5"),
                               categories=["shape"])
    assert zarr_build.path.name == "dataset.zarr" and hdf5_build.path.name == "dataset.h5"
    in_zarr, in_hdf5 = read_store(zarr_build.path), read_store(hdf5_build.path)
    assert [m["name"] for m in in_zarr["models"]] == [
        "shape__test__suzanne", "shape__train__angle_block", "shape__train__table"]
    assert all(m["cleaning"] is None for m in in_zarr["models"])
    assert in_zarr["attrs"]["cleaning"] == {"enabled": False, "max_faces": 2000, "remesh": False}
    assert_same_dataset(in_zarr, in_hdf5)


@pytest.mark.slow
def test_two_workers_give_the_same_dataset_as_one(src, reference, tmp_path):
    result = build_dataset(src, tmp_path / "out", SMALL, workers=2)
    assert_same_dataset(read_store(result.path), reference[1])


@pytest.mark.slow
@pytest.mark.usefixtures("taken_dashboard_port")
def test_dask_cluster_gives_the_same_dataset(src, reference, tmp_path):
    require_package("distributed")
    from distributed import LocalCluster

    # Worker processes: a clean_mesh run in a non-main thread can corrupt the heap
    # at interpreter exit (seen with pymeshlab + scipy's libgfortran), so keep it
    # out of the pytest process.
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=DASK_DASHBOARD) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        result = build_dataset(src, tmp_path / "out", SMALL, scheduler=cluster.scheduler_address)
    assert_same_dataset(read_store(result.path), reference[1])


def test_unreachable_scheduler_is_bad_input(src, tmp_path, monkeypatch):
    require_package("distributed")
    monkeypatch.setattr(parallel, "_CONNECT_TIMEOUT", "1s")
    with pytest.raises(InputError, match="scheduler: cannot connect to tcp://127.0.0.1:9"):
        build_dataset(src, tmp_path / "out", SMALL, scheduler="tcp://127.0.0.1:9")


@pytest.mark.parametrize(
    ("options", "message"),
    [
        pytest.param({"workers": 0}, "workers: must be at least 1", id="no-workers"),
        pytest.param({"workers": 2, "scheduler": "tcp://127.0.0.1:8786"}, "workers: give either",
                     id="workers-and-scheduler"),
        pytest.param({"scheduler": ""}, "scheduler: expected an address", id="empty-scheduler"),
        pytest.param({"progress": 1}, "progress: expected True or False", id="progress-int"),
        pytest.param({"categories": "cup,shape"}, "categories: expected a list of names",
                     id="categories-str"),
    ],
)
def test_bad_arguments_name_the_argument(src, tmp_path, options, message):
    with pytest.raises(InputError, match=message):
        build_dataset(src, tmp_path / "out", SMALL, **options)
    assert not (tmp_path / "out").exists()


def test_an_output_folder_that_is_not_ours_is_left_alone(src, tmp_path):
    out = tmp_path / "papers"
    out.mkdir()
    (out / "thesis.tex").write_text("precious")
    with pytest.raises(InputError, match="not a vptoolkit build folder"):
        build_dataset(src, out, SMALL)
    assert sorted(p.name for p in out.iterdir()) == ["thesis.tex"]
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="is not a folder"):
        build_dataset(src, tmp_path / "file", SMALL)
    with pytest.raises(InputError, match="no mesh files"):
        build_dataset(out, tmp_path / "new", SMALL)


def test_a_second_build_in_the_same_folder_is_refused(src, tmp_path):
    import fcntl

    staging = tmp_path / "out" / STAGING_DIR
    staging.mkdir(parents=True)
    with open(staging / "lock", "a+b") as lock:
        fcntl.flock(lock.fileno(), fcntl.LOCK_EX)
        with pytest.raises(InputError, match="another build is running"):
            build_dataset(src, tmp_path / "out", SMALL)


def test_progress_bar_shows_models_and_failures(src, tmp_path, capsys):
    build_dataset(src, tmp_path / "out", replace(SMALL, clean=False), progress=True)
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "models: 100%" in captured.err and "8/8" in captured.err and "failed=2" in captured.err


def test_remeshing_builds_a_finer_uniform_tessellation(tmp_path):
    """remesh=True cleans, then remeshes isotropically: more, similar-sized faces, in attrs."""
    require_package("pymeshlab")
    from vptoolkit.data import open_dataset
    from vptoolkit.synthetic import write_collection

    write_collection(tmp_path / "src", n_per_category=1, categories=("table",), layout="flat")
    options = BuildOptions(MeasureSettings(views=40, resolution=48), n_points=500)
    plain = build_dataset(tmp_path / "src", tmp_path / "plain", options)
    remeshed = build_dataset(tmp_path / "src", tmp_path / "remeshed", replace(options, remesh=True))
    with open_dataset(plain.path) as first, open_dataset(remeshed.path) as second:
        assert first.attrs["cleaning"]["remesh"] is False
        assert second.attrs["cleaning"]["remesh"] is True
        faces = [len(dataset.mesh(0)[1]) for dataset in (first, second)]
    assert faces[1] > 10 * faces[0]
    with pytest.raises(InputError, match="remesh"):
        build_dataset(tmp_path / "src", tmp_path / "plain", replace(options, remesh=True))
