"""Outputs: checked before the work, named in every error, never left half-written or stale."""

from __future__ import annotations

import errno
import io
import logging
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from vptoolkit.cli import main
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.errors import InputError
from vptoolkit.files import atomic_write, write_bytes_atomic
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings


def _run(*args: object) -> tuple[int, str]:
    outcome = CliRunner().invoke(main, [str(arg) for arg in args])
    return outcome.exit_code, outcome.output


@pytest.mark.parametrize("command, args", [
    ("measures", ["--views", "20", "--resolution", "32", "-o", "{missing}/q.npz"]),
    ("sample", ["-o", "{missing}/p.npy"]),
    ("clean", ["{tmp}/clean.ply", "--report", "{missing}/r.json"]),
], ids=["measures", "sample", "clean-report"])
def test_a_missing_output_folder_is_named_before_any_work(tmp_path: Path, command: str,
                                                          args: list[str]) -> None:
    missing = tmp_path / "nodir"
    filled = [arg.format(missing=missing, tmp=tmp_path) for arg in args]
    code, text = _run(command, sample_path("teapot"), *filled)
    assert code == 2 and text.count("\n") == 1, text
    assert f"{missing}/" in text and "does not exist" in text and ".partial" not in text
    assert not (tmp_path / "clean.ply").exists()  # clean wrote no mesh before failing


def test_a_failed_write_names_the_target_not_the_temporary_file(tmp_path: Path) -> None:
    target = tmp_path / "out.npz"
    with pytest.raises(OSError) as caught, atomic_write(target):
        raise OSError(errno.ENOSPC, "No space left on device")  # what a full disk raises
    assert caught.value.filename == str(target)
    assert not list(tmp_path.iterdir())


class _FullDisk(io.RawIOBase):
    """A file on a full disk: every write fails, as the kernel's ENOSPC does."""

    def __init__(self, handle: int) -> None:
        self._handle = handle

    def writable(self) -> bool:
        return True

    def fileno(self) -> int:
        return self._handle

    def write(self, data) -> int:
        raise OSError(errno.ENOSPC, "No space left on device")

    def close(self) -> None:
        if not self.closed:
            os.close(self._handle)
        super().close()


class _OsOnAFullDisk:
    """``os`` for vptoolkit.files, whose fdopen gives a file on a full disk."""

    def __getattr__(self, name: str):
        return getattr(os, name)

    @staticmethod
    def fdopen(handle: int, mode: str = "rb", *args, **kwargs):
        return io.BufferedWriter(_FullDisk(handle))


@pytest.mark.parametrize("command, args", [
    ("sample", ["-o", "{out}/p.npy"]),
    ("measures", ["--views", "20", "--resolution", "32", "-o", "{out}/q.npz"]),
    ("views", ["--views", "20", "--resolution", "32", "-o", "{out}/v.npz"]),
    ("render", ["--view", "0,0,1", "--size", "32", "-o", "{out}/r.png"]),
    ("predict", ["-o", "{out}/d.npz"]),
], ids=lambda value: value if isinstance(value, str) else None)
def test_a_full_disk_names_the_output(tmp_path: Path, monkeypatch, command: str,
                                      args: list[str]) -> None:
    from vptoolkit import files

    out = tmp_path / "out"
    out.mkdir()
    filled = [arg.format(out=out) for arg in args]
    monkeypatch.setattr(files, "os", _OsOnAFullDisk())
    code, text = _run(command, sample_path("teapot"), *filled)
    assert code == 2, text
    line = text.splitlines()[-1]
    assert line == f"vptool: error: {filled[-1]}: No space left on device", text
    assert "Traceback" not in text and list(out.iterdir()) == []


@pytest.mark.parametrize("n_bytes", [235, 250, 255])
def test_names_up_to_255_bytes_can_be_written(tmp_path: Path, n_bytes: int) -> None:
    target = tmp_path / ("a" * (n_bytes - 4) + ".npz")
    write_bytes_atomic(target, b"data")
    assert target.read_bytes() == b"data" and len(list(tmp_path.iterdir())) == 1


