"""What a plain install needs: no heavy package, and a fresh venv that reads a release."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from fixtures.paths import REPO
from fixtures.releases import N_MODELS
from fixtures.stores import N_VIEWS


def test_plain_install_needs_no_heavy_package() -> None:
    import tomllib

    project = tomllib.loads((REPO / "pyproject.toml").read_text())
    core = [re.split(r"[<>=;\[ ]", dep)[0] for dep in project["project"]["dependencies"]]
    assert sorted(core) == ["click", "h5py", "numpy", "packaging", "tqdm"]
    extras = project["project"]["optional-dependencies"]
    assert "vptoolkit[measures,clean,dataset,cluster,learn,pictures,remote,las]" in extras["all"]
    for package in ("numba", "trimesh"):
        assert any(dep.startswith(package) for dep in extras["measures"])
    assert {"datasets", "mlcroissant"} <= {re.split(r"[<>=]", d)[0] for d in extras["dev"]}


LIGHT_SCRIPT = """
import sys
from vptoolkit.data import open_dataset

with open_dataset(sys.argv[1]) as dataset:
    names = [item["name"] for item in dataset]
    shapes = {item["quality"].shape for item in dataset.split("validation")}
heavy = [m for m in ("torch", "open3d", "pymeshlab", "numba", "trimesh") if m in sys.modules]
print(len(names), sorted(shapes), heavy)
"""


@pytest.mark.slow
def test_a_plain_pip_install_reads_a_release(mini_release, tmp_path: Path) -> None:
    """The README's light install: `pip install vptoolkit`, no extras, then load a release."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, capture_output=True)
    python = venv / "bin" / "python"
    install = subprocess.run([str(python), "-m", "pip", "install", "--quiet",
                              "--disable-pip-version-check", str(REPO)],
                             capture_output=True, text=True)
    if install.returncode != 0:
        message = f"pip install failed: {install.stderr.strip()[-500:]}"
        if os.environ.get("VPTOOLKIT_REQUIRE_ALL") == "1":
            pytest.fail(message)
        pytest.skip(message)
    size = sum(p.stat().st_size for p in venv.rglob("*") if p.is_file() and not p.is_symlink())
    assert size < 250 * 2**20, f"{size / 2**20:.0f} MiB"
    listed = subprocess.run([str(python), "-m", "pip", "list", "--format=freeze"],
                            capture_output=True, text=True, check=True).stdout.lower()
    for heavy in ("open3d", "torch", "numba", "pymeshlab", "trimesh"):
        assert f"\n{heavy}" not in f"\n{listed}", heavy
    environment = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    result = subprocess.run([str(python), "-W", "error", "-c", LIGHT_SCRIPT,
                             str(mini_release.path)],
                            capture_output=True, text=True, env=environment, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == f"{N_MODELS} [({N_VIEWS}, 4)] []"
    info = subprocess.run([str(venv / "bin" / "vptool"), "info", str(mini_release.path)],
                          capture_output=True, text=True, env=environment)
    assert info.returncode == 0 and f"models {N_MODELS}" in info.stdout
