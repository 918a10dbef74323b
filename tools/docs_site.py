"""What mkdocs.yml needs beyond its plugins.

- A MkDocs hook: README.md is the site's home page and CHANGELOG.md its
  changelog page. Both live at the repository root, outside ``docs/``; their
  links into ``docs/`` become the site's paths.
- A griffe extension for the API reference, for what the docstrings take
  from Sphinx and numpydoc and griffe's numpy parser leaves as text: a role
  (``:func:`~vptoolkit.io.load_mesh```) becomes code showing the name as
  Sphinx would (``load_mesh``), and an Attributes entry documenting several
  names (``n_train, n_val : int``, as griffe already reads Parameters)
  becomes one attribute per name.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import griffe
from mkdocs.structure.files import File, Files

ROOT_PAGES = {"README.md": "index.md", "CHANGELOG.md": "changelog.md"}
"""Markdown file at the repository root: its page on the site."""


def site_markdown(text: str) -> str:
    """A root page's Markdown with its links into ``docs/`` and to the root pages rewritten."""
    text = re.sub(r"\]\(docs/", "](", text)
    for source, page in ROOT_PAGES.items():
        text = text.replace(f"]({source}", f"]({page}")
    return text


def on_files(files: Files, config: Any) -> Files:
    """MkDocs hook: add the root pages to the site's files."""
    root = Path(config.config_file_path).parent
    for source, page in ROOT_PAGES.items():
        text = (root / source).read_text(encoding="utf-8")
        files.append(File.generated(config, page, content=site_markdown(text)))
    return files


_ROLE = re.compile(r":(?:attr|class|data|exc|func|math|meth|mod|obj):`(~?)([^`]+)`")


def _role_as_code(match: re.Match[str]) -> str:
    shown = match.group(2).rsplit(".", 1)[-1] if match.group(1) else match.group(2)
    return f"`{shown}`"


def roles_as_code(text: str) -> str:
    """Each Sphinx role of ``text`` as Markdown code; ``~`` shows the last dotted part only."""
    return _ROLE.sub(_role_as_code, text)


class Numpydoc(griffe.Extension):
    """Sphinx roles as code; an Attributes entry ``a, b : type`` as one entry per name."""

    def on_instance(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = roles_as_code(obj.docstring.value)

    def on_class(self, *, cls: griffe.Class, **kwargs: Any) -> None:
        if cls.docstring is None:
            return
        for section in cls.docstring.parsed:
            if section.kind is griffe.DocstringSectionKind.attributes:
                section.value = [
                    griffe.DocstringAttribute(name=name.strip(), annotation=entry.annotation,
                                              description=entry.description)
                    for entry in section.value for name in entry.name.split(",")
                ]
