"""docs/architecture.md names every module of the package, so the map cannot fall behind."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import vptoolkit

PACKAGE = Path(vptoolkit.__file__).parent
ARCHITECTURE = PACKAGE.parent / "docs" / "architecture.md"


def _layout_paragraphs() -> list[str]:
    text = ARCHITECTURE.read_text(encoding="utf-8")
    section = text.split("\n## Layout\n", 1)[1].split("\n## ", 1)[0]
    return section.split("\n\n")


def _named(module: Path, paragraphs: list[str]) -> bool:
    """Whether the Layout names ``module``: by its path, or by its name under its package."""
    parts = module.relative_to(PACKAGE).with_suffix("").parts
    if len(parts) == 1:
        return any(f"`{parts[0]}`" in paragraph for paragraph in paragraphs)
    package, name = "/".join(parts[:-1]), parts[-1]
    if any(f"`{package}/{name}`" in paragraph for paragraph in paragraphs):
        return True
    in_package = [p for p in paragraphs if f"`{package}/" in p or f"(`{package}/`)" in p]
    if name == "__init__":
        return bool(in_package)
    return any(f"`{name}`" in paragraph for paragraph in in_package)


def test_layout_names_every_module():
    paragraphs = _layout_paragraphs()
    missing = [str(path.relative_to(PACKAGE)) for path in sorted(PACKAGE.rglob("*.py"))
               if not _named(path, paragraphs)]
    assert not missing, f"docs/architecture.md's Layout section does not name: {', '.join(missing)}"


def _package_parts(package: Path) -> list[str]:
    """The modules of ``package`` and its subpackages, by name (``__init__`` left out)."""
    modules = [path.stem for path in package.glob("*.py") if path.name != "__init__.py"]
    subpackages = [path.name for path in package.iterdir() if (path / "__init__.py").is_file()]
    return sorted(modules + subpackages)


def _names_in(docstring: str, name: str) -> bool:
    """Whether ``docstring`` names ``name`` in backticks, alone or as ``pkg.name``."""
    return re.search(rf"[`.~]{re.escape(name)}`", docstring) is not None


def test_package_docstrings_name_every_module():
    # A package whose docstring lists its modules lists all of them, private ones included,
    # so a new module cannot be left out of the map; packages that list none are skipped.
    missing = []
    for init in sorted(PACKAGE.rglob("__init__.py")):
        docstring = ast.get_docstring(ast.parse(init.read_text(encoding="utf-8"))) or ""
        parts = _package_parts(init.parent)
        if not any(_names_in(docstring, name) for name in parts):
            continue
        missing += [f"{init.parent.relative_to(PACKAGE.parent).as_posix()}: {name}"
                    for name in parts if not _names_in(docstring, name)]
    assert not missing, f"package docstrings do not name: {', '.join(missing)}"
