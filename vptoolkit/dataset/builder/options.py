"""What defines a built dataset: one frozen, validated value, ``BuildOptions``.

The same value is the argument of :func:`~vptoolkit.dataset.builder.run.build_dataset`
and :func:`~vptoolkit.dataset.builder.plan.plan_build`, the options of every
model's task (:class:`~vptoolkit.dataset.builder.compute.ModelTask`), the record
of the staging folder (``build.json``: :meth:`BuildOptions.to_dict`; a
resumed build compares ``BuildOptions.from_dict(recorded) == options``)
and the options part of the store's attributes
(:meth:`BuildOptions.store_attrs`). Every default is a named constant of
its owner: ``N_VIEWS``, ``RESOLUTION`` and ``Camera()`` through
:class:`~vptoolkit.settings.MeasureSettings`, the paper's four measures
(:data:`~vptoolkit.measures.registry.PAPER_MEASURES`), ``N_SURFACE_POINTS``,
``MAX_FACES``, ``MAX_POINTS``, ``SEED`` and :data:`DEFAULT_FORMAT`.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final, Literal

from vptoolkit.checks import as_path, check_bool, check_int, check_keys
from vptoolkit.clean.simplify import MAX_FACES
from vptoolkit.conventions import SEED
from vptoolkit.errors import InputError
from vptoolkit.measures.registry import PAPER_MEASURES, resolve_measures
from vptoolkit.point_cloud import MAX_POINTS
from vptoolkit.points import MAX_SURFACE_POINTS, N_SURFACE_POINTS
from vptoolkit.settings import MeasureSettings, check_settings

__all__ = ["DEFAULT_FORMAT", "FORMATS", "BuildOptions", "SplitFile", "StoreFormat",
           "checked_measures"]

StoreFormat = Literal["zarr", "hdf5"]

FORMATS: Final[dict[str, str]] = {"zarr": "dataset.zarr", "hdf5": "dataset.h5"}
"""Store file name inside OUT for each ``format``."""

DEFAULT_FORMAT: Final = "zarr"
"""Store format of a build unless it is given one."""

_KEYS = ("format", "measure", "measures", "n_points", "max_faces", "clean", "remesh",
         "split_seed", "splits_sha256", "max_models", "max_points", "sampling")

SAMPLINGS: Final = ("uniform", "scan")
"""How a mesh's stored points are taken (:attr:`BuildOptions.sampling`)."""


@dataclass(frozen=True)
class SplitFile:
    """A published split file, known by the SHA-256 of its bytes.

    Two split files are the same when their bytes are: a build resumed with
    an edited file is refused like one with another seed.

    Attributes
    ----------
    sha256 : str
        SHA-256 of the file's bytes, 64 lowercase hex digits.
    path : Path or None
        Where the file was read (not compared); None for one rebuilt from
        a record.
    """

    sha256: str
    path: Path | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        digest = self.sha256
        if not (isinstance(digest, str) and len(digest) == 64
                and all(c in "0123456789abcdef" for c in digest)):
            raise InputError(f"splits_sha256: expected 64 lowercase hex digits, got {digest!r}")

    @classmethod
    def read(cls, path: str | os.PathLike[str]) -> SplitFile:
        """The split file at ``path`` (its bytes are hashed here)."""
        checked = as_path(path, "splits")
        try:
            digest = hashlib.sha256(checked.read_bytes()).hexdigest()
        except OSError as err:
            raise InputError(
                f"{checked}: cannot read the split file ({err.strerror or err})") from err
        return cls(sha256=digest, path=checked)


def checked_measures(measures: str | Iterable[str]) -> tuple[str, ...]:
    """The measure names of a build: :func:`~vptoolkit.measures.registry.resolve_measures`
    of ``measures`` (names, ``"VE,SL"``, ``"paper"`` or ``"all"``).

    Raises
    ------
    InputError
        One line starting ``measures:``, naming an unknown or repeated name.
    """
    try:
        return resolve_measures(measures)
    except InputError as err:
        raise InputError(f"measures: {str(err).removeprefix('measures: ')}") from err


