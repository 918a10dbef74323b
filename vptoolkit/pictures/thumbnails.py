"""Thumbnails of a collection of models, from each model's best (or a predicted) view.

:func:`render_thumbnails` draws one picture per entry of a collection (a
folder, a glob, a model file or ``@list.txt``:
:func:`vptoolkit.collection.discover.discover`) through the collection
runner (:func:`vptoolkit.collection.runner.run_collection`): the directions
are found in worker processes or on a Dask cluster.

Where pictures are drawn
    With the software engine (the default,
    :class:`~vptoolkit.pictures.software_engine.SoftwareRenderer`), each
    worker draws the entries it answered with an engine of the same size,
    camera, style and supersampling (:class:`PictureDrawing`) and sends back
    the PNG's bytes; this process only writes them, so ``workers`` and a
    cluster speed the drawing up too, and the pictures are the same bytes
    whoever drew them. Any other engine draws in this process: the Open3D
    engine is one offscreen renderer (a render child) per process, started
    once and not picklable. A ``predictor`` answers in this process, so its
    pictures are drawn here with either engine. This process is the one
    writer of the output folder either way. The picture of
the entry ``a/b.off`` is ``OUT/a/b.off.png`` (the key and ``.png``, so
``b.off`` and ``b.obj`` never share a picture). Each model is drawn in its
own colours and texture where its file has them
(:func:`vptoolkit.io.load_with_appearance`, read again in this process),
framed as the engine's style says (``RenderStyle.margin``). A folder may
mix meshes and point clouds: a cloud is searched on its points and drawn
as splats by the software engine (the Open3D engine refuses it, one line
in the failures); a prediction (``predictor``) takes meshes only.

By default each direction comes from the anytime search
(:class:`~vptoolkit.collection.methods.SearchMethod`, a
:class:`~vptoolkit.best_view.search.SearchSettings` budget of views);
``settings`` (a :class:`~vptoolkit.settings.MeasureSettings`) measures every
view of the sphere instead, the exhaustive answer
(:class:`~vptoolkit.collection.methods.MeasureMethod`); ``view_set`` draws a
coverage set as a contact sheet; ``predictor`` takes the direction from a
direction source (:class:`PredictedMethod`, in this process).

State
    A picture is written (atomically) before its entry is staged, so a rerun
    after ``kill -9`` redraws nothing done and loses only the entries in flight. The run's table is
    ``OUT/.runs/<digest>/table.parquet``; ``OUT/thumbnails.json`` records the
    measure, the method's settings, the size, one
    ``{"source", "image", "direction", "label"}`` record per picture and the
    failures with their one-line reasons, written at the end from the table;
    ``OUT/index.html`` (and ``index-2.html``, ...) shows the pictures a page
    at a time (:mod:`vptoolkit.pictures.thumbnail_index`).
"""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.appearance import Appearance
from vptoolkit.best_view.search import SearchSettings
from vptoolkit.camera import Camera
from vptoolkit.checks import as_path, check_int, one_line
from vptoolkit.collection.discover import Entry, is_remote_entry
from vptoolkit.collection.methods import (
    Answer,
    MeasureMethod,
    Method,
    SearchMethod,
    ViewSetMethod,
    cameras,
)
from vptoolkit.collection.runner import (
    MAX_MODEL_FACES,
    TIMEOUT_S,
    EntryResult,
    run_collection,
)
from vptoolkit.errors import InputError, VptoolkitError
from vptoolkit.files import atomic_write, write_bytes_atomic
from vptoolkit.io import require_surface
from vptoolkit.measures.registry import canonical_name
from vptoolkit.mesh import Mesh
from vptoolkit.optional import require
from vptoolkit.pictures.engine import Engine, drawing_engine
from vptoolkit.pictures.png import png_bytes
from vptoolkit.pictures.shading import RenderStyle
from vptoolkit.pictures.thumbnail_index import ThumbnailCard, write_thumbnail_index
from vptoolkit.pictures.views import DirectionSource, resolve_direction
from vptoolkit.point_cloud import MAX_POINTS, PointCloud
from vptoolkit.settings import MeasureSettings, check_settings

__all__ = ["PictureDrawing", "PredictedMethod", "ThumbnailFailure", "ThumbnailResult",
           "picture_name", "render_thumbnails", "thumbnail_method", "ThumbnailMethod"]

