"""A build survives damage to its staging folder, and leaves no process behind when killed."""

from __future__ import annotations

import json
import logging
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest

from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.dataset.builder.run import build_dataset
from vptoolkit.dataset.builder.sources import discover_models
from vptoolkit.dataset.builder.staging import STAGING_DIR, scan_staging, source_signature
from vptoolkit.dataset.store.reader import open_store
from vptoolkit.dataset.store.schema import ARRAY_NAMES
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings

TET = "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"
SMALL = BuildOptions(MeasureSettings(views=60, resolution=64), n_points=300, max_faces=2000,
                     clean=False)


def _descendants(pid: int) -> list[int]:
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                fields = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if fields[0] != "Z":
                children.setdefault(int(fields[1]), []).append(int(entry))
    found, stack = [], [pid]
    while stack:
        for child in children.get(stack.pop(), []):
            found.append(child)
            stack.append(child)
    return found


def _is_running(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_workers_die_with_a_killed_build(tmp_path: Path) -> None:
    (tmp_path / "napping.py").write_text(
        "import time\n\ndef nap(task):\n    time.sleep(600)\n    return {}\n"
    )
    script = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(tmp_path)!r})
        import napping
        from vptoolkit.parallel import run_tasks
        for result in run_tasks(napping.nap, ["a", "b"], workers=2, crashed=repr):
            print(result)
    """)
    build = subprocess.Popen([sys.executable, "-c", script])
    try:
        deadline = time.monotonic() + 120
        while len(_descendants(build.pid)) < 4:  # forkserver, tracker and two workers
            assert build.poll() is None and time.monotonic() < deadline
            time.sleep(0.1)
        time.sleep(1.0)
        left = _descendants(build.pid)
    finally:
        build.kill()
        build.wait()
    deadline = time.monotonic() + 20
    while any(_is_running(pid) for pid in left) and time.monotonic() < deadline:
        time.sleep(0.2)
    alive = [pid for pid in left if _is_running(pid)]
    for pid in alive:  # do not leave them behind even when the test fails
        os.kill(pid, signal.SIGKILL)
    assert not alive


def test_an_unreadable_staged_model_is_computed_again_with_one_warning(tmp_path, caplog):
    src = tmp_path / "src"
    src.mkdir()
    for name in ("teapot", "suzanne"):
        shutil.copyfile(sample_path(name), src / sample_path(name).name)
    out = tmp_path / "out"
    first = build_dataset(src, out, SMALL)
    with open_store(first.path) as store:
        reference = {name: np.asarray(store.array(name)[...]) for name in ARRAY_NAMES}
    staged = sorted((out / STAGING_DIR).glob("m-*teapot*.npz"))[0]
    content = bytearray(staged.read_bytes())
    content[len(content) // 3] ^= 0x10  # inside a compressed member: a bad CRC
    staged.write_bytes(bytes(content))

    with caplog.at_level(logging.WARNING, logger="vptoolkit.dataset.builder.staging"):
        again = build_dataset(src, out, SMALL)
    warnings = [record.getMessage() for record in caplog.records
                if record.levelno >= logging.WARNING]
    assert len(warnings) == 1 and staged.name in warnings[0] and "\n" not in warnings[0]
    assert again.n_resumed == 1 and again.n_models == 2
    with open_store(again.path) as store:
        for name in ARRAY_NAMES:
            assert np.array_equal(np.asarray(store.array(name)[...]), reference[name],
                                  equal_nan=True), name


@pytest.fixture(scope="module")
def staged_tetrahedron(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A source folder holding one tetrahedron and the staging folder of its build."""
    root = tmp_path_factory.mktemp("staged")
    src = root / "src"
    src.mkdir()
    (src / "tet.off").write_text(TET)
    build_dataset(src, root / "out", SMALL)
    return src, root / "out" / STAGING_DIR


def _break_deflate(staged: Path, src: Path) -> None:
    """Make the deflate stream of the ``points`` member invalid (block type 3)."""
    content = bytearray(staged.read_bytes())
    with zipfile.ZipFile(staged) as archive:
        info = archive.getinfo("points.npy")
    start = info.header_offset
    name_length = int.from_bytes(content[start + 26 : start + 28], "little")
    extra_length = int.from_bytes(content[start + 28 : start + 30], "little")
    content[info.header_offset + 30 + name_length + extra_length] = 0xFF
    staged.write_bytes(bytes(content))


