"""Every Python snippet of the guides (``docs/guide/*.md``) and the README runs as written.

Each snippet runs alone, in a child process (Open3D's renderer wants one), in a
fresh folder that holds what a reader's folder would: ``models/`` (three bundled
samples), ``out/`` (a small build), ``release/`` (its release) and
``licenses.csv``. A snippet preceded by a ``<!-- skip: why -->`` line does not
run (a build of ModelNet40, a training run, a web server); :data:`MAX_SKIPPED`
bounds how many. A snippet that imports a package this environment lacks is
skipped with its name. The Open3D snippet of the best-view guide is also checked
for what it says it draws: the bunny upright (ears at the top) and lit.
"""

from __future__ import annotations

import ast
import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

from fixtures.paths import TESTS

ROOT = TESTS.parent
GUIDES = sorted((ROOT / "docs" / "guide").glob("*.md")) + [ROOT / "README.md"]
MAX_SKIPPED = 4
"""Snippets marked not runnable, at most (each says why in its comment)."""

MODELS = ("mug.obj", "ballA.off", "angle_block.STL")


class Snippet(NamedTuple):
    """One fenced ``python`` block: where it starts, its code, and whether it is marked skip."""

    where: str
    code: str
    skipped: bool


def guide_snippets() -> list[Snippet]:
    """Every fenced ``python`` block of :data:`GUIDES`, in file and line order."""
    found = []
    for path in GUIDES:
        lines = path.read_text(encoding="utf-8").split("\n")
        index = 0
        while index < len(lines):
            if lines[index].strip() == "```python":
                end = lines.index("```", index + 1)
                before = next((line for line in reversed(lines[:index]) if line.strip()), "")
                found.append(Snippet(f"{path.relative_to(ROOT)}:{index + 1}",
                                     "\n".join(lines[index + 1:end]),
                                     before.strip().startswith("<!-- skip")))
                index = end
            index += 1
    return found


SNIPPETS = guide_snippets()
RUNNABLE = [snippet for snippet in SNIPPETS if not snippet.skipped]


def test_few_snippets_are_skipped_and_none_is_empty():
    assert 0 < len(SNIPPETS) - len(RUNNABLE) <= MAX_SKIPPED
    assert all(snippet.code.strip() for snippet in SNIPPETS)


def _missing_package(code: str) -> str | None:
    """The first top-level package the snippet imports that is not installed, if any."""
    for node in ast.walk(ast.parse(code)):
        names = ([alias.name for alias in node.names] if isinstance(node, ast.Import)
                 else [node.module] if isinstance(node, ast.ImportFrom) and node.module else [])
        for name in names:
            if importlib.util.find_spec(name.split(".")[0]) is None:
                return name.split(".")[0]
    return None


@pytest.fixture()
def reader_folder(tmp_path: Path, request: pytest.FixtureRequest) -> Path:
    """A folder as the guides assume: models/, out/, release/ (unless the snippet packs it)
    and licenses.csv."""
    from vptoolkit.samples import sample_path

    models = tmp_path / "models"
    models.mkdir()
    for name in MODELS:
        shutil.copy(sample_path(name), models / name)
    code = request.node.callspec.params["snippet"].code
    if "release/" in code or "out/" in code or "licenses.csv" in code:
        build = request.getfixturevalue("build")
        shutil.copytree(build, tmp_path / "out")
        shutil.copy(request.getfixturevalue("licenses_csv"), tmp_path / "licenses.csv")
        if "pack_release(" not in code:
            shutil.copytree(request.getfixturevalue("release").path, tmp_path / "release")
    return tmp_path


@pytest.mark.slow
@pytest.mark.parametrize("snippet", RUNNABLE, ids=[snippet.where for snippet in RUNNABLE])
def test_the_snippet_runs_as_written(snippet: Snippet, reader_folder: Path):
    missing = _missing_package(snippet.code)
    if missing is not None:
        pytest.skip(f"{snippet.where} needs {missing}")
    script = reader_folder / "snippet.py"
    script.write_text(snippet.code + "\n", encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get(
        "PYTHONPATH", "")]), "MPLBACKEND": "Agg"}
    done = subprocess.run([sys.executable, str(script)], cwd=reader_folder, env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, f"{snippet.where} failed:\n{done.stderr[-3000:]}"
    if "bunny_ve.png" in snippet.code:
        _check_upright_and_lit(reader_folder / "bunny_ve.png")


def _check_upright_and_lit(picture: Path) -> None:
    """The bunny of the Open3D snippet is drawn where the exported pose puts its vertices
    (a picture turned upside down covers about 70 % of them), that pose puts its ears (the
    top tenth in +y) in the upper half, and it is shaded, not one flat colour."""
    from PIL import Image

    from vptoolkit import SearchSettings, load_mesh, search_best_views
    from vptoolkit.samples import sample_path

    image = np.asarray(Image.open(picture).convert("L"), dtype=np.int64)
    drawn = image != image[0, 0]
    bunny = load_mesh(sample_path("bunny.ply"))
    found = search_best_views(bunny, SearchSettings(budget=64, resolution=128))
    extrinsic = np.linalg.inv(found.camera_pose("VE"))
    points = bunny.vertices @ extrinsic[:3, :3].T + extrinsic[:3, 3]
    pixels = points @ found.intrinsics(image.shape[0]).T
    columns, rows = (pixels[:, :2] / pixels[:, 2:]).astype(int).T
    assert drawn[rows, columns].mean() > 0.97
    heights = bunny.vertices[:, 1]
    ears = heights > heights.max() - 0.1 * np.ptp(heights)
    assert rows[ears].max() < image.shape[0] / 2
    assert len(np.unique(image[drawn])) > 60  # lit: about 160 shades; unlit about 30 (edges)
