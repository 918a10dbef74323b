"""The static HTML report of a dataset.

The report is opened in a real headless Chromium (Debian's ``chromium``),
driven over the DevTools protocol on a pipe (``--remote-debugging-pipe``,
NUL-separated JSON; no browser download, no websocket package): the page
must load without console errors, show every model, and filter by category
and split, also from the address (``#category=...&split=...``). The browser
test skips when chromium is absent, or fails with ``VPTOOLKIT_REQUIRE_ALL=1``.
"""

from __future__ import annotations

import base64
import hashlib
import html
import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fixtures.browser import Chromium, Page
from fixtures.environment import require_package
from fixtures.meshes import primitive_mesh
from fixtures.pictures import (
    decode_png,
    model_mask,
    preferred_directions,
    read_png,
    smooth_quality,
    started_renderer,
)
from vptoolkit.errors import InputError
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.mesh import Mesh
from vptoolkit.sphere import fibonacci_sphere

N_VIEWS = 200
SIZE = 96
# (category, name, split, trimesh primitive), in (category, name) order.
MODELS = [
    ("box", "box_a", "train", ("box", {"extents": (1.0, 1.0, 1.0)})),
    ("box", "box_b", "test", ("box", {"extents": (2.0, 1.0, 0.5)})),
    ("round", "ball", "train", ("icosphere", {"subdivisions": 2})),
    ("round", "capsule", "test", ("capsule", {"height": 1.0, "radius": 0.4})),
    ("round", "mug & 'co' <1>", "val", ("cylinder", {"radius": 0.5, "height": 1.0})),
    ("thin", "cone", "val", ("cone", {"radius": 0.5, "height": 1.5})),
]
BUILD = {
    "resolution": 64,
    "backend": "raster",
    "camera": {"fov_deg": 45.0, "distance_factor": 1.4142, "up": [0.0, -1.0, 0.0]},
    "cleaning": {"enabled": False},
    "split_seed": 0,
    "split_fractions": {"train": 0.6, "val": 0.2, "test": 0.2},
    "source": "trimesh primitives",
    "toolkit_version": "0.1.0",
    "created": "2025-01-01T00:00:00+00:00",
}


def write_store(path: Path, build: dict[str, Any] = BUILD) -> Path:
    """A small dataset store of trimesh primitives with made-up smooth quality."""
    require_package("zarr")
    from vptoolkit.dataset.store.schema import ModelEntry
    from vptoolkit.dataset.store.writer import write_dataset

    views = fibonacci_sphere(N_VIEWS)
    entries = []
    for category, name, split, (kind, options) in MODELS:
        mesh = primitive_mesh(kind, options, name)
        quality = smooth_quality(views, preferred_directions(name))
        best = np.argmax(quality, axis=0)
        worst = np.argmin(quality, axis=0)
        rng = np.random.default_rng(len(name))
        normals = rng.normal(size=(32, 3))
        entries.append(ModelEntry(
            name=name, category=category, split=split, source=f"{category}/{name}.off",
            source_sha256=hashlib.sha256(name.encode()).hexdigest(),
            points=rng.normal(size=(32, 3)),
            normals=normals / np.linalg.norm(normals, axis=1, keepdims=True),
            quality=quality, quality_raw=quality, best_index=best,
            best_value=quality[best, np.arange(4)], worst_index=worst,
            worst_value=quality[worst, np.arange(4)],
            vertices=mesh.vertices, faces=mesh.faces,
        ))
    failures = [{"source": "box/broken <b>.off", "category": "box", "reason": "no faces"}]
    return write_dataset(path, entries, attrs=build, views=views, failures=failures)


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_store(tmp_path_factory.mktemp("store") / "dataset.zarr")


@pytest.fixture(scope="module")
def report_renderer():
    from vptoolkit.camera import Camera

    yield from started_renderer(SIZE, camera=Camera.from_dict(BUILD["camera"]))


@pytest.fixture(scope="module")
def full_report(store, report_renderer, matplotlib_available, tmp_path_factory) -> Path:
    from vptoolkit.pictures.report import write_report

    return write_report(store, tmp_path_factory.mktemp("report") / "all", engine=report_renderer)


@pytest.fixture(scope="module")
def predictions(store, tmp_path_factory) -> tuple[Path, np.ndarray]:
    """Predictions for the test split: box_b exactly right, capsule off; no VMI."""
    from vptoolkit.predictions import write_predictions as save_predictions

    views = fibonacci_sphere(N_VIEWS)
    directions = np.zeros((2, 3, 3))
    directions[0] = views[np.argmax(smooth_quality(views, preferred_directions("box_b")),
                                    axis=0)[:3]]
    directions[1] = [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.2]]
    path = tmp_path_factory.mktemp("predictions") / "predictions.npz"
    save_predictions(path, ["box_b", "capsule"], directions, measures=PAPER_MEASURES[:3])
    return path, directions


@pytest.fixture(scope="module")
def test_report(store, predictions, report_renderer, matplotlib_available,
                tmp_path_factory) -> Path:
    from vptoolkit.pictures.report import write_report

    return write_report(store, tmp_path_factory.mktemp("report") / "test", split="test",
                        predictions=predictions[0], engine=report_renderer)