def _replace_meta(staged: Path, meta: bytes | None) -> None:
    """Replace the ``meta`` member; None keeps its signature and drops its record."""
    with np.load(staged, allow_pickle=False) as loaded:
        arrays = {name: loaded[name] for name in loaded.files}
    if meta is None:
        signature = json.loads(arrays["meta"].tobytes())["signature"]
        meta = json.dumps({"signature": signature}).encode()
    arrays["meta"] = np.frombuffer(meta, dtype=np.uint8)
    with open(staged, "wb") as stream:
        np.savez_compressed(stream, **arrays)


def _failure_instead(staged: Path, failure: str, src: Path) -> None:
    (model,) = discover_models(src)
    signature = json.dumps(source_signature(model))
    staged.with_name(staged.name.replace(".npz", ".failed.json")).write_text(
        failure.replace("SIGNATURE", signature))
    staged.unlink()


@pytest.mark.parametrize("damage", [
    pytest.param(_break_deflate, id="damaged-deflate-stream"),
    pytest.param(lambda staged, src: _replace_meta(staged, b"[1, 2]"), id="meta-a-list"),
    pytest.param(lambda staged, src: _replace_meta(staged, None), id="meta-without-record"),
    pytest.param(lambda staged, src: _replace_meta(staged, b"[" * 200_000), id="meta-nested"),
    pytest.param(lambda staged, src: _failure_instead(
                     staged, '{"signature": SIGNATURE, "failure": 3}', src),
                 id="failure-a-number"),
    pytest.param(lambda staged, src: _failure_instead(staged, "[" * 200_000, src),
                 id="failure-nested"),
])
def test_a_staged_file_that_decodes_wrong_is_computed_again(
    staged_tetrahedron: tuple[Path, Path], tmp_path: Path, caplog: pytest.LogCaptureFixture, damage
) -> None:
    src, reference = staged_tetrahedron
    staging = tmp_path / STAGING_DIR
    shutil.copytree(reference, staging)
    (staged,) = staging.glob("m-*.npz")
    damage(staged, src)
    models = discover_models(src)

    with caplog.at_level(logging.WARNING, logger="vptoolkit.dataset.builder.staging"):
        done, failed, todo = scan_staging(staging, models)
    assert (done, failed, todo) == ({}, {}, models)
    assert not list(staging.glob("m-*")), "the unreadable staged file is deleted"
    warnings = [record.getMessage() for record in caplog.records
                if record.levelno >= logging.WARNING]
    assert len(warnings) <= 1 and all("\n" not in warning for warning in warnings)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
def test_a_named_pipe_in_the_source_is_a_failure_not_a_hang(tmp_path: Path) -> None:
    src = tmp_path / "src"
    src.mkdir()
    (src / "tet.off").write_text(TET)
    os.mkfifo(src / "pipe.off")

    def give_up(signum: int, frame: object) -> None:
        raise TimeoutError("the build waited on the named pipe")

    previous = signal.signal(signal.SIGALRM, give_up)
    signal.alarm(60)
    try:
        result = build_dataset(src, tmp_path / "out", SMALL)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    assert result.n_models == 1
    (failure,) = result.failures
    assert failure["source"] == "pipe.off" and "not a regular file" in failure["reason"]


def test_the_build_reports_seconds_per_stage_and_stores_none(tmp_path: Path) -> None:
    from vptoolkit.dataset.builder.run import STAGES

    src = tmp_path / "src"
    src.mkdir()
    shutil.copyfile(sample_path("teapot"), src / "teapot.stl")
    result = build_dataset(src, tmp_path / "out", SMALL)
    assert set(result.stage_seconds) == set(STAGES) and result.n_computed == 1
    assert all(spent >= 0.0 for spent in result.stage_seconds.values())
    assert result.stage_seconds["measure"] > 0.0
    again = build_dataset(src, tmp_path / "out", SMALL)  # all resumed: nothing computed
    assert again.n_computed == 0 and again.stage_seconds["measure"] == 0.0


def test_a_dangling_symlink_in_the_source_is_named_by_its_path_under_src(tmp_path: Path) -> None:
    src = tmp_path / "src"
    (src / "tets").mkdir(parents=True)
    (src / "tets" / "tet.off").write_text(TET)
    (src / "tets" / "gone.off").symlink_to(tmp_path / "nowhere" / "gone.off")
    result = build_dataset(src, tmp_path / "out", SMALL)
    assert result.n_models == 1
    (failure,) = result.failures
    assert failure["source"] == "tets/gone.off"
    assert failure["reason"] == "tets/gone.off: dangling symbolic link (its target does not exist)"
    store = [path for path in (tmp_path / "out" / "dataset.zarr").rglob("*") if path.is_file()]
    assert store and not any(str(tmp_path).encode() in path.read_bytes() for path in store)