_INDEX_NAME = "thumbnails.json"
RUNS_FOLDER = ".runs"
"""The folder below OUT of the runs' staging and tables (hidden: no key starts with a dot)."""


@dataclass(frozen=True)
class ThumbnailFailure:
    """An entry that got no thumbnail.

    Attributes
    ----------
    source : str
        The entry's key: its path relative to the root given.
    reason : str
        One line: what went wrong.
    """

    source: str
    reason: str


@dataclass(frozen=True)
class ThumbnailResult:
    """What :func:`render_thumbnails` did.

    Attributes
    ----------
    done : list of Path
        Every entry's picture (drawn now or by an earlier run), sorted.
    failures : list of ThumbnailFailure
        The entries without a picture, with their reasons, in key order.
    index : Path
        ``thumbnails.json`` in the output folder (module docstring).
    html : Path
        ``index.html`` in the output folder, the first page of the pictures.
    table : Path
        The run's Parquet table (:mod:`vptoolkit.collection.table`).
    n_drawn : int
        Pictures drawn by this call (the others were drawn by an earlier run).
    """

    done: list[Path] = field(default_factory=list)
    failures: list[ThumbnailFailure] = field(default_factory=list)
    index: Path | None = None
    html: Path | None = None
    table: Path | None = None
    n_drawn: int = 0


@dataclass(frozen=True)
class PredictedMethod:
    """A direction source's answer for every model, in the calling process.

    Attributes
    ----------
    predictor : (3,) or (4, 3) array_like, or callable
        As :func:`vptoolkit.pictures.views.resolve_direction` takes it.
    name : str
        What the predictor is (a checkpoint's path, ``default``): its record.
    measure : str
        The measure whose direction is taken (default: "VE").
    settings : MeasureSettings
        Whose camera and resolution the pose and intrinsics are of.
    """

    predictor: Any = field(compare=False)
    name: str
    measure: str = "VE"
    settings: MeasureSettings = field(default_factory=MeasureSettings)

    @property
    def names(self) -> tuple[str, ...]:
        """The one measure."""
        return (canonical_name(self.measure),)

    @property
    def in_process(self) -> bool:
        """True: a predictor (a network) is not sent to workers."""
        return True

    def record(self) -> dict[str, Any]:
        """``{"method": "predicted", "predictor", "measure", "camera"}``."""
        return {"method": "predicted", "predictor": self.name, "measure": self.names[0],
                "camera": self.settings.camera.to_dict()}

    def __call__(self, mesh: Mesh | PointCloud) -> Answer:
        """The predicted direction of a mesh (a predictor reads surfaces: a point cloud is
        refused in one line)."""
        mesh = require_surface(mesh)
        direction = resolve_direction(mesh, self.predictor, measure=self.names[0])[None]
        poses, intrinsics = cameras(mesh, self.settings.camera, direction,
                                    self.settings.resolution)
        return Answer(direction, np.full(1, np.nan), poses, intrinsics, 0,
                      f"predicted {self.names[0]}")


ThumbnailMethod = SearchMethod | MeasureMethod | ViewSetMethod | PredictedMethod
"""The methods a thumbnail's direction comes from; each has the camera its pictures use."""


def _stood_up(model: Mesh | PointCloud, direction: NDArray[np.float64],
              up: tuple[float, float, float]
              ) -> tuple[Mesh | PointCloud, NDArray[np.float64]]:
    """The model and view direction turned together so that the model's own up axis
    (:func:`vptoolkit.upright.resting_up`, as the search with ``up="auto"`` found it) is the
    picture's ``up``: the same view, upright (a cloud's normals turn with its points)."""
    from vptoolkit.upright import resting_up, rotation_between

    turn = rotation_between(resting_up(model), up)
    if isinstance(model, PointCloud):
        normals = None if model.normals is None else model.normals @ turn.T
        return replace(model, points=model.points @ turn.T, normals=normals), direction @ turn.T
    return replace(model, vertices=model.vertices @ turn.T), direction @ turn.T


