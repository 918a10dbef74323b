"""Sizing a build before it runs: ``--dry-run``, ``--max-models`` and the compile notice.

Builds run the real pipeline on the bundled sample meshes at tiny sizes
(40 views at 48 px, 200 points, no cleaning).
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
from click.testing import CliRunner

from vptoolkit.cli import main
from vptoolkit.dataset.builder import run as build_module
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.dataset.builder.plan import plan_build
from vptoolkit.dataset.builder.run import COMPILE_NOTICE, build_dataset
from vptoolkit.dataset.builder.sources import discover_models, split_of, spread_over_categories
from vptoolkit.dataset.store.reader import open_store
from vptoolkit.errors import InputError
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings

TINY = BuildOptions(MeasureSettings(views=40, resolution=48), n_points=200, clean=False)
TINY_ARGS = ["--views", "40", "--resolution", "48", "--points", "200", "--no-clean"]
TREE = {
    "cup/train/mug.obj": "mug",
    "cup/train/bottle.obj": "bottle",
    "cup/test/teapot.stl": "teapot",
    "shape/train/angle_block.STL": "angle_block",
    "shape/train/table.obj": "table",
    "shape/test/suzanne.ply": "suzanne",
    "toy/train/lego.obj": "lego",
}


@pytest.fixture(scope="module")
def src(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("plan") / "src"
    for relative, name in TREE.items():
        target = root / relative
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(sample_path(name), target)
    return root


def test_spread_over_categories_takes_one_category_after_another(src):
    models = discover_models(src)  # cup: test__teapot, train__bottle, train__mug; shape: ...
    assert [m.name for m in spread_over_categories(models, 4)] == [
        "cup__test__teapot", "cup__train__bottle", "shape__test__suzanne", "toy__train__lego"]
    assert [m.name for m in spread_over_categories(models, 2)] == [
        "cup__test__teapot", "shape__test__suzanne"]
    assert spread_over_categories(models, 100) == models
    with pytest.raises(InputError, match="max_models"):
        spread_over_categories(models, 0)


def test_max_models_builds_that_subset_with_the_full_splits_and_resumes_only_with_it(
        src, tmp_path):
    out = tmp_path / "out"
    result = build_dataset(src, out, replace(TINY, max_models=4))
    assert result.n_models == 4 and result.n_failures == 0
    with open_store(result.path) as store:
        records = {record["name"]: record for record in store.models()}
    assert sorted(records) == ["cup__test__teapot", "cup__train__bottle", "shape__test__suzanne",
                               "toy__train__lego"]
    splits = {m.name: split_of(m, 0) for m in discover_models(src)}
    assert {name: record["split"] for name, record in records.items()} == {
        name: splits[name] for name in records}
    again = build_dataset(src, out, replace(TINY, max_models=4))
    assert again.n_resumed == 4 and again.n_computed == 0
    with pytest.raises(InputError, match=r"max_models=4 \(now None\)"):
        build_dataset(src, out, TINY)


def test_dry_run_counts_per_category_and_split_without_writing_out(src, tmp_path):
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["build-dataset", str(src), str(out), "--dry-run",
                                       "--calibrate", "0", *TINY_ARGS])
    assert result.exit_code == 0, result.output
    assert not out.exists()
    models = discover_models(src)
    lines = result.output.splitlines()
    for category in ("cup", "shape", "toy"):
        row = next(line.split() for line in lines if line.startswith(category + " "))
        expected = [sum(1 for m in models if m.category == category and split_of(m, 0) == s)
                    for s in ("train", "val", "test")]
        assert [int(value) for value in row[1:]] == expected
    assert "7 models to build, 0 duplicate names" in result.output
    assert "estimate" not in result.output


def test_dry_run_estimates_hours_and_disk_from_the_calibration_models(src, tmp_path):
    plan = plan_build(src, tmp_path / "out", TINY, calibrate=2)
    assert plan.n_models == 7 and plan.n_calibrated == 2 and plan.n_calibration_failures == 0
    assert plan.seconds_per_model is not None and plan.seconds_per_model > 0
    assert plan.estimated_seconds == pytest.approx(7 * plan.seconds_per_model)
    # the per-model bytes are those of a real build folder of two models
    built = build_dataset(src, tmp_path / "two", replace(TINY, max_models=2))
    n_bytes = sum(p.stat().st_size for p in built.path.parent.rglob("*") if p.is_file())
    assert plan.bytes_per_model == pytest.approx(n_bytes / 2, rel=0.2)
    assert plan.estimated_bytes == pytest.approx(7 * plan.bytes_per_model)
    assert "estimate from 2 calibration models" in plan.lines()[-1]
    assert not list(Path(tmp_path).glob("out*"))


def test_the_estimate_shares_the_hours_among_the_workers_one_per_cpu(src, tmp_path):
    plan = plan_build(src, tmp_path / "out", TINY, calibrate=1, workers=64)
    # one process per CPU at most, and never more processes than models
    assert plan.workers == min(64, os.cpu_count() or 1, plan.n_models)
    assert plan.estimated_wall_seconds == pytest.approx(plan.estimated_seconds / plan.workers)
    hour_each = replace(plan, seconds_per_model=3600.0)  # 7 models
    assert "about 7.0 h in one process" in replace(hour_each, workers=1).lines()[-1]
    assert "worker processes" not in replace(hour_each, workers=1).lines()[-1]
    assert "about 3.5 h with 2 worker processes" in replace(hour_each, workers=2).lines()[-1]
    assert replace(plan, seconds_per_model=None).estimated_wall_seconds is None


def test_dry_run_of_a_subset_counts_the_subset(src, tmp_path):
    plan = plan_build(src, tmp_path / "out", replace(TINY, max_models=2), calibrate=0)
    assert plan.n_models == 2 and plan.n_found == 7
    assert sum(sum(row.values()) for row in plan.counts.values()) == 2
    assert set(plan.counts) == {"cup", "shape"}
    assert "a subset of the 7 found" in "\n".join(plan.lines())


def test_bad_max_models_is_bad_input(src, tmp_path):
    result = CliRunner().invoke(main, ["build-dataset", str(src), str(tmp_path / "o"),
                                       "--max-models", "0", *TINY_ARGS])
    assert result.exit_code == 2
    result = CliRunner().invoke(main, ["build-dataset", str(src), str(tmp_path / "o"),
                                       "--calibrate", "2", *TINY_ARGS])
    assert result.exit_code == 2 and "--calibrate: only with --dry-run" in result.output
    assert not (tmp_path / "o").exists()
    with pytest.raises(InputError, match="max_models"):
        build_dataset(src, tmp_path / "o", replace(TINY, max_models=0))


def test_the_compile_notice_is_printed_exactly_when_the_kernel_would_compile(
        src, tmp_path, monkeypatch, capsys):
    import vptoolkit._numba

    for compiles in (True, False):
        monkeypatch.setattr(vptoolkit._numba, "will_compile", lambda _dispatcher: compiles)
        build_dataset(src, tmp_path / f"out-{compiles}", replace(TINY, max_models=1), progress=True)
        assert (COMPILE_NOTICE in capsys.readouterr().err) is compiles
    # nothing to compute (all resumed): no notice even with an empty cache
    monkeypatch.setattr(vptoolkit._numba, "will_compile", lambda _dispatcher: True)
    build_dataset(src, tmp_path / "out-True", replace(TINY, max_models=1), progress=True)
    assert COMPILE_NOTICE not in capsys.readouterr().err
    assert build_module.COMPILE_NOTICE == COMPILE_NOTICE


def test_will_compile_reads_numbas_cache_of_a_function(tmp_path):
    from vptoolkit._numba import will_compile

    module_file = tmp_path / "cached_kernel.py"
    module_file.write_text("from numba import njit\n\n@njit(cache=True)\n"
                           "def add_one(x):\n    return x + 1\n")
    spec = importlib.util.spec_from_file_location("cached_kernel", module_file)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert will_compile(module.add_one)  # no cache on disk, not compiled here
    assert module.add_one(1) == 2
    assert not will_compile(module.add_one)  # compiled in this process
    check = ("import sys; sys.path.insert(0, sys.argv[1]); import cached_kernel; "
             "from vptoolkit._numba import will_compile; "
             "print(will_compile(cached_kernel.add_one))")
    fresh = subprocess.run([sys.executable, "-c", check, str(tmp_path)], capture_output=True,
                           text=True, check=True, timeout=120)
    assert fresh.stdout.strip() == "False"  # another process finds the cache
    module_file.write_text(module_file.read_text() + "\n# edited\n")
    stale = subprocess.run([sys.executable, "-c", check, str(tmp_path)], capture_output=True,
                           text=True, check=True, timeout=120)
    assert stale.stdout.strip() == "True"  # the source changed: numba compiles again


def test_calibration_models_are_spread_over_the_file_sizes(src, tmp_path):
    from vptoolkit.dataset.builder.plan import size_strata

    models = discover_models(src)
    by_size = sorted(models, key=lambda model: model.path.stat().st_size)
    chosen = size_strata(models, 3)  # midpoints of 3 strata of 7: indices 1, 3 and 5
    assert [model.name for model in chosen] == [by_size[i].name for i in (1, 3, 5)]
    assert size_strata(models, 10) == by_size and size_strata([], 2) == []
    # A collection sorted small-first is not judged by its first, smallest models.
    plan = plan_build(src, tmp_path / "out", TINY, calibrate=3)
    assert plan.n_calibrated == 3 and plan.n_calibration_failures == 0


def test_calibration_draws_as_a_worker_of_the_build_does(src, tmp_path, monkeypatch):
    """Several workers draw with one numba thread each; one process with all of them."""
    from vptoolkit._numba import max_threads, numba

    seen = []
    real = build_module.build_dataset

    def recording(*args, **kwargs):
        seen.append(numba.get_num_threads())
        return real(*args, **kwargs)

    monkeypatch.setattr(build_module, "build_dataset", recording)
    shared = plan_build(src, tmp_path / "a", TINY, calibrate=1, workers=2)
    plan_build(src, tmp_path / "b", TINY, calibrate=1, workers=1)
    # [warm-up, timed] per plan; one CPU gives one worker whatever is asked
    assert seen[1] == (1 if shared.workers > 1 else max_threads())
    assert seen[3] == max_threads()
    assert numba.get_num_threads() == max_threads()  # restored
