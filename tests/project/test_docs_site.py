"""The documentation site's sources: mkdocs.yml's nav, the root pages' links, tools/docs_site.py.

CI builds the site itself (``mkdocs build --strict`` in ``.ci/run``); these
checks are the fast part of it.
"""

from __future__ import annotations

import re

import pytest

from fixtures.environment import require_package
from fixtures.paths import REPO

DOCS = REPO / "docs"
_LINK = re.compile(r"\]\(([^)\s]+)\)")


@pytest.fixture(scope="module")
def docs_site():
    require_package("mkdocs")
    require_package("griffe")
    import docs_site

    return docs_site


def _nav_pages(entry) -> list[str]:
    if isinstance(entry, str):
        return [entry]
    if isinstance(entry, list):
        return [page for item in entry for page in _nav_pages(item)]
    return [page for value in entry.values() for page in _nav_pages(value)]


def test_nav_lists_every_page_once(docs_site):
    import yaml

    config = yaml.safe_load((REPO / "mkdocs.yml").read_text(encoding="utf-8"))
    listed = _nav_pages(config["nav"])
    pages = sorted(path.relative_to(DOCS).as_posix() for path in DOCS.rglob("*.md"))
    assert sorted(listed) == sorted(pages + list(docs_site.ROOT_PAGES.values()))


@pytest.mark.parametrize("source", ["README.md", "CHANGELOG.md"])
def test_root_page_links_reach_site_pages(docs_site, source):
    text = docs_site.site_markdown((REPO / source).read_text(encoding="utf-8"))
    targets = [link.split("#")[0] for link in _LINK.findall(text)
               if "://" not in link and not link.startswith(("#", "mailto:"))]
    site_pages = set(docs_site.ROOT_PAGES.values())
    broken = [t for t in targets if t not in site_pages and not (DOCS / t).is_file()]
    assert not broken, f"{source}: links that leave the site: {broken}"
    if source == "README.md":
        assert "guide/best-view.md" in targets and "changelog.md" in targets


def test_site_markdown_rewrites_links_only(docs_site):
    text = "See [the guide](docs/guide/x.md#a), [changes](CHANGELOG.md) and `docs/guide/x.md`."
    assert docs_site.site_markdown(text) == (
        "See [the guide](guide/x.md#a), [changes](changelog.md) and `docs/guide/x.md`."
    )


@pytest.mark.parametrize(("docstring", "markdown"), [
    (":func:`~vptoolkit.io.load_mesh` reads", "`load_mesh` reads"),
    (":class:`vptoolkit.mesh.Mesh`", "`vptoolkit.mesh.Mesh`"),
    (":math:`C_{in}` and :attr:`mean`", "`C_{in}` and `mean`"),
    ("``plain`` stays", "``plain`` stays"),
])
def test_roles_become_code(docs_site, docstring, markdown):
    assert docs_site.roles_as_code(docstring) == markdown


def test_attribute_entry_of_several_names_becomes_one_per_name(docs_site, tmp_path):
    import griffe

    (tmp_path / "bounds.py").write_text('''
class Bounds:
    """A range.

    Attributes
    ----------
    low, high : float
        The ends, as :func:`~numpy.clip` takes them.
    """
''', encoding="utf-8")
    module = griffe.load("bounds", search_paths=[tmp_path], docstring_parser="numpy",
                         extensions=griffe.load_extensions(docs_site.Numpydoc))
    sections = module["Bounds"].docstring.parsed
    (attributes,) = [s for s in sections if s.kind is griffe.DocstringSectionKind.attributes]
    assert [entry.name for entry in attributes.value] == ["low", "high"]
    assert {entry.description for entry in attributes.value} == {"The ends, as `clip` takes them."}
