"""A static HTML report of a dataset's models and their viewpoint quality.

:func:`write_report` writes ``index.html`` and its pictures into a folder
that any browser opens from disk (no server, no network, no external
script): one card per model with a picture from the best view of each
measure, the quality maps (:func:`vptoolkit.pictures.sphere_panels.sphere_maps`),
the scores of predictions if given, filters by category and split (also
settable in the address, e.g. ``index.html#category=chair&split=test``)
and a summary table per category. The measures are those the dataset
records (:attr:`ViewpointDataset.measures
<vptoolkit.data.ViewpointDataset.measures>`: the paper's four unless it
was built with others), in its order.
"""

from __future__ import annotations

import html
import os
import re
from collections import Counter
from collections.abc import Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm import tqdm

from vptoolkit.camera import Camera
from vptoolkit.checks import as_path, check_int, one_line
from vptoolkit.conventions import Split
from vptoolkit.errors import InputError, VptoolkitError
from vptoolkit.files import write_text_atomic
from vptoolkit.mesh import Mesh
from vptoolkit.pictures.engine import Engine, drawing_engine
from vptoolkit.pictures.png import save_png

__all__ = ["write_report"]

REPORT_SIZE = 256
"""Side in pixels of a report's pictures unless one is given."""

_MAP_DPI = 80  # a row of four maps is 960 x 272 pixels


_SAFE = re.compile(r"[^A-Za-z0-9._-]+")


def _slug(position: int, name: str) -> str:
    """A file-name-safe, unique stem for a model's pictures."""
    return f"{position:05d}-{_SAFE.sub('_', name)[:80]}"


@dataclass
class _Card:
    name: str
    category: str
    split: str
    slug: str
    n_faces: int
    best_index: list[int]
    best_images: list[str | None]
    sphere_map: str
    map_size: tuple[int, int] = (0, 0)
    predicted_images: list[str | None] | None = None
    scores: list[float] | None = None
    view_set: list[int] = field(default_factory=list)
    view_set_coverage: list[float] = field(default_factory=list)
    view_set_images: list[str | None] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)


def _model_mesh(dataset: Any, position: int, name: str) -> Mesh:
    vertices, faces = dataset.mesh(position)
    return Mesh(vertices.astype(np.float64), faces.astype(np.int64), name)


