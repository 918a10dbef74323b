"""Every install hint names an extra that pyproject.toml declares."""

from __future__ import annotations

import ast
import tomllib
from pathlib import Path

import pytest

import vptoolkit
from fixtures.paths import REPO
from vptoolkit.optional import EXTRAS, install_hint

PACKAGE = Path(vptoolkit.__file__).parent
DECLARED = set(tomllib.loads((REPO / "pyproject.toml").read_text())["project"][
    "optional-dependencies"])


def literal_extras() -> list[tuple[str, str]]:
    """``(where, extra)`` for every ``require(..., extra="...")`` with a literal extra."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                    and node.func.id in ("require", "install_hint")):
                continue
            for keyword in node.keywords:
                if keyword.arg == "extra" and isinstance(keyword.value, ast.Constant):
                    found.append((f"{path.relative_to(PACKAGE)}:{node.lineno}",
                                  keyword.value.value))
    return found


def test_the_source_names_some_extras():
    assert {extra for _, extra in literal_extras()} >= {"measures", "learn", "dataset"}


@pytest.mark.parametrize(("where", "extra"), literal_extras(), ids=lambda v: str(v))
def test_every_require_names_a_declared_extra(where, extra):
    assert extra in DECLARED, f"{where}: extra {extra!r} is not in pyproject.toml"


@pytest.mark.parametrize("module", sorted(EXTRAS))
def test_every_default_extra_is_declared(module):
    assert EXTRAS[module] in DECLARED
    assert install_hint(module) == f"pip install 'vptoolkit[{EXTRAS[module]}]'"


def test_a_core_dependency_is_installed_by_name():
    assert install_hint("h5py") == "pip install h5py"