def _picture(result: EntryResult, engine: Engine, method: ThumbnailMethod, rows: slice,
             is_stood_up: bool, max_points: int) -> NDArray[np.uint8]:
    """The thumbnail of an answered entry (with its model, read with ``max_points``): the
    chosen view, stood up when the search put the model's own up axis up, or a view set's
    contact sheet."""
    assert result.answer is not None and result.model is not None  # answered entries
    model = result.model
    appearance = model_appearance(result.entry, model, max_points)
    if isinstance(method, ViewSetMethod):
        from vptoolkit.pictures.contact_sheet import view_set_sheet

        image, _ = view_set_sheet(model, view_set=result.answer.detail,
                                  settings=method.settings, engine=engine,
                                  appearance=appearance)
        return image
    direction = result.answer.directions[rows][0]
    if is_stood_up:
        model, direction = _stood_up(model, direction, engine.style.up)
    return engine.render(model, direction, appearance=appearance)[0]


@dataclass(frozen=True)
class PictureDrawing:
    """Draw an answered entry's thumbnail in the worker that answered it, as PNG bytes.

    The ``draw`` of :func:`~vptoolkit.collection.runner.run_collection`
    that :func:`render_thumbnails` gives with the software engine: picklable
    (the engine's settings, not the engine), it draws each entry with a
    :class:`~vptoolkit.pictures.software_engine.SoftwareRenderer` of these
    settings, so the bytes are those this process would draw.

    Attributes
    ----------
    size : int
        The picture's side, in pixels.
    camera : Camera
        The engine's camera (the method's).
    style : RenderStyle
        The engine's shading, up and margin.
    supersampling : int
        The engine's samples per pixel along each axis.
    method : ThumbnailMethod
        The method that answered (a view set is drawn as a contact sheet).
    rows : slice
        The answer's rows the picture shows (the measure's, or every view of a set).
    is_stood_up : bool
        Whether the model is turned to stand on its own up axis (a search
        with ``up="auto"``).
    max_points : int
        The ``max_points`` the entries were read with (their colours are read alike).
    """

    size: int
    camera: Camera
    style: RenderStyle
    supersampling: int
    method: ThumbnailMethod
    rows: slice
    is_stood_up: bool
    max_points: int

    def __call__(self, result: EntryResult) -> EntryResult:
        """The entry with its picture's PNG bytes as ``output`` (no model), or a failure
        with its one-line reason."""
        from vptoolkit.pictures.software_engine import SoftwareRenderer

        try:
            with SoftwareRenderer(size=self.size, camera=self.camera, style=self.style,
                                  supersampling=self.supersampling) as engine:
                image = _picture(result, engine, self.method, self.rows, self.is_stood_up,
                                 self.max_points)
            return replace(result, model=None, output=png_bytes(image))
        except VptoolkitError as err:
            return replace(result, answer=None, reason=one_line(err), model=None)


def picture_name(key: str) -> str:
    """The picture of an entry, relative to the output folder: its key and ``.png``."""
    return f"{key}.png"


def model_appearance(entry: Entry, model: Mesh | PointCloud,
                     max_points: int) -> Appearance | None:
    """The appearance of an entry's file, if it is local and belongs to ``model``.

    The file is read again (:func:`vptoolkit.io.load_with_appearance`, a point
    cloud thinned by ``max_points`` as ``model`` was); a
    remote entry, a model whose kind or counts differ from ``model``'s, or a
    file whose colours cannot be read (a warning names it) give None: the
    picture is then drawn in the style's colour.
    """
    if is_remote_entry(entry.path):
        return None
    from vptoolkit.io import load_with_appearance

    try:
        read, appearance = load_with_appearance(entry.path, max_points=max_points)
    except VptoolkitError as err:
        warnings.warn(f"{entry.key}: drawn without its colours ({one_line(err)})", stacklevel=2)
        return None
    if isinstance(model, PointCloud):
        if not isinstance(read, PointCloud) or read.n_points != model.n_points:
            return None
    elif not isinstance(read, Mesh) or (read.n_vertices, read.n_faces) != (model.n_vertices,
                                                                          model.n_faces):
        return None
    return None if appearance.is_empty else appearance


def _drawn_rows(names: tuple[str, ...], measure: str) -> slice:
    """The answer's rows a picture shows: the measure's, or every view of a set."""
    return slice(names.index(measure), names.index(measure) + 1) if measure in names \
        else slice(None)