def write_report(
    dataset: Any,
    out_dir: str | os.PathLike[str],
    *,
    split: Split = None,
    predictions: str | os.PathLike[str] | None = None,
    thumbnails: bool = True,
    engine: Engine | None = None,
    progress: bool = False,
    view_set: int | None = 4,
) -> Path:
    """Write a static HTML report of a dataset's models and viewpoint quality.

    The folder gets ``index.html`` (inline CSS and script, nothing
    external), ``thumbs/`` (one PNG per distinct best view, and per
    predicted view) and ``maps/`` (one PNG of the Mercator quality maps of
    every measure the dataset records, four to a row, per model). Each
    model's card shows its name, category, split and face count, its
    pictures from the best view of each recorded measure (VE, VR, VKL and
    VMI for the paper's four), the maps
    with the best view starred and the prediction crossed, and, with
    predictions, the pictures from the predicted views and their scores (the
    normalised quality of the nearest sampled view, in percent, as
    :func:`vptoolkit.evaluate.scores.score_directions` computes them). The summary
    table counts the models per category and split and, with predictions,
    gives the mean score per category and the mean over categories (the
    paper's table 2). A model whose pictures cannot be drawn keeps its card,
    with the reason. ``index.html`` is replaced last and atomically.

    Parameters
    ----------
    dataset : ViewpointDataset or path-like
        An open dataset (:func:`vptoolkit.data.open_dataset`) or a store path.
    out_dir : path-like
        Output folder, created if needed; files of an earlier report there
        are overwritten.
    split : str, optional
        Report only ``"train"``, ``"val"`` or ``"test"`` (default: all models).
    predictions : path-like, optional
        A predictions ``.npz``/``.npy`` naming each reported model (see
        :func:`vptoolkit.evaluate.scores.load_predictions`).
    thumbnails : bool
        Draw the pictures (default: True); False writes maps and tables
        only and needs no engine.
    engine : Engine, optional
        The engine that draws the pictures (its size and style apply), left
        open; its camera must be the dataset's (:attr:`ViewpointDataset.camera
        <vptoolkit.data.ViewpointDataset.camera>`, the camera the measures
        used). Default: a software engine of :data:`REPORT_SIZE` pixels with
        that camera, made for this call.
    progress : bool
        Show a progress bar on stderr (default: False).
    view_set : int or None
        Views in each model's coverage view set (:mod:`vptoolkit.view_sets`,
        default: 4), drawn as a row of pictures captioned with the coverage
        reached and marked on the maps as numbered circles; None leaves it
        out. The set is searched over the dataset's views, from pixel counts
        of the stored mesh at the dataset's resolution.

    Returns
    -------
    index : pathlib.Path
        ``out_dir/index.html``.

    Raises
    ------
    InputError
        For an unknown split, a split without models, a predictions file
        that does not fit the reported models, or an engine whose camera is
        not the dataset's.
    MissingDependencyError
        If matplotlib is missing, or ``thumbnails`` is set and the engine
        cannot start here (checked before any work).
    """
    from vptoolkit.data import ViewpointDataset, open_dataset

    if not isinstance(dataset, ViewpointDataset):
        with open_dataset(dataset) as opened:
            return write_report(
                opened, out_dir, split=split, predictions=predictions, thumbnails=thumbnails,
                engine=engine, progress=progress, view_set=view_set,
            )
    from vptoolkit.evaluate.scores import load_predictions, score_directions
    from vptoolkit.optional import require
    from vptoolkit.pictures.sphere_map import save_figure
    from vptoolkit.pictures.sphere_panels import sphere_maps

    require("matplotlib")
    target = as_path(out_dir, "out_dir")
    if view_set is not None:
        view_set = check_int(view_set, "view_set", minimum=1)
    selected = dataset if split is None else dataset.split(split)
    if len(selected) == 0:
        where = f"split {split!r} of " if split else ""
        raise InputError(f"{where}{dataset.path.name}: no models to report")
    predicted: NDArray[np.float64] | None = None
    evaluation = None
    if predictions is not None:
        _, predicted = load_predictions(predictions, selected)
        evaluation = score_directions(selected, predicted, split=split,
                                      predictions=Path(predictions).name)
    for folder in (target, target / "thumbs", target / "maps"):
        folder.mkdir(parents=True, exist_ok=True)

    views = selected.views
    measures = selected.measures
    names = selected.names
    categories = selected.categories
    splits = selected.splits
    records = selected.records
    camera = selected.camera
    cards: list[_Card] = []
    with ExitStack() as stack:
        active = (stack.enter_context(drawing_engine(engine, size=REPORT_SIZE, camera=camera))
                  if thumbnails else None)
        bar = tqdm(total=len(selected), desc="report", unit="model", disable=not progress)
        try:
            if active is not None:
                active.start()  # fail fast, in one line, when no engine can run here
            for position, name in enumerate(names):
                item = selected[position]
                slug = _slug(position, name)
                best_index = [int(i) for i in item["best_index"]]
                card = _Card(name=name, category=categories[position], split=splits[position],
                             slug=slug, n_faces=int(records[position].get("n_faces", 0)),
                             best_index=best_index, best_images=[None] * len(measures),
                             sphere_map=f"maps/{slug}.png")
                rows = None if predicted is None else predicted[position]
                if evaluation is not None:
                    card.scores = [float(v) for v in evaluation.scores[position]]
                if view_set is not None:
                    _find_view_set(selected, position, view_set, card)
                if active is not None:
                    _draw_card_pictures(active, selected, position, card, views, rows, target,
                                        measures)
                figure = sphere_maps(views, item["quality"], measures=measures, predicted=rows,
                                     title=f"{name} ({card.category}, {card.split})",
                                     view_set=views[card.view_set] if card.view_set else None)
                save_figure(figure, target / card.sphere_map, dpi=_MAP_DPI)
                width, height = figure.get_size_inches() * _MAP_DPI
                card.map_size = (round(width), round(height))
                cards.append(card)
                bar.update(1)
        finally:
            bar.close()
    page = _page(selected, cards, evaluation, has_pictures=active is not None, camera=camera)
    index = target / "index.html"
    return write_text_atomic(index, page)


def _find_view_set(dataset: Any, position: int, k: int, card: _Card) -> None:
    """The model's coverage view set, onto the card (or the reason it has none).

    The set stored by the build is used when it has ``k`` views (or stopped
    because more add nothing); otherwise it is searched here.
    """
    from vptoolkit.evaluate.coverage import model_view_set

    try:
        chosen = model_view_set(dataset, position, k)
    except VptoolkitError as err:
        card.problems.append(f"view set: {one_line(err)}")
        return
    card.view_set = [int(i) for i in chosen.indices]
    card.view_set_coverage = [float(c) for c in chosen.coverage]


