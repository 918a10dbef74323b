"""A build survives damage to its staging folder, and leaves no process behind when killed."""

from __future__ import annotations

import logging
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from vptoolkit.dataset.build import build_dataset
from vptoolkit.dataset.reader import open_store
from vptoolkit.dataset.schema import ARRAY_NAMES
from vptoolkit.dataset.staging import STAGING_DIR
from vptoolkit.samples import sample_path

SMALL = {"n_views": 60, "resolution": 64, "n_points": 300, "max_faces": 2000, "clean": False}


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
    first = build_dataset(src, out, **SMALL)
    with open_store(first.path) as store:
        reference = {name: np.asarray(store.array(name)[...]) for name in ARRAY_NAMES}
    staged = sorted((out / STAGING_DIR).glob("m-*teapot*.npz"))[0]
    content = bytearray(staged.read_bytes())
    content[len(content) // 3] ^= 0x10  # inside a compressed member: a bad CRC
    staged.write_bytes(bytes(content))

    with caplog.at_level(logging.WARNING, logger="vptoolkit.dataset.staging"):
        again = build_dataset(src, out, **SMALL)
    warnings = [record.getMessage() for record in caplog.records if record.levelno >= logging.WARNING]
    assert len(warnings) == 1 and staged.name in warnings[0] and "\n" not in warnings[0]
    assert again.n_resumed == 1 and again.n_models == 2
    with open_store(again.path) as store:
        for name in ARRAY_NAMES:
            assert np.array_equal(np.asarray(store.array(name)[...]), reference[name],
                                  equal_nan=True), name


def test_the_build_reports_seconds_per_stage_and_stores_none(tmp_path: Path) -> None:
    from vptoolkit.dataset.build import STAGES

    src = tmp_path / "src"
    src.mkdir()
    shutil.copyfile(sample_path("teapot"), src / "teapot.stl")
    result = build_dataset(src, tmp_path / "out", **SMALL)
    assert set(result.stage_seconds) == set(STAGES) and result.n_computed == 1
    assert all(spent >= 0.0 for spent in result.stage_seconds.values())
    assert result.stage_seconds["measure"] > 0.0
    again = build_dataset(src, tmp_path / "out", **SMALL)  # all resumed: nothing computed
    assert again.n_computed == 0 and again.stage_seconds["measure"] == 0.0