def image_sources(page: str) -> list[str]:
    return [html.unescape(src) for src in re.findall(r'<img [^>]*src="([^"]+)"', page)]


def cards(page: str) -> list[dict[str, str]]:
    found = re.findall(r'<article class="card" [^>]*data-name="([^"]*)" '
                       r'data-category="([^"]*)" data-split="([^"]*)"', page)
    return [{"name": html.unescape(n), "category": c, "split": s} for n, c, s in found]


@pytest.mark.renderer
def test_report_has_a_card_and_pictures_for_every_model(full_report: Path):
    page = full_report.read_text(encoding="utf-8")
    assert full_report.name == "index.html"
    from vptoolkit.dataset.store.schema import published_split

    assert cards(page) == [{"name": n, "category": c, "split": published_split(s)}
                           for c, n, s, _ in MODELS]
    assert "mug &amp; &#x27;co&#x27; &lt;1&gt;" in page and "<1>" not in page
    sources = image_sources(page)
    n_set = len(re.findall(r'alt="[^"]*, view \d+ of its set"', page))
    assert n_set >= len(MODELS)  # each model's view set has a picture per view
    # four views and the maps
    assert len(sources) == len(MODELS) * (len(PAPER_MEASURES) + 1) + n_set
    for source in sources:
        assert not source.startswith(("/", "http")), source
        image = read_png(full_report.parent / source)
        if source.startswith("thumbs/"):
            assert image.shape == (SIZE, SIZE, 3) and model_mask(image).any()
    assert "1 source files were not built" in page and "box/broken &lt;b&gt;.off" in page


@pytest.mark.renderer
def test_report_thumbnails_are_the_best_views(full_report: Path, store, report_renderer):
    from vptoolkit.data import open_dataset

    page = full_report.read_text(encoding="utf-8")
    with open_dataset(store) as dataset:
        item = dataset["box_b"]
        vertices, faces = dataset.mesh("box_b")
        mesh = Mesh(vertices.astype(np.float64), faces.astype(np.int64), "box_b")
        index = int(item["best_index"][1])
        expected = report_renderer.render(mesh, dataset.views[index])[0]
    source = f"thumbs/00001-box_b-v{index}.png"
    assert f'src="{source}"' in page and f"VR · view {index} of {N_VIEWS}" in page
    np.testing.assert_array_equal(decode_png((full_report.parent / source).read_bytes()),
                                  expected)


def test_summary_table_counts_models_per_category_and_split(full_report: Path):
    table = re.search(r'<table class="summary".*?</table>', full_report.read_text("utf-8"),
                      re.S).group(0)
    rows = re.findall(r"<tr[^>]*><td>([^<]*)</td>((?:<td>[^<]*</td>)*)</tr>", table)
    counts = {label: re.findall(r"<td>([^<]*)</td>", cells) for label, cells in rows}
    # category: models, train, val, test
    assert counts == {"box": ["2", "1", "0", "1"], "round": ["3", "1", "1", "1"],
                      "thin": ["1", "0", "1", "0"], "all": ["6", "2", "2", "2"]}


@pytest.mark.renderer
def test_report_with_predictions_shows_their_scores(test_report: Path, store, predictions):
    from vptoolkit.evaluate.scores import evaluate_predictions

    page = test_report.read_text(encoding="utf-8")
    assert [card["name"] for card in cards(page)] == ["box_b", "capsule"]
    report = evaluate_predictions(store, predictions[0], split="test")
    for row, name in enumerate(report.names):
        card = re.search(rf'data-name="{name}".*?</article>', page, re.S).group(0)
        scores = re.findall(r'<span class="score">([^<]*)</span>', card)
        expected = [f"{v:.1f} %" for v in report.scores[row, :3]] + ["not predicted"]
        assert scores == expected
        assert f"thumbs/{row:05d}-{name}-pred-VE.png" in card
        assert "pred-VMI" not in card
    assert report.scores[0, :3].tolist() == [100.0, 100.0, 100.0]
    mean_row = re.search(r'<tr class="mean">.*?</tr>', page).group(0)
    assert f"<td>{report.mean[0]:.1f}</td>" in mean_row


def test_report_without_pictures_needs_no_renderer(store, matplotlib_available, tmp_path: Path,
                                                   monkeypatch):
    from vptoolkit.pictures.report import write_report

    for variable in ("VK_ICD_FILENAMES", "VK_DRIVER_FILES"):
        monkeypatch.setenv(variable, "/nonexistent/vptoolkit-test-icd.json")
    index = write_report(store, tmp_path / "maps", split="val", thumbnails=False)
    page = index.read_text(encoding="utf-8")
    assert [card["name"] for card in cards(page)] == ["mug & 'co' <1>", "cone"]
    assert image_sources(page) == ["maps/00000-mug_co_1_.png", "maps/00001-cone.png"]
    assert not (tmp_path / "maps" / "thumbs").exists() or not any(
        (tmp_path / "maps" / "thumbs").iterdir())