def _rounded(direction: Any) -> list[Any]:
    """A direction (or, for a view set, each direction) as a list of 6-decimal floats."""
    array = np.asarray(direction, dtype=np.float64)
    if array.ndim == 2:
        return [_rounded(row) for row in array]
    return [round(float(c), 6) for c in array]


def thumbnail_method(measure: str, search: SearchSettings | None, settings: MeasureSettings | None,
            predictor: DirectionSource | None, predictor_name: str,
            view_set: int | None) -> ThumbnailMethod:
    """The method of :func:`render_thumbnails`'s options (see there); ``measure`` as
    the registry spells it (:func:`~vptoolkit.measures.registry.canonical_name`).

    Raises
    ------
    InputError
        If the options contradict each other or one is invalid.
    """
    if search is not None and settings is not None:
        raise InputError("settings: a search (search) or every view measured (settings); "
                         "drop one of them")
    if view_set is not None:
        view_set = check_int(view_set, "view_set", minimum=1)
        if predictor is not None:
            raise InputError("view_set: a predictor gives one view per mesh; drop one of them")
        if search is not None:
            raise InputError("view_set: a view set is chosen from every view (settings); "
                             "drop search")
        return ViewSetMethod(view_set, MeasureSettings() if settings is None
                             else check_settings(settings))
    if predictor is not None:
        return PredictedMethod(predictor, predictor_name, measure,
                               MeasureSettings() if settings is None else check_settings(settings))
    if settings is not None:
        return MeasureMethod(check_settings(settings))
    if search is not None and not isinstance(search, SearchSettings):
        raise InputError(f"search: expected a SearchSettings, got {type(search).__name__}")
    return SearchMethod(SearchSettings() if search is None else search, (measure,))


