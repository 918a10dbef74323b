"""The one input router: which inputs are model files or datasets, and their models.

Every command and library entry that reads a model reads it here: the
commands that take "meshes, point clouds or a dataset" (``vptool predict``,
``predict --model unoccluded``, ``best-view``) through :func:`open_inputs`,
and those that take one model file (``measure``, ``clean``, ``sample``,
``render``, ``thumbnails``) through :func:`read_model`, so one rule decides
what an input is:

a :class:`~vptoolkit.data.ViewpointDataset`, a folder or dataset store, or a release's URL
    every model of ``split`` (``None``: every model), opened with
    :func:`vptoolkit.data.open_dataset` and closed when the ``with`` block ends;
a file whose suffix :func:`vptoolkit.io.load` reads (:data:`vptoolkit.io.MODEL_SUFFIXES`)
    one model, a :class:`~vptoolkit.mesh.Mesh` or a
    :class:`~vptoolkit.point_cloud.PointCloud` as its content decides (a PLY
    without faces is a point cloud; an ``.npy`` array is always one);

anything else is an :class:`~vptoolkit.errors.InputError`. Where the work
needs a surface (``requires="surface"``), a point cloud is refused with the
one message of :func:`vptoolkit.io.require_surface`. A model is named by its
name in the dataset, or a file by its stem; files of one stem are named by
their paths under the folder they share, as ``vptool build-dataset`` names
a path (:func:`vptoolkit.conventions.model_name`): ``a/teapot.stl`` beside
``b/teapot.obj`` are ``a__teapot`` and ``b__teapot``, ``x.npy`` beside
``b/x.npy`` are ``x`` and ``b__x``. Names must be unique over all inputs, and :func:`claim_name` is
the one check (and message) for that.
Nothing is read until a :class:`ModelSource` is asked for its model, mesh,
points or normals, so a caller can record a bad model and carry on.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Literal, TypeAlias, overload

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import check_int
from vptoolkit.conventions import model_name
from vptoolkit.errors import InputError
from vptoolkit.mesh import Mesh
from vptoolkit.point_cloud import MAX_POINTS, PointCloud

if TYPE_CHECKING:
    from vptoolkit.data import ViewpointDataset

__all__ = ["InputKind", "Requirement", "ModelSource", "claim_name", "open_inputs", "read_model"]

InputKind: TypeAlias = Literal["file", "stored"]
"""What a model comes from: a model file (a mesh or a point cloud) or a dataset."""

Requirement: TypeAlias = Literal["surface"] | None
"""What the work needs of a model: ``"surface"`` (a mesh; a point cloud is
refused with one message) or None (a mesh or a point cloud)."""


@overload
def read_model(path: str | os.PathLike[str], *, requires: Literal["surface"],
               max_points: int = ...) -> Mesh: ...


@overload
def read_model(path: str | os.PathLike[str], *, requires: None = None,
               max_points: int = ...) -> Mesh | PointCloud: ...


def read_model(path: str | os.PathLike[str], *, requires: Requirement = None,
               max_points: int = MAX_POINTS) -> Mesh | PointCloud:
    """The model of one file, a mesh or a point cloud as its content decides.

    Parameters
    ----------
    path : str or os.PathLike
        A file :func:`vptoolkit.io.load` reads.
    requires : {"surface", None}
        ``"surface"``: refuse a point cloud with the one message of
        :func:`vptoolkit.io.require_surface` (default: None, either).
    max_points : int
        Most points a point cloud keeps; a larger one is thinned, with a
        warning (:func:`vptoolkit.io.load`; default:
        :data:`~vptoolkit.point_cloud.MAX_POINTS`).

    Returns
    -------
    Mesh or PointCloud
        A Mesh whenever ``requires="surface"``.

    Raises
    ------
    MeshLoadError
        :func:`vptoolkit.io.load`'s messages, and ``FILE: a point cloud (N
        points, no faces); this needs a surface (a mesh with faces)``.
    InputError
        If ``requires`` is not one of the above.
    """
    from vptoolkit.io import load, require_surface

    if requires not in (None, "surface"):
        raise InputError(f"requires: expected 'surface' or None, got {requires!r}")
    model = load(path if isinstance(path, os.PathLike) else str(path), max_points=max_points)
    if requires == "surface":
        return require_surface(model, Path(path).name)
    return model



@dataclass(frozen=True)
class ModelSource:
    """One model of the inputs, not yet read.

    Attributes
    ----------
    name : str
        The file's stem, or the model's name in its dataset.
    kind : {"file", "stored"}
        A model file (a mesh or a point cloud, as its content decides) or a
        model stored in a dataset.
    origin : str
        The input as given: the file, or the dataset (for messages).
    category : str or None
        The dataset's category of a stored model; None for files.
    dataset : ViewpointDataset or None
        The split a stored model is read from (open while the router's
        ``with`` block lasts); None for files.
    position : int
        The stored model's row in ``dataset``; -1 for files.
    requires : {"surface", None}
        What the work needs of a file's model (:func:`read_model`).
    max_points : int
        Most points a file's point cloud keeps (:func:`read_model`).
    """

    name: str
    kind: InputKind
    origin: str
    category: str | None = None
    dataset: ViewpointDataset | None = field(default=None, repr=False, compare=False)
    position: int = -1
    requires: Requirement = None
    max_points: int = MAX_POINTS

    @property
    def label(self) -> str:
        """Where the model comes from, for a batch's failure list: the file, or the model's name."""
        return self.name if self.kind == "stored" else self.origin

    def _stored(self) -> ViewpointDataset:
        if self.dataset is None:
            raise InputError(f"{self.origin}: {self.name!r} is not a stored model")
        return self.dataset

    def model(self) -> Mesh | PointCloud:
        """The model, named :attr:`name`: a file's as :func:`read_model` reads it with
        ``requires``, or the stored, cleaned mesh."""
        if self.kind == "stored":
            vertices, faces = self._stored().mesh(self.name)
            return Mesh(vertices.astype(np.float64), faces.astype(np.int64), name=self.name)
        model = read_model(self.origin, requires=self.requires, max_points=self.max_points)
        return model if model.name == self.name else replace(model, name=self.name)

    def mesh(self) -> Mesh:
        """The model, which must be a mesh (:func:`vptoolkit.io.require_surface`)."""
        from vptoolkit.io import require_surface

        return require_surface(self.model(), Path(self.origin).name)

    def points(self, *, seed: int) -> NDArray[np.float64]:
        """Surface points ``(n, 3) float64``: the stored ones, a point cloud's, or
        ``N_SURFACE_POINTS`` sampled from a mesh with ``seed``
        (:func:`vptoolkit.points.sample_surface`)."""
        from vptoolkit.points import N_SURFACE_POINTS, sample_surface

        if self.kind == "stored":
            return np.asarray(self._stored()[self.position]["points"], dtype=np.float64)
        model = self.model()
        if isinstance(model, PointCloud):
            return np.array(model.points)
        return sample_surface(model, N_SURFACE_POINTS, seed=seed).points

    def normals(self) -> NDArray[np.float64]:
        """Point normals ``(n, 3) float64`` as stored or as a point cloud carries them (a
        cloud's are unit length); a mesh has face normals instead (:mod:`vptoolkit.geometry`)."""
        if self.kind == "stored":
            return np.asarray(self._stored()[self.position]["normals"], dtype=np.float64)
        model = self.model()
        if isinstance(model, Mesh):
            raise InputError(f"{self.origin}: a mesh file has no point normals")
        if model.normals is None:
            raise InputError(f"{self.origin}: has no normals; give points "
                             "with normals (an (N, 6) array x y z nx ny nz, as vptool sample "
                             "writes, or a PLY with nx ny nz)")
        return np.array(model.normals)


def claim_name(names: set[str], name: str) -> None:
    """Add ``name`` to ``names``, or raise the one message for a second model of that name."""
    if name in names:
        raise InputError(f"inputs: two models are named {name!r}; model names must be unique")
    names.add(name)


def _is_dataset(path: Path) -> bool:
    """Whether ``path`` may hold a dataset: a folder, or a file a store container claims."""
    from vptoolkit.dataset.store.containers import store_kind

    if path.is_dir():
        return True
    try:
        store_kind(path)
    except InputError:
        return False
    return True


def _stored_sources(dataset: ViewpointDataset, origin: str, split: str | None,
                    purpose: str | None, requires: Requirement) -> list[ModelSource]:
    """The models of ``split`` of one dataset (every model for None): the one split rule."""
    subset = dataset.split(split) if split is not None else dataset
    if purpose is not None and not len(subset.names):
        which = "the dataset" if split is None else f"split {split!r}"
        raise InputError(f"{origin}: {which} holds no models; nothing to {purpose}")
    return [ModelSource(str(name), "stored", origin, category, subset, position, requires)
            for position, (name, category) in enumerate(zip(subset.names, subset.categories))]


@contextlib.contextmanager
def open_inputs(inputs: (str | os.PathLike[str] | ViewpointDataset
                         | Sequence[str | os.PathLike[str] | ViewpointDataset]),
                *, split: str | None = "test", purpose: str | None = None,
                requires: Requirement = None,
                max_points: int = MAX_POINTS) -> Iterator[list[ModelSource]]:
    """The models of model files and datasets, in input order.

    Parameters
    ----------
    inputs : path-like, ViewpointDataset or a sequence of them
        In any mix (module docstring). A dataset given open stays open.
    split : str, optional
        ``"train"``, ``"validation"``, ``"test"``, or None for every model
        of each dataset (default: "test").
    purpose : str, optional
        What the models are for (``"search"``): a dataset with no model of
        ``split`` is then an error, ``<dataset>: split 'test' holds no
        models; nothing to search``.
    requires : {"surface", None}
        ``"surface"``: a file's point cloud is refused, when its model is
        read, with the one message of :func:`vptoolkit.io.require_surface`
        (default: None, a mesh or a point cloud).
    max_points : int
        Most points a file's point cloud keeps; a larger one is thinned, with
        a warning (:func:`vptoolkit.io.load`; default:
        :data:`~vptoolkit.point_cloud.MAX_POINTS`).

    Yields
    ------
    sources : list of ModelSource
        Datasets opened here are closed when the block ends.

    Raises
    ------
    InputError
        Naming the input: neither a model file nor a dataset; a dataset that
        cannot be opened, an unknown split or (with ``purpose``) an empty
        one; a ``requires`` not in the list or a ``max_points`` below 1.
    """
    from vptoolkit.data import ViewpointDataset, open_dataset
    from vptoolkit.data.remote import is_remote
    from vptoolkit.io import MODEL_SUFFIXES

    if requires not in (None, "surface"):
        raise InputError(f"requires: expected 'surface' or None, got {requires!r}")
    max_points = check_int(max_points, "max_points", minimum=1)

    entries = [inputs] if isinstance(inputs, (str, os.PathLike, ViewpointDataset)) else inputs
    with contextlib.ExitStack() as stack:
        sources: list[ModelSource] = []
        files: list[int] = []  # rows of sources read from files
        for entry in entries:
            if isinstance(entry, ViewpointDataset):
                sources += _stored_sources(entry, str(entry.path), split, purpose, requires)
                continue
            if not isinstance(entry, (str, os.PathLike)):
                raise InputError("inputs: expected paths or a ViewpointDataset, "
                                 f"got {type(entry).__name__}")
            path = Path(entry)
            suffix = path.suffix.lower()
            if isinstance(entry, str) and is_remote(entry):
                opened = stack.enter_context(open_dataset(entry))
                sources += _stored_sources(opened, entry, split, purpose, requires)
            elif suffix in MODEL_SUFFIXES and not path.is_dir():
                sources.append(ModelSource(path.stem, "file", str(entry), requires=requires,
                                           max_points=max_points))
                files.append(len(sources) - 1)
            elif _is_dataset(path):
                opened = stack.enter_context(open_dataset(path))
                sources += _stored_sources(opened, str(entry), split, purpose, requires)
            else:
                raise InputError(f"{path.name}: not a model file ({', '.join(MODEL_SUFFIXES)}) "
                                 "or dataset")
        yield _named_by_path(sources, files)


def _named_by_path(sources: list[ModelSource], files: list[int]) -> list[ModelSource]:
    """``sources`` with the files at rows ``files`` that share a stem named by their paths
    under the folder those files share (:func:`~vptoolkit.conventions.model_name`)."""
    paths = [Path(os.path.abspath(sources[row].origin)) for row in files]
    by_stem: dict[str, list[int]] = {}
    for i, path in enumerate(paths):
        by_stem.setdefault(path.stem, []).append(i)
    named = list(sources)
    for group in by_stem.values():
        if len(group) < 2:
            continue
        common = Path(os.path.commonpath([paths[i].parent for i in group]))
        for i in group:
            named[files[i]] = replace(sources[files[i]],
                                      name=model_name(paths[i].relative_to(common).as_posix()))
    return named