def _draw_card_pictures(renderer: Engine, dataset: Any, position: int, card: _Card,
                        views: NDArray[np.float64], predicted: NDArray[np.float64] | None,
                        target: Path, measures: Sequence[str]) -> None:
    """Render a model's best (and predicted) views into ``thumbs/``; note failures on the card."""
    try:
        mesh = _model_mesh(dataset, position, card.name)
    except VptoolkitError as err:
        card.problems.append(f"mesh: {one_line(err)}")
        return
    distinct = sorted(set(card.best_index) | set(card.view_set))
    try:
        images = renderer.render(mesh, views[distinct])
        for index, image in zip(distinct, images):
            save_png(image, target / "thumbs" / f"{card.slug}-v{index}.png")
        card.best_images = [f"thumbs/{card.slug}-v{index}.png" for index in card.best_index]
        card.view_set_images = [f"thumbs/{card.slug}-v{index}.png" for index in card.view_set]
    except (VptoolkitError, OSError) as err:
        card.problems.append(f"pictures: {one_line(err)}")
    if predicted is None:
        return
    card.predicted_images = [None] * len(measures)
    for column, measure in enumerate(measures):
        if np.isnan(predicted[column]).any():
            continue
        try:
            image = renderer.render(mesh, predicted[column])[0]
            relative = f"thumbs/{card.slug}-pred-{measure}.png"
            save_png(image, target / relative)
            card.predicted_images[column] = relative
        except (VptoolkitError, OSError) as err:
            card.problems.append(f"predicted {measure}: {one_line(err)}")


# --------------------------------------------------------------------------- HTML

_STYLE = """
:root { --ink: #1d2430; --muted: #5b6675; --line: #d9dee5; --card: #ffffff; --page: #f3f5f8; }
* { box-sizing: border-box; }
body { margin: 0; font: 14px/1.45 system-ui, -apple-system, "Segoe UI", sans-serif;
       color: var(--ink); background: var(--page); }
header, main, footer { max-width: 1240px; margin: 0 auto; padding: 16px 20px; }
h1 { font-size: 22px; margin: 8px 0 4px; }
h2 { font-size: 16px; margin: 0; word-break: break-all; }
p.lead, footer { color: var(--muted); }
table.summary { border-collapse: collapse; margin: 12px 0; background: var(--card); }
table.summary th, table.summary td { border: 1px solid var(--line); padding: 4px 10px;
                                     text-align: right; }
table.summary th:first-child, table.summary td:first-child { text-align: left; }
table.summary tr.mean td { font-weight: 600; }
#filters { display: flex; flex-wrap: wrap; gap: 16px; align-items: center; position: sticky;
           top: 0; z-index: 1; padding: 10px 20px; background: var(--page);
           border-bottom: 1px solid var(--line); }
#filters label { display: flex; gap: 6px; align-items: center; }
#shown-count { color: var(--muted); }
.card { background: var(--card); border: 1px solid var(--line); border-radius: 8px;
        padding: 14px 16px; margin: 14px 0; }
.card-head { display: flex; gap: 10px; align-items: baseline; flex-wrap: wrap; }
.badge { font-size: 12px; padding: 1px 8px; border-radius: 10px; background: #e6ebf2; }
.badge.split-test { background: #fde8c8; } .badge.split-validation { background: #dff0d8; }
.meta { color: var(--muted); font-size: 12px; }
.views { display: grid; grid-template-columns: repeat(4, minmax(0, 1fr)); gap: 10px;
         margin-top: 10px; max-width: 760px; }
.views figure { margin: 0; text-align: center; }
.views img { width: 100%; max-width: 180px; aspect-ratio: 1; border: 1px solid var(--line);
             border-radius: 4px; background: #fff; }
.views .missing { display: flex; align-items: center; justify-content: center; width: 100%;
                  max-width: 180px; aspect-ratio: 1; margin: 0 auto; color: var(--muted);
                  border: 1px dashed var(--line); border-radius: 4px; font-size: 12px; }
figcaption { font-size: 12px; color: var(--muted); }
img.map { width: 100%; max-width: 960px; margin-top: 8px; }
.row-label { font-size: 12px; font-weight: 600; margin-top: 10px; }
.problems { color: #a4262c; font-size: 12px; }
[hidden] { display: none !important; }
"""