def test_stale_partials_of_killed_writes_are_removed_by_the_next_success(
    small_build: Path, tmp_path: Path
) -> None:
    from vptoolkit.dataset.release.pack import pack_release
    from vptoolkit.dataset.store.reader import open_store
    from vptoolkit.dataset.store.writer import write_dataset

    beside = tmp_path / ".release.k9x2ab.partial"
    beside.mkdir()
    (beside / "half.h5").write_bytes(b"half")
    inside = small_build / ".dataset.zarr.q1w2e3.partial"
    inside.mkdir()
    pack_release(small_build, tmp_path / "release")
    assert not beside.exists()
    with open_store(small_build / "dataset.zarr") as reader:
        write_dataset(tmp_path / "copy.zarr", reader.entries(), attrs=dict(reader.attrs),
                      views=reader.array("views")[:], failures=reader.failures())
    shutil.rmtree(tmp_path / "copy.zarr")
    (tmp_path / ".copy.zarr.zz.partial").mkdir()
    with open_store(small_build / "dataset.zarr") as reader:
        write_dataset(tmp_path / "copy.zarr", reader.entries(), attrs=dict(reader.attrs),
                      views=reader.array("views")[:], failures=reader.failures())
    assert not (tmp_path / ".copy.zarr.zz.partial").exists()


def test_sphere_map_of_a_text_file_says_what_it_is(tmp_path: Path) -> None:
    text_file = tmp_path / "notes.npz"
    text_file.write_text("just text\n")
    code, text = _run("sphere-map", text_file, "-o", tmp_path / "m.png")
    assert code == 2 and "notes.npz: not an .npz archive" in text and "pickled" not in text


def test_huge_direction_vectors_score_like_unit_ones(small_build: Path) -> None:
    from vptoolkit.data import open_dataset
    from vptoolkit.evaluate.scores import score_directions

    with open_dataset(small_build) as dataset:
        directions = np.random.default_rng(0).normal(size=(len(dataset), 4, 3))
        unit = score_directions(dataset, directions).scores
        huge = score_directions(dataset, directions / np.abs(directions).max() * 1e308).scores
    np.testing.assert_array_equal(huge, unit)


def test_frame_buffers_are_capped_by_a_memory_budget() -> None:
    from vptoolkit.visibility._workspace import FRAME_BUDGET_BYTES, threads_within_budget

    assert threads_within_budget(resolution=16384, n_faces=10, n_vertices=10, capacity=10) == 1
    small = threads_within_budget(resolution=64, n_faces=10, n_vertices=10, capacity=10)
    assert small >= 1 and 8 * 64 * 64 * small <= FRAME_BUDGET_BYTES


def test_a_rerun_with_fewer_categories_says_the_store_shrinks(tmp_path: Path, caplog) -> None:
    from vptoolkit.dataset.builder.run import build_dataset

    for relative in ("cup/teapot.stl", "shape/suzanne.ply"):
        (tmp_path / "src" / relative).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(sample_path(Path(relative).name), tmp_path / "src" / relative)
    options = BuildOptions(MeasureSettings(views=20, resolution=32), n_points=50, clean=False)
    build_dataset(tmp_path / "src", tmp_path / "out", options)
    with caplog.at_level(logging.WARNING, logger="vptoolkit.dataset.builder.staging"):
        result = build_dataset(tmp_path / "src", tmp_path / "out", options, categories=["cup"])
    assert result.n_models == 1
    assert any("1 staged models are not part of this run" in r.getMessage()
               for r in caplog.records)


def test_output_folder_check_names_the_argument(tmp_path: Path) -> None:
    from vptoolkit.files import check_output_folder

    with pytest.raises(InputError, match=r"^--output: .*nodir/x.npz: output folder .* does not"):
        check_output_folder(tmp_path / "nodir" / "x.npz", "--output")
