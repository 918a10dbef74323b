"""The install commands of the README and guides agree with pyproject.toml and tools/setup.sh."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from check_install_docs import CPU_INDEX, install_doc_problems

from fixtures.paths import REPO

SCRIPT = REPO / "tools" / "check_install_docs.py"


def test_the_checkout_install_docs_pass_the_check() -> None:
    done = subprocess.run([sys.executable, str(SCRIPT)], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stdout
    assert done.stdout == ""
    assert "the install docs agree with pyproject.toml" in done.stderr


@pytest.fixture()
def copy(tmp_path: Path) -> Path:
    """The files the check reads, copied from the checkout."""
    for name in ["README.md", "pyproject.toml", "tools/setup.sh", ".ci/run"]:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(REPO / name, tmp_path / name)
    shutil.copytree(REPO / "docs", tmp_path / "docs")
    return tmp_path


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text(encoding="utf-8")
    assert old in text, old
    path.write_text(text.replace(old, new, 1), encoding="utf-8")


def _line_of(path: Path, text: str) -> int:
    return next(number for number, line in
                enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if text in line)


def test_the_remote_extra_brings_huggingface_hub_and_all_includes_it() -> None:
    import tomllib

    extras = tomllib.loads((REPO / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]
    assert any(r.startswith("huggingface_hub") for r in extras["remote"])
    assert "remote" in extras["all"][0].split("[")[1].rstrip("]").split(",")


def test_an_extra_the_docs_name_must_exist(copy: Path) -> None:
    guide = copy / "docs/guide/learning.md"
    _edit(guide, "pip install 'vptoolkit[learn]'", "pip install 'vptoolkit[learning,dataset]'")
    line = _line_of(guide, "vptoolkit[learning")
    problems = install_doc_problems(copy)
    assert problems == [f"docs/guide/learning.md:{line}: extra 'learning' is not in "
                        "pyproject.toml (it has all, clean, cluster, dataset, dev, docs, las, "
                        "learn, measures, pictures, remote, torch)"]


def test_the_readme_table_of_extras_must_match_pyproject(copy: Path) -> None:
    _edit(copy / "pyproject.toml", 'torch = ["torch>=2.2"]\n', "")
    problems = install_doc_problems(copy)
    assert len(problems) == 2, problems
    assert problems[0].endswith("extra 'torch' is not in pyproject.toml (it has all, clean, "
                                "cluster, dataset, dev, docs, las, learn, measures, pictures, "
                                "remote)")
    assert problems[1].endswith("the table of extras lists 'torch', which pyproject.toml does "
                                "not define")


def test_a_torch_pin_in_the_docs_must_equal_the_setup_pin(copy: Path) -> None:
    _edit(copy / "tools/setup.sh", "torch==2.13.0", "torch==2.14.0")
    problems = install_doc_problems(copy)
    assert problems and all("but tools/setup.sh installs torch==2.14.0" in p for p in problems)
    assert any(p.startswith("README.md:") for p in problems)
    assert any(p.startswith("docs/guide/learning.md:") for p in problems)


def test_a_documented_torch_install_must_take_the_cpu_index(copy: Path) -> None:
    readme = copy / "README.md"
    _edit(readme, f"torch==2.13.0 --index-url {CPU_INDEX}", "torch==2.13.0")
    line = _line_of(readme, "pip install torch==2.13.0")
    assert install_doc_problems(copy) == [
        f"README.md:{line}: 'pip install torch==...' without --index-url {CPU_INDEX} installs "
        "the CUDA build on Linux"]


def test_the_docs_publish_with_hf_not_huggingface_cli(copy: Path) -> None:
    guide = copy / "docs/guide/datasets.md"
    _edit(guide, "hf auth login", "huggingface-cli login")
    line = _line_of(guide, "huggingface-cli login")
    assert install_doc_problems(copy) == [
        f"docs/guide/datasets.md:{line}: 'huggingface-cli' is replaced by huggingface_hub's "
        "'hf' command (hf upload, hf auth login)"]


def test_the_script_exits_1_with_one_line_per_problem(copy: Path) -> None:
    _edit(copy / "tools/setup.sh", "torch==2.13.0", "torch")
    done = subprocess.run([sys.executable, str(SCRIPT), str(copy)], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 1
    assert done.stdout == "tools/setup.sh: expected one torch==X pin, found 0\n"