def render_thumbnails(
    src: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    measure: str = "VE",
    search: SearchSettings | None = None,
    settings: MeasureSettings | None = None,
    predictor: DirectionSource | None = None,
    predictor_name: str = "predictor",
    view_set: int | None = None,
    workers: int = 1,
    scheduler: str | None = None,
    engine: Engine | None = None,
    max_faces: int = MAX_MODEL_FACES,
    max_points: int = MAX_POINTS,
    timeout: float = TIMEOUT_S,
    progress: bool = False,
) -> ThumbnailResult:
    """Draw a thumbnail of every mesh of a collection from its best (or predicted) view.

    Parameters
    ----------
    src : str or path-like
        A folder (walked recursively, hidden files and folders skipped), a
        glob, one model file, or ``@list.txt``
        (:func:`vptoolkit.collection.discover.discover`).
    out : path-like
        Output folder, created if needed.
    measure : str
        ``"VE"``, ``"VR"``, ``"VKL"`` or ``"VMI"`` (default: "VE").
    search : SearchSettings, optional
        The search's budget, resolution and camera (default:
        ``SearchSettings()`` when neither ``settings`` nor ``view_set`` is given).
    settings : MeasureSettings, optional
        Measure every view of this sphere instead of searching: the
        exhaustive answer (``MeasureSettings()``: 1000 views at 1024 px);
        the sphere of ``view_set``, the camera of ``predictor``.
    predictor : (3,) or (4, 3) array_like, or callable, optional
        Direction source (see :func:`vptoolkit.pictures.views.resolve_direction`);
        a callable gets each :class:`~vptoolkit.mesh.Mesh`, e.g. a trained
        network's prediction. It runs in this process, and the pictures are
        drawn there too.
    predictor_name : str
        What ``predictor`` is, for the run's record, which names its output
        folder: give each predictor its own name, or a rerun takes the
        answers of an earlier one (default: "predictor").
    view_set : int, optional
        Draw each mesh's ``view_set``-view coverage set as a captioned
        contact sheet (:func:`vptoolkit.pictures.contact_sheet.view_set_sheet`),
        a tile of the engine's size per view; its record lists every direction.
    workers : int
        Processes finding the directions and, with the software engine,
        drawing the pictures, as ``build-dataset --workers`` (default: 1, in
        this process).
    scheduler : str, optional
        A Dask scheduler's address instead of ``workers``.
    engine : Engine, optional
        The engine that draws, its size the thumbnails' side; its camera
        must be the method's (default: a software engine of 512 pixels with
        that camera, made for this call). A software engine's settings draw
        in the workers (module docstring); any other engine draws in this
        process.
    max_faces, max_points, timeout
        The per-file limits of :func:`vptoolkit.collection.runner.run_collection`.
    progress : bool
        Show a progress bar on stderr (default: False).

    Returns
    -------
    ThumbnailResult

    Raises
    ------
    InputError
        If ``src`` does not exist, an option is invalid or contradicts
        another, or the engine's camera is not the method's.
    MissingDependencyError
        If the engine cannot start here (checked before any work).
    """
    source = os.fspath(src)
    target = as_path(out, "out")
    measure = canonical_name(measure)
    method = thumbnail_method(measure, search, settings, predictor, predictor_name, view_set)
    rows = _drawn_rows(method.names, measure)

    is_stood_up = search is not None and search.up == "auto"
    with drawing_engine(engine, camera=method.settings.camera) as active:
        active.start()  # fail fast, in one line, when no engine can run here
        from vptoolkit.pictures.software_engine import SoftwareRenderer

        in_workers = (PictureDrawing(active.size, active.camera, active.style,
                                     active.supersampling, method, rows, is_stood_up,
                                     max_points)
                      if type(active) is SoftwareRenderer else None)
        drawn = [0]

        def write(result: EntryResult) -> EntryResult:
            """Write the entry's picture (drawn by its worker, or here); stage the result."""
            try:
                payload = result.output if in_workers is not None else png_bytes(
                    _picture(result, active, method, rows, is_stood_up, max_points))
                image_path = target / picture_name(result.entry.key)
                image_path.parent.mkdir(parents=True, exist_ok=True)
                write_bytes_atomic(image_path, payload)
                drawn[0] += 1
            except (VptoolkitError, OSError) as err:
                return replace(result, answer=None, reason=one_line(err), model=None)
            return replace(result, model=None, output=b"")

        target.mkdir(parents=True, exist_ok=True)
        run = run_collection(source, target / RUNS_FOLDER, method, max_faces=max_faces,
                             max_points=max_points, timeout=timeout, workers=workers,
                             scheduler=scheduler, draw=in_workers, finish=write, progress=progress)
        size = active.size
    cards = _write_index(target / _INDEX_NAME, run.table, method, measure, rows, size, source)
    if isinstance(method, ViewSetMethod):
        title = f"View sets of {source}"
    else:
        chosen = "predicted" if isinstance(method, PredictedMethod) else "best"
        title = f"Thumbnails of {source}: {chosen} {measure} views"
    pages = write_thumbnail_index(target, cards, size=size, title=title)
    failures = [ThumbnailFailure(key, reason) for key, reason in run.failures]
    return ThumbnailResult(sorted(target / image for _, image, _ in cards), failures,
                           target / _INDEX_NAME, pages[0], run.table, drawn[0])


def _write_index(path: Path, table: Path, method: Method, measure: str, rows: slice,
                 size: int, source: str) -> list[ThumbnailCard]:
    """Write ``thumbnails.json`` from the table, streamed one record per line; the
    pictures' cards, in the table's order."""
    pq = require("pyarrow.parquet", extra="dataset")
    names = method.names[rows]
    header = {"source": source, "measure": measure,
              "direction_from": "predictor" if isinstance(method, PredictedMethod)
              else "measures", "settings": method.record(), "size": size}
    pictures: list[ThumbnailCard] = []
    failures: list[str] = []
    with atomic_write(path) as stream:
        stream.write(json.dumps(header, indent=2)[:-2].encode() + b',\n  "thumbnails": [')
        separator = b"\n    "
        for batch in pq.ParquetFile(table).iter_batches():
            for row in batch.to_pylist():
                if row["status"] != "ok":
                    failures.append(json.dumps({"source": row["key"], "reason": row["reason"]}))
                    continue
                directions = [row[f"{name}_direction"] for name in names]
                record = {"source": row["key"], "image": picture_name(row["key"]),
                          "direction": _rounded(directions if len(names) > 1
                                                else directions[0]),
                          "label": row["label"]}
                stream.write(separator + json.dumps(record).encode())
                separator = b",\n    "
                pictures.append((row["key"], record["image"], row["label"] or ""))
        stream.write(b"\n  ],\n  \"failures\": [" + ",".join(failures).encode() + b"]\n}\n")
    return pictures