@dataclass(frozen=True)
class BuildOptions:
    """The options that define a built dataset, checked once when made.

    Parameters
    ----------
    measure : MeasureSettings
        Views, triangle-ID image side, camera and backend of the measures
        (default: ``MeasureSettings()``: 1000 views at 1024 px, raster).
    measures : tuple of str
        The measures every model gets, the columns of the store's ``quality``,
        ``quality_raw``, ``best_*`` and ``worst_*`` in this order (the root
        attribute ``measures``): registered, distinct names
        (:func:`checked_measures` turns ``"VE,SL"``, ``"paper"`` or ``"all"``
        into them; default: the paper's four, VE, VR, VKL and VMI).
    n_points : int
        Surface points per model, 1 to ``MAX_SURFACE_POINTS`` (default:
        ``N_SURFACE_POINTS`` = 20000).
    max_faces : int
        Face budget of the cleaned meshes, at least 4 (default: ``MAX_FACES`` = 10000).
    clean : bool
        Clean each mesh before measuring (default: True).
    remesh : bool
        Also remesh isotropically in the last cleaning step; needs ``clean``
        (:func:`vptoolkit.clean.clean_mesh`; default: False). Viewpoint
        entropy depends on the tessellation: shapes assembled from a few
        large faces (``vptoolkit.synthetic``) reward views that scanned or
        decimated real meshes do not, and remeshing removes that difference
        (on 16 procedural shapes the PCA view scores 41 % VE against 64 % for
        a random view as assembled, 79 % against 78 % remeshed).
    split_seed : int
        Seed of the split and of every model's point sample (default: ``SEED`` = 0).
    splits : SplitFile, optional
        A published split to use instead of the seeded one
        (:func:`~vptoolkit.dataset.builder.split_files.read_split_file`; made with
        :meth:`SplitFile.read`): a ``name,split`` CSV, or the paper authors'
        ``small.txt`` with their rule over the lines of the build's
        ``categories`` (default: None, the seeded split).
    max_models : int, optional
        Build only this many models, taken in turn from each category
        (:func:`~vptoolkit.dataset.builder.sources.spread_over_categories`); their
        splits are those of the whole source, and models with duplicate names
        are left out instead of recorded as failures (default: None, every model).
    format : {"zarr", "hdf5"}
        Store format (default: ``DEFAULT_FORMAT`` = "zarr").
    max_points : int
        Most points a point cloud file keeps, at least 1; a larger one is
        thinned on reading (:func:`vptoolkit.io.load`; default: ``MAX_POINTS``
        = 20 million). Meshes are never thinned.
    sampling : {"uniform", "scan"}
        How a mesh's ``n_points`` stored points are taken (default:
        "uniform"): area-uniform on its surface
        (:func:`vptoolkit.points.sample_surface`), or a virtual scan of it
        (:func:`vptoolkit.scan.virtual_scan`: 3 range images of
        ``SCAN_RESOLUTION`` px from seeded directions, range noise
        ``SCAN_NOISE`` of the diagonal, seeded by the model's sample seed),
        drawn to ``n_points`` by :func:`vptoolkit.cloud_sample.sample_cloud`'s
        rule (distinct points when the scan has more, every point and repeats
        when it has fewer), each with the normal of the face it lies on. The
        labels are the mesh's either way: a store of scans trains a network
        on the partial, uneven points a scanner gives. A point cloud keeps its
        own points.

    Raises
    ------
    InputError
        A one-line message naming the field, e.g. ``n_points: must be at least 1, got 0``
        or ``measures: unknown measure 'XY'; known: ...``.
    """

    measure: MeasureSettings = field(default_factory=MeasureSettings)
    measures: tuple[str, ...] = PAPER_MEASURES
    n_points: int = N_SURFACE_POINTS
    max_faces: int = MAX_FACES
    clean: bool = True
    remesh: bool = False
    split_seed: int = SEED
    splits: SplitFile | None = None
    max_models: int | None = None
    format: StoreFormat = DEFAULT_FORMAT
    max_points: int = MAX_POINTS
    sampling: str = "uniform"

    def __post_init__(self) -> None:
        checked: dict[str, Any] = {
            "measure": check_settings(self.measure, "measure"),
            "measures": checked_measures(self.measures),
            "n_points": check_int(self.n_points, "n_points", minimum=1,
                                  maximum=MAX_SURFACE_POINTS),
            "max_faces": check_int(self.max_faces, "max_faces", minimum=4),
            "clean": check_bool(self.clean, "clean"),
            "remesh": check_bool(self.remesh, "remesh"),
            "split_seed": check_int(self.split_seed, "split_seed"),
            "max_models": None if self.max_models is None
            else check_int(self.max_models, "max_models", minimum=1),
            "max_points": check_int(self.max_points, "max_points", minimum=1),
        }
        for name, value in checked.items():
            object.__setattr__(self, name, value)
        if self.splits is not None and not isinstance(self.splits, SplitFile):
            raise InputError(f"splits: expected a SplitFile (SplitFile.read(path)), got "
                             f"{type(self.splits).__name__}")
        if self.format not in FORMATS:
            raise InputError(
                f"format: expected one of {', '.join(FORMATS)}, got {self.format!r}")
        if self.sampling not in SAMPLINGS:
            raise InputError(f"sampling: expected one of {', '.join(SAMPLINGS)}, got "
                             f"{self.sampling!r}")
        if self.remesh and not self.clean:
            raise InputError("remesh: remeshing is a cleaning step; it needs clean=True")

    @property
    def store_name(self) -> str:
        """File name of the store inside OUT (``dataset.zarr`` or ``dataset.h5``)."""
        return FORMATS[self.format]

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe record (the staging folder's ``build.json`` holds it)."""
        return {
            "format": self.format,
            "measure": self.measure.to_dict(),
            "measures": list(self.measures),
            "n_points": self.n_points,
            "max_faces": self.max_faces,
            "clean": self.clean,
            "remesh": self.remesh,
            "split_seed": self.split_seed,
            "splits_sha256": None if self.splits is None else self.splits.sha256,
            "max_models": self.max_models,
            "max_points": self.max_points,
            "sampling": self.sampling,
        }

    @classmethod
    def from_dict(cls, record: dict[str, Any]) -> BuildOptions:
        """The options of a :meth:`to_dict` record; a missing or unknown key is an InputError.

        A record made before builds chose their measures has no ``measures``: the
        paper's four, which it was built with; one made before point clouds were
        thinned by option has no ``max_points``: ``MAX_POINTS``, which it read with;
        one made before scans has no ``sampling``: "uniform".
        """
        if isinstance(record, dict) and "measures" not in record:
            record = {**record, "measures": list(PAPER_MEASURES)}
        if isinstance(record, dict) and "max_points" not in record:
            record = {**record, "max_points": MAX_POINTS}
        if isinstance(record, dict) and "sampling" not in record:
            record = {**record, "sampling": "uniform"}
        record = check_keys(record, _KEYS, "build options")
        digest = record["splits_sha256"]
        return cls(
            measure=MeasureSettings.from_dict(record["measure"]),
            measures=record["measures"],
            n_points=record["n_points"],
            max_faces=record["max_faces"],
            clean=record["clean"],
            remesh=record["remesh"],
            split_seed=record["split_seed"],
            splits=None if digest is None else SplitFile(sha256=digest),
            max_models=record["max_models"],
            format=record["format"],
            max_points=record["max_points"],
            sampling=record["sampling"],
        )

    def store_attrs(self) -> dict[str, Any]:
        """The store attributes these options define (``vptoolkit/dataset_card/SCHEMA.md``).

        ``measures``, ``resolution``, ``backend``, ``camera``, ``cleaning``
        (``enabled``, ``max_faces``, ``remesh``), ``split_seed`` and, with
        ``splits``, ``split_file`` (``name``, ``sha256``), and with scanned
        points, ``sampling`` (``"scan"``); the writer adds
        ``higher_is_better`` from the registry, and ``n_views`` and
        ``n_points`` from the arrays.
        """
        attrs: dict[str, Any] = {
            "measures": list(self.measures),
            "resolution": self.measure.resolution,
            "backend": self.measure.backend,
            "camera": self.measure.camera.to_dict(),
            "cleaning": {"enabled": self.clean, "max_faces": self.max_faces,
                         "remesh": self.remesh},
            "split_seed": self.split_seed,
        }
        if self.splits is not None:
            name = self.splits.path.name if self.splits.path is not None else None
            attrs["split_file"] = {"name": name, "sha256": self.splits.sha256}
        if self.sampling != "uniform":
            attrs["sampling"] = self.sampling
        return attrs