_SCRIPT = """
(function () {
  "use strict";
  var category = document.getElementById("filter-category");
  var split = document.getElementById("filter-split");
  var shown = document.getElementById("shown-count");
  var cards = Array.prototype.slice.call(document.querySelectorAll("article.card"));

  function hasOption(select, value) {
    return Array.prototype.some.call(select.options, function (option) {
      return option.value === value;
    });
  }

  function readAddress() {
    var params = new URLSearchParams(window.location.hash.replace(/^#/, ""));
    var wanted = params.get("category") || "";
    category.value = hasOption(category, wanted) ? wanted : "";
    wanted = params.get("split") || "";
    split.value = hasOption(split, wanted) ? wanted : "";
  }

  function writeAddress() {
    var params = new URLSearchParams();
    if (category.value) { params.set("category", category.value); }
    if (split.value) { params.set("split", split.value); }
    var hash = params.toString();
    if (window.location.hash.replace(/^#/, "") !== hash) { window.location.hash = hash; }
  }

  function apply() {
    var n = 0;
    cards.forEach(function (card) {
      var isShown = (!category.value || card.dataset.category === category.value) &&
                    (!split.value || card.dataset.split === split.value);
      card.hidden = !isShown;
      if (isShown) { n += 1; }
    });
    shown.textContent = n + " of " + cards.length + " models shown";
    document.body.dataset.shown = String(n);
  }

  category.addEventListener("change", function () { writeAddress(); apply(); });
  split.addEventListener("change", function () { writeAddress(); apply(); });
  window.addEventListener("hashchange", function () { readAddress(); apply(); });
  readAddress();
  apply();
}());
"""


def _e(text: object) -> str:
    return html.escape(str(text), quote=True)


def _options(values: Sequence[str]) -> str:
    return "".join(f'<option value="{_e(v)}">{_e(v)}</option>' for v in values)


def _summary_table(dataset: Any, cards: list[_Card], evaluation: Any) -> str:
    from vptoolkit.conventions import SPLITS

    categories = sorted({card.category for card in cards})
    counts = Counter((card.category, card.split) for card in cards)
    scored = [] if evaluation is None else list(evaluation.scored_measures)
    head = "".join(f"<th>{s}</th>" for s in SPLITS)
    head += "".join(f"<th>{_e(m)} %</th>" for m in scored)
    rows = []
    category_scores = {}
    if evaluation is not None:
        category_scores = dict(zip(evaluation.categories, evaluation.category_scores))
    for category in categories:
        total = sum(counts[(category, s)] for s in SPLITS)
        cells = "".join(f"<td>{counts[(category, s)]}</td>" for s in SPLITS)
        for measure in scored:
            value = category_scores[category][evaluation.measures.index(measure)]
            cells += f"<td>{value:.1f}</td>"
        rows.append(f'<tr data-category="{_e(category)}"><td>{_e(category)}</td>'
                    f"<td>{total}</td>{cells}</tr>")
    totals = "".join(f"<td>{sum(counts[(c, s)] for c in categories)}</td>" for s in SPLITS)
    mean_cells = ""
    if evaluation is not None:
        mean_cells = "".join(f"<td>{evaluation.mean[evaluation.measures.index(m)]:.1f}</td>"
                             for m in scored)
    label = "all (scores: mean over categories)" if scored else "all"
    rows.append(f'<tr class="mean"><td>{label}</td><td>{len(cards)}</td>{totals}{mean_cells}</tr>')
    caption = ("Models per category and split" + (
        "; prediction scores: normalised quality of the nearest sampled view, in %"
        if scored else ""))
    return (f'<table class="summary" id="summary"><caption>{_e(caption)}</caption>'
            f"<thead><tr><th>category</th><th>models</th>{head}</tr></thead>"
            f"<tbody>{''.join(rows)}</tbody></table>")


def _figure(image: str | None, caption: str, alt: str) -> str:
    picture = (f'<img src="{_e(image)}" alt="{_e(alt)}" width="180" height="180">'
               if image else '<div class="missing">no picture</div>')
    return f"<figure>{picture}<figcaption>{caption}</figcaption></figure>"


