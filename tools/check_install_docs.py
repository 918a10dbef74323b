"""Check the documented install commands against pyproject.toml, so that they cannot drift.

Reads ``README.md``, ``docs/**/*.md``, ``tools/setup.sh`` and ``.ci/run`` beside
``pyproject.toml`` and checks that:

- every extra a ``pip install`` names (``'vptoolkit[learn]'``, ``'.[all,dev]'``,
  ``'vptoolkit-0.1.0-py3-none-any.whl[torch]'``) is an extra of ``pyproject.toml``;
- the README's table of extras (``| extra | brings | for |``) names exactly those extras;
- ``tools/setup.sh`` pins torch once (``torch==X``), the README names that pin, and
  every ``torch==`` pin in the docs and ``.ci/run`` is the same version;
- every documented ``pip install torch==...`` takes PyTorch's CPU index
  (:data:`CPU_INDEX`), since PyPI's Linux torch is the CUDA build;
- the docs publish with huggingface_hub's ``hf`` command, not ``huggingface-cli``.

With ``--installed`` it also checks that the installed torch is the pinned
version (CI runs it so after ``tools/setup.sh``).

Usage: ``python tools/check_install_docs.py [--installed] [ROOT]`` (ROOT: the
checkout, default the folder above ``tools/``). Exit 0 with one line on stderr,
or exit 1 with one line per problem, ``FILE:LINE: problem``.
"""

from __future__ import annotations

import argparse
import re
import sys
import tomllib
from importlib import metadata
from pathlib import Path

CPU_INDEX = "https://download.pytorch.org/whl/cpu"
"""PyTorch's own index of CPU-only wheels."""

_PIP_INSTALL = re.compile(r"pip install\s+([^`\n]*)")
_EXTRAS = re.compile(r"(?:vptoolkit|\.|\S+\.whl)\[([^\]]*)\]")
_TORCH_PIN = re.compile(r"torch==([0-9][^\s'\"`;)]*)")
_TABLE_HEADER = re.compile(r"^\|\s*extra\s*\|")
_TABLE_ROW = re.compile(r"^\|\s*`([^`]+)`\s*\|")


def _lines(path: Path, root: Path) -> list[tuple[str, str]]:
    """``("FILE:LINE", text)`` for every line of ``path``, FILE relative to ``root``."""
    name = path.relative_to(root).as_posix()
    text = path.read_text(encoding="utf-8")
    return [(f"{name}:{number}", line) for number, line in enumerate(text.splitlines(), 1)]


def install_doc_problems(root: Path) -> list[str]:
    """Every drift between the install docs and ``pyproject.toml``, one ``FILE:LINE: ...`` each.

    Parameters
    ----------
    root : Path
        The checkout (or an unpacked sdist): ``pyproject.toml``, ``README.md``,
        ``docs/``, ``tools/setup.sh`` and ``.ci/run``.

    Returns
    -------
    list of str
        Empty when the docs agree with ``pyproject.toml`` and ``tools/setup.sh``.
    """
    pyproject = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))
    extras = set(pyproject["project"].get("optional-dependencies", {}))
    readme = root / "README.md"
    docs = [readme, *sorted((root / "docs").rglob("*.md"))]
    setup, ci = root / "tools" / "setup.sh", root / ".ci" / "run"
    problems: list[str] = []

    for where, line in [entry for path in [*docs, setup, ci] for entry in _lines(path, root)]:
        for command in _PIP_INSTALL.findall(line):
            for group in _EXTRAS.findall(command):
                for extra in (part.strip() for part in group.split(",")):
                    if extra not in extras:
                        problems.append(f"{where}: extra {extra!r} is not in pyproject.toml "
                                        f"(it has {', '.join(sorted(extras))})")
            if _TORCH_PIN.search(command) and CPU_INDEX not in command and not where.startswith(
                    ("tools/", ".ci/")):
                problems.append(f"{where}: 'pip install torch==...' without --index-url "
                                f"{CPU_INDEX} installs the CUDA build on Linux")
        if "huggingface-cli" in line:
            problems.append(f"{where}: 'huggingface-cli' is replaced by huggingface_hub's "
                            "'hf' command (hf upload, hf auth login)")

    readme_lines = _lines(readme, root)
    table_at = next((i for i, (_, line) in enumerate(readme_lines)
                     if _TABLE_HEADER.match(line)), None)
    if table_at is None:
        problems.append("README.md: no table of extras ('| extra | brings | for |')")
    else:
        listed = set()
        for _, line in readme_lines[table_at + 2:]:
            row = _TABLE_ROW.match(line)
            if row is None:
                break
            listed.add(row.group(1))
        where = readme_lines[table_at][0]
        for extra in sorted(extras - listed):
            problems.append(f"{where}: the table of extras lacks {extra!r}")
        for extra in sorted(listed - extras):
            problems.append(f"{where}: the table of extras lists {extra!r}, which pyproject.toml "
                            "does not define")

    setup_pins = [(where, pin) for where, line in _lines(setup, root)
                  for pin in _TORCH_PIN.findall(line)]
    if len(setup_pins) != 1:
        problems.append(f"tools/setup.sh: expected one torch==X pin, found {len(setup_pins)}")
        return problems
    pin = setup_pins[0][1]
    readme_pins = [p for _, line in readme_lines for p in _TORCH_PIN.findall(line)]
    if not readme_pins:
        problems.append(f"README.md: names no torch pin; tools/setup.sh installs torch=={pin}")
    for where, line in [entry for path in [*docs, ci] for entry in _lines(path, root)]:
        for other in _TORCH_PIN.findall(line):
            if other != pin:
                problems.append(f"{where}: torch=={other}, but tools/setup.sh installs "
                                f"torch=={pin}")
    return problems


def installed_torch_problems(root: Path) -> list[str]:
    """A problem when the installed torch is not the version ``tools/setup.sh`` pins."""
    setup = root / "tools" / "setup.sh"
    pins = _TORCH_PIN.findall(setup.read_text(encoding="utf-8"))
    try:
        version = metadata.version("torch")
    except metadata.PackageNotFoundError:
        return [f"torch: not installed; tools/setup.sh installs torch=={pins[0]}"]
    if version.split("+")[0] != pins[0]:
        return [f"torch: {version} is installed, but tools/setup.sh pins torch=={pins[0]}"]
    return []


def main(argv: list[str] | None = None) -> int:
    """Print the problems (stdout) or a summary (stderr); return the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", nargs="?", type=Path, default=Path(__file__).resolve().parents[1],
                        help="the checkout (default: the folder above tools/)")
    parser.add_argument("--installed", action="store_true",
                        help="also check that the installed torch is the pinned version")
    arguments = parser.parse_args(argv)
    root = arguments.root
    problems = install_doc_problems(root)
    if arguments.installed and not problems:
        problems = installed_torch_problems(root)
    for problem in problems:
        print(problem)
    if problems:
        return 1
    print("check_install_docs: the install docs agree with pyproject.toml and tools/setup.sh",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
