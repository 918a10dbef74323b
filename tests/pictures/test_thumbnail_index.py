"""The HTML index of a folder of thumbnails: pages, escaping, lazy pictures in a real browser."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from fixtures.browser import Chromium, Page
from vptoolkit.pictures.png import png_bytes
from vptoolkit.pictures.thumbnail_index import index_page_name, write_thumbnail_index


def cards(n: int) -> list[tuple[str, str, str]]:
    return [(f"models/m{i:05d}.off", f"models/m{i:05d}.off.png", "best VE (view 3)")
            for i in range(n)]


def test_pages_hold_page_size_lazy_pictures_and_link_each_other(tmp_path: Path):
    pages = write_thumbnail_index(tmp_path, cards(450), size=96, title="Thumbnails",
                                  page_size=200)
    assert [p.name for p in pages] == ["index.html", "index-2.html", "index-3.html"]
    first = pages[0].read_text()
    images = re.findall(r"<img [^>]*>", first)
    assert len(images) == 200 and all('loading="lazy"' in tag for tag in images)
    assert 'width="96" height="96"' in images[0]
    assert "pictures 1 to 200 of 450, page 1 of 3" in first
    assert 'href="index-3.html"' in first and 'rel="next"' in first
    last = pages[2].read_text()
    assert len(re.findall(r"<img ", last)) == 50 and 'rel="prev"' in last
    assert index_page_name(1) == "index.html" and index_page_name(7) == "index-7.html"

    (tmp_path / "index-notes.html").write_text("kept")
    fewer = write_thumbnail_index(tmp_path, cards(5), size=96, title="Thumbnails")
    assert [p.name for p in fewer] == ["index.html"]  # pages of the larger run are gone
    assert sorted(p.name for p in tmp_path.glob("index*.html")) == ["index-notes.html",
                                                                    "index.html"]
    assert "<nav>" not in fewer[0].read_text()


def test_names_are_escaped_and_paths_quoted(tmp_path: Path):
    page = write_thumbnail_index(tmp_path, [('a <b> & "c".off', 'a <b> & "c".off.png', "<x>")],
                                 size=64, title="<T>")[0].read_text()
    assert "<b>" not in page and "&lt;b&gt; &amp; &quot;c&quot;.off" in page
    assert 'src="a%20%3Cb%3E%20%26%20%22c%22.off.png"' in page and "&lt;T&gt;" in page
    empty = write_thumbnail_index(tmp_path, [], size=64, title="none")[0].read_text()
    assert "no pictures, page 1 of 1" in empty


WAIT_FOR = """new Promise(function (done) {{
  var start = Date.now();
  (function poll() {{
    if ({condition}) {{ done(true); }}
    else if (Date.now() - start > 20000) {{ done(false); }}
    else {{ setTimeout(poll, 50); }}
  }}());
}})"""

LOADED = ("Array.prototype.filter.call(document.images, function (i) "
          "{ return i.complete && i.naturalWidth > 0; }).length")


@pytest.mark.renderer
def test_ten_thousand_thumbnails_open_a_page_at_a_time_and_load_lazily(chromium: Chromium,
                                                                       tmp_path: Path):
    n_models = 10_000
    picture = png_bytes(np.full((256, 256, 3), (230, 200, 40), dtype=np.uint8))
    (tmp_path / "models").mkdir()
    for _, image, _ in cards(n_models):
        (tmp_path / image).write_bytes(picture)
    pages = write_thumbnail_index(tmp_path, cards(n_models), size=256, title="Thumbnails")
    assert len(pages) == n_models // 200

    page = Page(chromium)
    page.open(pages[0].resolve().as_uri())
    assert page.evaluate("document.getElementById('shown').textContent") == \
        "pictures 1 to 200 of 10000, page 1 of 50"
    assert page.evaluate("document.images.length") == 200
    assert page.evaluate(WAIT_FOR.format(condition="document.images[0].naturalWidth > 0"))
    loaded = page.evaluate(LOADED)
    assert 0 < loaded < 100, loaded  # the first screens only, not the whole page
    assert page.evaluate("document.images[199].naturalWidth") == 0
    page.evaluate("window.scrollTo(0, document.body.scrollHeight)")
    assert page.evaluate(WAIT_FOR.format(condition="document.images[199].naturalWidth > 0"))
    assert page.evaluate("document.images[199].alt") == "models/m00199.off"
    page.open(pages[-1].resolve().as_uri())
    assert page.evaluate("document.querySelector('figure img').alt") == "models/m09800.off"
    assert page.errors() == []
