"""A browsable HTML index of a folder of thumbnails, a page at a time.

:func:`write_thumbnail_index` writes ``index.html`` and, past
:data:`PAGE_SIZE` pictures, ``index-2.html``, ``index-3.html`` and so on
beside the pictures: static pages, no script, each a grid of captioned
pictures linked to their files, with links to the other pages. Every
``<img>`` has ``loading="lazy"`` and its size, so a browser fetches only
the pictures near the screen and lays a page out before any arrives: a
folder of 10^4 thumbnails opens as fast as one of a hundred. Paths are
relative, so the folder can be moved or served as it is.
"""

from __future__ import annotations

import html
import re
from collections.abc import Sequence
from pathlib import Path
from urllib.parse import quote

from vptoolkit.checks import check_int
from vptoolkit.files import atomic_write

__all__ = ["PAGE_SIZE", "ThumbnailCard", "index_page_name", "write_thumbnail_index"]

PAGE_SIZE = 200
"""Pictures on one page of the index."""

ThumbnailCard = tuple[str, str, str]
"""One picture of the index: ``(source, image, label)``, the model's key, the
picture's path relative to the folder (POSIX separators) and a caption line."""

_PAGE = re.compile(r"index(-[0-9]+)?\.html")

_STYLE = """
body { font: 14px/1.4 system-ui, sans-serif; margin: 1.5em; color: #1d2430; }
nav { margin: 1em 0; } nav a, nav strong { margin-right: 0.6em; }
main { display: grid; grid-template-columns: repeat(auto-fill, minmax(%dpx, 1fr)); gap: 12px; }
figure { margin: 0; } img { display: block; width: 100%%; height: auto; background: #f4f5f7; }
figcaption { font-size: 12px; overflow-wrap: anywhere; }
figcaption span { color: #6b7380; }
"""


def index_page_name(page: int) -> str:
    """File name of page ``page`` (1-based): ``index.html``, ``index-2.html``, ..."""
    return "index.html" if page == 1 else f"index-{page}.html"


def write_thumbnail_index(folder: str | Path, cards: Sequence[ThumbnailCard], *, size: int,
                          title: str, page_size: int = PAGE_SIZE) -> list[Path]:
    """Write the index pages of a folder's thumbnails; remove pages left from a larger run.

    Parameters
    ----------
    folder : str or Path
        The folder of the pictures, where the pages go.
    cards : sequence of ThumbnailCard
        The pictures in the order shown.
    size : int
        Side of the pictures in pixels (the grid's column width and each
        ``<img>``'s ``width`` and ``height``, so nothing moves as they load).
    title : str
        Heading of every page.
    page_size : int
        Pictures per page (default: :data:`PAGE_SIZE`, 200).

    Returns
    -------
    pages : list of Path
        The pages written, the first ``index.html`` (written even for no pictures).
    """
    folder = Path(folder)
    size = check_int(size, "size", minimum=1)
    page_size = check_int(page_size, "page_size", minimum=1)
    n_pages = max(1, -(-len(cards) // page_size))
    pages = []
    for page in range(1, n_pages + 1):
        first = (page - 1) * page_size
        shown = cards[first:first + page_size]
        path = folder / index_page_name(page)
        text = _page_html(shown, page, n_pages, first, len(cards), size, title)
        with atomic_write(path) as stream:
            stream.write(text.encode())
        pages.append(path)
    written = {path.name for path in pages}
    for stale in folder.glob("index-*.html"):
        if _PAGE.fullmatch(stale.name) and stale.name not in written:
            stale.unlink()
    return pages


def _navigation(page: int, n_pages: int) -> str:
    """Links to the previous, every and the next page, the current one in bold."""
    if n_pages == 1:
        return ""
    links = []
    if page > 1:
        links.append(f'<a href="{index_page_name(page - 1)}" rel="prev">&larr; previous</a>')
    for other in range(1, n_pages + 1):
        links.append(f"<strong>{other}</strong>" if other == page
                     else f'<a href="{index_page_name(other)}">{other}</a>')
    if page < n_pages:
        links.append(f'<a href="{index_page_name(page + 1)}" rel="next">next &rarr;</a>')
    return "<nav>" + " ".join(links) + "</nav>"


def _page_html(cards: Sequence[ThumbnailCard], page: int, n_pages: int, first: int, total: int,
               size: int, title: str) -> str:
    """One page of the index."""
    figures = []
    for source, image, label in cards:
        link = html.escape(quote(image), quote=True)
        figures.append(
            f'<figure><a href="{link}"><img src="{link}" loading="lazy" decoding="async" '
            f'width="{size}" height="{size}" alt="{html.escape(source, quote=True)}"></a>'
            f"<figcaption>{html.escape(source)}<br><span>{html.escape(label)}</span>"
            "</figcaption></figure>")
    shown = (f"pictures {first + 1} to {first + len(cards)} of {total}" if cards
             else "no pictures")
    navigation = _navigation(page, n_pages)
    return (
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        f"<title>{html.escape(title)} ({page} of {n_pages})</title>"
        "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
        f"<style>{_STYLE % min(size, 256)}</style></head>\n<body>"
        f"<h1>{html.escape(title)}</h1><p id=\"shown\">{shown}, page {page} of {n_pages}</p>"
        f"{navigation}\n<main>\n" + "\n".join(figures) + f"\n</main>\n{navigation}</body></html>\n"
    )
