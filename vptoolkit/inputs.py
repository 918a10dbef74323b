"""The one input router: which inputs are mesh files, point files or datasets, and their models.

Every command that takes "meshes, point files or a dataset" (``vptool
predict``, ``predict --model unoccluded``, ``best-view``) reads its inputs
through :func:`open_inputs`, so one rule decides what an input is:

``*.npy``
    a point file: an ``(N, 3)`` or ``(N, 6)`` float array, ``x y z`` first
    (``nx ny nz`` next when present; :mod:`vptoolkit.points`);
mesh files (``.off``, ``.obj``, ``.ply``, ``.stl``, ``.glb``, ``.gltf``)
    :func:`vptoolkit.io.load_mesh`;
a :class:`~vptoolkit.data.ViewpointDataset`, a dataset store or folder, or a release's URL
    every model of ``split`` (``None``: every model), opened with
    :func:`vptoolkit.data.open_dataset` and closed when the ``with`` block ends;

anything else is an :class:`~vptoolkit.errors.InputError`. A model is named
by its file's stem, or by its name in the dataset; names must be unique over
all inputs, and :func:`claim_name` is the one check (and message) for that.
Nothing is read until a :class:`ModelSource` is asked for its mesh, points or
normals, so a caller can record a bad model and carry on.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal, TypeAlias

import numpy as np
from numpy.typing import NDArray

from vptoolkit.errors import InputError
from vptoolkit.mesh import Mesh

if TYPE_CHECKING:
    from vptoolkit.data import ViewpointDataset

__all__ = ["InputKind", "ModelSource", "claim_name", "open_inputs"]

InputKind: TypeAlias = Literal["mesh", "points", "stored"]
"""What a model comes from: a mesh file, a point file or a dataset."""



@dataclass(frozen=True)
class ModelSource:
    """One model of the inputs, not yet read.

    Attributes
    ----------
    name : str
        The file's stem, or the model's name in its dataset.
    kind : {"mesh", "points", "stored"}
        A mesh file, a point file or a model stored in a dataset.
    origin : str
        The input as given: the file, or the dataset (for messages).
    category : str or None
        The dataset's category of a stored model; None for files.
    dataset : ViewpointDataset or None
        The split a stored model is read from (open while the router's
        ``with`` block lasts); None for files.
    position : int
        The stored model's row in ``dataset``; -1 for files.
    """

    name: str
    kind: InputKind
    origin: str
    category: str | None = None
    dataset: ViewpointDataset | None = field(default=None, repr=False, compare=False)
    position: int = -1

    @property
    def label(self) -> str:
        """Where the model comes from, for a batch's failure list: the file, or the model's name."""
        return self.name if self.kind == "stored" else self.origin

    def _stored(self) -> ViewpointDataset:
        if self.dataset is None:
            raise InputError(f"{self.origin}: {self.name!r} is not a stored model")
        return self.dataset

    def mesh(self) -> Mesh:
        """The mesh: the file read by :func:`vptoolkit.io.load_mesh` (its errors), or the stored,
        cleaned mesh."""
        if self.kind == "stored":
            vertices, faces = self._stored().mesh(self.name)
            return Mesh(vertices.astype(np.float64), faces.astype(np.int64), name=self.name)
        from vptoolkit.io import load_mesh

        return load_mesh(self.origin)

    def points(self, *, seed: int) -> NDArray[np.float64]:
        """Surface points ``(n, 3) float64``: the stored ones, a point file's, or
        ``N_SURFACE_POINTS`` sampled from a mesh file with ``seed``
        (:func:`vptoolkit.points.sample_surface`)."""
        from vptoolkit.points import N_SURFACE_POINTS, read_point_file, sample_surface

        if self.kind == "stored":
            return np.asarray(self._stored()[self.position]["points"], dtype=np.float64)
        path = Path(self.origin)
        if not path.is_file():
            raise InputError(f"{path}: no such {'point' if self.kind == 'points' else 'mesh'} file")
        if self.kind == "points":
            return np.asarray(read_point_file(path), dtype=np.float64)
        return sample_surface(self.mesh(), N_SURFACE_POINTS, seed=seed).points

    def normals(self) -> NDArray[np.float64]:
        """Point normals ``(n, 3) float64`` as stored or as in an ``(N, 6)`` point file (not
        made unit length); a mesh file has face normals instead (:mod:`vptoolkit.geometry`)."""
        if self.kind == "stored":
            return np.asarray(self._stored()[self.position]["normals"], dtype=np.float64)
        if self.kind == "mesh":
            raise InputError(f"{self.origin}: a mesh file has no point normals")
        from vptoolkit.points import read_point_normals

        return np.asarray(read_point_normals(Path(self.origin))[1], dtype=np.float64)


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
                    purpose: str | None) -> list[ModelSource]:
    """The models of ``split`` of one dataset (every model for None): the one split rule."""
    subset = dataset.split(split) if split is not None else dataset
    if purpose is not None and not len(subset.names):
        which = "the dataset" if split is None else f"split {split!r}"
        raise InputError(f"{origin}: {which} holds no models; nothing to {purpose}")
    return [ModelSource(str(name), "stored", origin, category, subset, position)
            for position, (name, category) in enumerate(zip(subset.names, subset.categories))]


@contextlib.contextmanager
def open_inputs(inputs: (str | os.PathLike[str] | ViewpointDataset
                         | Sequence[str | os.PathLike[str] | ViewpointDataset]),
                *, split: str | None = "test",
                purpose: str | None = None) -> Iterator[list[ModelSource]]:
    """The models of mesh files, point files and datasets, in input order.

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

    Yields
    ------
    sources : list of ModelSource
        Datasets opened here are closed when the block ends.

    Raises
    ------
    InputError
        Naming the input: neither a mesh, a point file nor a dataset; a
        dataset that cannot be opened, an unknown split or (with ``purpose``)
        an empty one.
    """
    from vptoolkit.data import ViewpointDataset, open_dataset
    from vptoolkit.data.remote import is_remote
    from vptoolkit.io import SUPPORTED_SUFFIXES

    entries = [inputs] if isinstance(inputs, (str, os.PathLike, ViewpointDataset)) else inputs
    with contextlib.ExitStack() as stack:
        sources: list[ModelSource] = []
        for entry in entries:
            if isinstance(entry, ViewpointDataset):
                sources += _stored_sources(entry, str(entry.path), split, purpose)
                continue
            if not isinstance(entry, (str, os.PathLike)):
                raise InputError("inputs: expected paths or a ViewpointDataset, "
                                 f"got {type(entry).__name__}")
            path = Path(entry)
            suffix = path.suffix.lower()
            if isinstance(entry, str) and is_remote(entry):
                opened = stack.enter_context(open_dataset(entry))
                sources += _stored_sources(opened, entry, split, purpose)
            elif suffix == ".npy":
                sources.append(ModelSource(path.stem, "points", str(entry)))
            elif suffix in SUPPORTED_SUFFIXES:
                sources.append(ModelSource(path.stem, "mesh", str(entry)))
            elif _is_dataset(path):
                opened = stack.enter_context(open_dataset(path))
                sources += _stored_sources(opened, str(entry), split, purpose)
            else:
                raise InputError(f"{path.name}: not a mesh ({', '.join(SUPPORTED_SUFFIXES)}), "
                                 "point file (.npy) or dataset")
        yield sources