def _card_html(card: _Card, n_views: int, has_pictures: bool,
               measures: Sequence[str]) -> str:
    parts = [
        f'<article class="card" id="model-{_e(card.slug)}" data-name="{_e(card.name)}" '
        f'data-category="{_e(card.category)}" data-split="{_e(card.split)}">',
        '<div class="card-head">',
        f"<h2>{_e(card.name)}</h2>",
        f'<span class="badge">{_e(card.category)}</span>',
        f'<span class="badge split-{_e(card.split)}">{_e(card.split)}</span>',
        f'<span class="meta">{card.n_faces} faces</span>',
        "</div>",
    ]
    if has_pictures:
        parts.append('<div class="row-label">best views</div><div class="views">')
        for column, measure in enumerate(measures):
            caption = f"{_e(measure)} · view {card.best_index[column]} of {n_views}"
            parts.append(_figure(card.best_images[column], caption,
                                 f"{card.name} from its best {measure} view"))
        parts.append("</div>")
    if card.view_set:
        seen = 100 * card.view_set_coverage[-1]
        parts.append(f'<div class="row-label">view set: {len(card.view_set)} views see '
                     f'{seen:.1f} % of the surface</div><div class="views view-set">')
        for pick, (index, coverage) in enumerate(zip(card.view_set, card.view_set_coverage), 1):
            caption = f"{pick} · view {index} · {100 * coverage:.1f} % seen"
            image = card.view_set_images[pick - 1] if card.view_set_images else None
            if has_pictures:
                parts.append(_figure(image, caption, f"{card.name}, view {pick} of its set"))
            else:
                parts.append(f"<figure><figcaption>{caption}</figcaption></figure>")
        parts.append("</div>")
    if card.scores is not None:
        label = "predicted views" if has_pictures and card.predicted_images else "predictions"
        parts.append(f'<div class="row-label">{label}</div><div class="views">')
        for column, measure in enumerate(measures):
            score = card.scores[column]
            text = "not predicted" if np.isnan(score) else f"{score:.1f} %"
            caption = f"{_e(measure)} · <span class=\"score\">{text}</span>"
            if has_pictures and card.predicted_images is not None:
                parts.append(_figure(card.predicted_images[column], caption,
                                     f"{card.name} from its predicted {measure} view"))
            else:
                parts.append(f"<figure><figcaption>{caption}</figcaption></figure>")
        parts.append("</div>")
    width, height = card.map_size
    parts.append(f'<img class="map" src="{_e(card.sphere_map)}" loading="lazy" '
                 f'alt="quality maps of {_e(card.name)}" width="{width}" height="{height}">')
    if card.problems:
        parts.append('<p class="problems">' + "<br>".join(_e(p) for p in card.problems) + "</p>")
    parts.append("</article>")
    return "\n".join(parts)


def _page(dataset: Any, cards: list[_Card], evaluation: Any, *, has_pictures: bool,
          camera: Camera) -> str:
    from vptoolkit.conventions import SPLITS

    title = f"Viewpoint quality: {dataset.path.name}"
    categories = sorted({card.category for card in cards})
    splits = [s for s in SPLITS if any(card.split == s for card in cards)]
    n_views = len(dataset.views)
    failures = dataset.failures
    lead = (f"{len(cards)} models, {len(categories)} categories, {n_views} sampled views "
            f"per model. Pictures use the measures' camera (field of view "
            f"{camera.fov_deg:g}°, distance {camera.distance_factor:.3f} bounding-box "
            f"diagonals, image up {tuple(camera.up)}). Maps: Mercator, longitude atan2(z, x), "
            "latitude asin(y); ★ best sampled view, ✕ prediction, numbered circles: the view "
            "set (views that together see the most of the surface, in selection order).")
    if evaluation is not None:
        lead += f" Predictions: {evaluation.predictions}."
    failure_html = ""
    if failures:
        items = "".join(f"<li>{_e(f.get('source'))}: {_e(f.get('reason'))}</li>" for f in failures)
        failure_html = (f"<details><summary>{len(failures)} source files were not built"
                        f"</summary><ul>{items}</ul></details>")
    body = "\n".join(_card_html(card, n_views, has_pictures, dataset.measures)
                     for card in cards)
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{_e(title)}</title>
<style>{_STYLE}</style>
</head>
<body>
<header>
<h1>{_e(title)}</h1>
<p class="lead">{_e(lead)}</p>
{_summary_table(dataset, cards, evaluation)}
{failure_html}
</header>
<form id="filters" onsubmit="return false">
<label>Category <select id="filter-category"><option value="">all</option>\
{_options(categories)}</select></label>
<label>Split <select id="filter-split"><option value="">all</option>\
{_options(splits)}</select></label>
<span id="shown-count">{len(cards)} of {len(cards)} models shown</span>
</form>
<main id="cards">
{body}
</main>
<footer>Written by vptoolkit; open this file in any browser, no server needed.</footer>
<script>{_SCRIPT}</script>
</body>
</html>
"""