def test_report_draws_through_the_camera_of_the_dataset(matplotlib_available,
                                                       tmp_path: Path) -> None:
    from vptoolkit.camera import Camera
    from vptoolkit.data import open_dataset
    from vptoolkit.pictures.engine import open_renderer
    from vptoolkit.pictures.report import REPORT_SIZE, write_report

    camera = Camera(fov_deg=60.0, distance_factor=1.2, up=(0.0, 0.0, 1.0),
                    fallback_up=(0.0, 1.0, 0.0))
    store = write_store(tmp_path / "dataset.zarr", {**BUILD, "camera": camera.to_dict()})
    index = write_report(store, tmp_path / "report", split="val", view_set=None)
    page = index.read_text(encoding="utf-8")
    assert "field of view 60°, distance 1.200 bounding-box diagonals, image up (0.0, 0.0, 1.0)" \
        in page
    with open_dataset(store) as dataset:
        assert dataset.camera == camera
        vertices, faces = dataset.mesh("cone")
        view = int(dataset["cone"]["best_index"][0])
        direction = dataset.views[view]
    mesh = Mesh(vertices.astype(np.float64), faces.astype(np.int64), "cone")
    drawn = decode_png((tmp_path / "report" / f"thumbs/00001-cone-v{view}.png").read_bytes())
    with open_renderer(size=REPORT_SIZE, camera=camera) as through_it, \
            open_renderer(size=REPORT_SIZE) as through_the_default:
        np.testing.assert_array_equal(drawn, through_it.render(mesh, direction)[0])
        assert not np.array_equal(drawn, through_the_default.render(mesh, direction)[0])
        with pytest.raises(InputError, match="camera differs from the camera of the measures"):
            write_report(store, tmp_path / "other", split="val", view_set=None,
                         engine=through_the_default)


def test_report_rejects_an_unknown_split_and_unfit_predictions(store, predictions, tmp_path):
    from vptoolkit.pictures.report import write_report

    with pytest.raises(InputError, match="unknown split 'tset'"):
        write_report(store, tmp_path / "r", split="tset", thumbnails=False)
    with pytest.raises(InputError, match="predictions.npz"):
        write_report(store, tmp_path / "r", split="train", predictions=predictions[0],
                     thumbnails=False)
    assert not (tmp_path / "r" / "index.html").exists()


VISIBLE_NAMES = """
Array.prototype.filter.call(document.querySelectorAll("article.card"),
    function (card) { return card.offsetParent !== null; })
  .map(function (card) { return card.dataset.name; })
"""


def choose(select_id: str, value: str) -> str:
    """Script: pick an option of a filter as a user would (value, then a change event)."""
    return (f'(function () {{ var s = document.getElementById("{select_id}"); '
            f's.value = {json.dumps(value)}; s.dispatchEvent(new Event("change")); '
            f"return [window.location.hash, document.getElementById('shown-count').textContent]; "
            "}())")


@pytest.mark.renderer
def test_report_in_headless_chromium(chromium: Chromium, full_report: Path, tmp_path: Path):
    names = [name for _, name, _, _ in MODELS]
    url = full_report.resolve().as_uri()
    page = Page(chromium)
    page.open(url)
    assert page.evaluate("document.readyState") == "complete"
    assert page.evaluate(VISIBLE_NAMES) == names  # every model shown
    broken = page.evaluate(
        "Array.prototype.filter.call(document.images, function (i) { return i.loading !== "
        "'lazy' && !(i.complete && i.naturalWidth > 0); }).map(function (i) { return i.src; })")
    assert broken == []
    n_set = page.evaluate("document.querySelectorAll('.view-set img').length")
    assert n_set >= len(MODELS)  # a picture per view of each model's view set
    assert page.evaluate("document.images.length") == len(MODELS) * 5 + n_set

    assert page.evaluate(choose("filter-category", "round")) == [
        "#category=round", "3 of 6 models shown"]
    assert page.evaluate(VISIBLE_NAMES) == ["ball", "capsule", "mug & 'co' <1>"]
    assert page.evaluate(choose("filter-split", "test"))[0] == "#category=round&split=test"
    assert page.evaluate(VISIBLE_NAMES) == ["capsule"]
    page.evaluate(choose("filter-category", ""))
    assert page.evaluate(VISIBLE_NAMES) == ["box_b", "capsule"]
    page.evaluate(choose("filter-split", ""))
    assert page.evaluate(VISIBLE_NAMES) == names
    assert page.errors() == []

    page.open(url + "#category=thin&split=val")  # a shared link opens filtered
    assert page.evaluate(VISIBLE_NAMES) == ["cone"]
    assert page.evaluate("document.getElementById('filter-category').value") == "thin"
    page.open(url + "#category=nonsense")  # an unknown value falls back to all
    assert page.evaluate(VISIBLE_NAMES) == names
    shot = page.call("Page.captureScreenshot", {"format": "png"})["data"]
    (tmp_path / "report.png").write_bytes(base64.b64decode(shot))
    assert read_png(tmp_path / "report.png").shape[2] in (3, 4)
    assert page.errors() == []
