"""Fixed conventions shared by every part of vptoolkit.

Measures
    Named by the registry (:mod:`vptoolkit.measures.registry`), the one
    vocabulary of measures; its ``PAPER_MEASURES = ("VE", "VR", "VKL",
    "VMI")`` is the order of every ``(..., 4)`` array of the paper's four.
    Normalised values are always in [0, 1] with 1 = best. Logarithms are
    base 2 (bits).

Splits
    ``SPLITS = ("train", "validation", "test")`` names the splits everywhere
    a user sees one; :data:`Split` is the one type of every ``split``
    argument, with None for every model.

Views
    ``N_VIEWS = 1000`` directions on the authors' Fibonacci sphere
    (:func:`vptoolkit.sphere.fibonacci_sphere`). A view direction ``v`` is a
    unit vector from the model's bounding-box centre towards the camera.

Model names
    A model built from a source folder (``vptool build-dataset``) is named
    by its path relative to that folder without the file suffix, the path's
    parts joined by ``NAME_SEPARATOR = "__"``: ``SRC/teapot.stl`` is
    ``teapot``, ``SRC/a/teapot.stl`` is ``a__teapot`` and
    ``SRC/airplane/train/airplane_0001.off`` is
    ``airplane__train__airplane_0001``. The separator is not ``/`` because
    a name is also one file or folder name (an exported mesh, a store
    record checked by :func:`vptoolkit.files.check_path_part`). Names are
    unique within a dataset; two files that give one name (``a.off`` and
    ``a.obj``, or ``a/b.off`` and ``a__b.off``) are both refused.

Releases
    ``DATASET_VERSION = "1.0.0"`` is the version a release gets unless it is
    given one (:func:`vptoolkit.dataset.release.pack.pack_release`, ``vptool pack
    --version``), in its attributes, file names, card and Croissant.

Camera (defaults of :class:`vptoolkit.camera.Camera`)
    Perspective, square image of ``RESOLUTION`` pixels a side, vertical field
    of view ``FOV_DEG`` degrees, looking at the bounding-box centre ``c`` from
    ``c + d v`` with ``d = DISTANCE_FACTOR * diagonal``, image up vector
    ``UP`` (``FALLBACK_UP`` where ``v`` is parallel to ``UP``), back faces
    culled (counter-clockwise winding is the front, right-hand rule).

Exported cameras and pictures
    Poses handed to other renderers (:meth:`vptoolkit.camera.ViewPoses.camera_to_world`,
    :meth:`vptoolkit.best_view.answer.BestViews.camera_pose`) put ``PICTURE_UP``
    at the top of the image, as Open3D, trimesh and glTF do; the measures keep
    ``UP`` inside, so their values do not depend on it.
"""

from __future__ import annotations

import math
from pathlib import PurePosixPath
from typing import Final, Literal, TypeAlias

__all__ = [
    "N_VIEWS",
    "RESOLUTION",
    "SEED",
    "SPLITS",
    "Split",
    "NAME_SEPARATOR",
    "model_name",
    "DATASET_VERSION",
    "FOV_DEG",
    "DISTANCE_FACTOR",
    "UP",
    "FALLBACK_UP",
    "PICTURE_UP",
]

N_VIEWS: Final = 1000
"""Number of candidate views on the Fibonacci sphere (the paper's choice)."""

RESOLUTION: Final = 1024
"""Side of the square triangle-ID image in pixels (the paper's choice)."""

SEED: Final = 0
"""Default seed of every seeded choice the command line offers (sampling, splits, training)."""

SPLITS: Final = ("train", "validation", "test")
"""The split names, one vocabulary everywhere a user sees one.

The loader (:mod:`vptoolkit.data`), the dataset card, Croissant, the Parquet
shards, ``vptool info`` and the CLI say ``"validation"``, as the Hugging Face
hub does. A store or build of schema 1 may record ``"val"``;
:func:`vptoolkit.dataset.store.schema.published_split` maps it, and every API that
takes a split accepts ``"val"`` as an alias.
"""

Split: TypeAlias = Literal["train", "validation", "val", "test"] | None
"""A ``split`` argument: one split of :data:`SPLITS` (``"val"`` an alias of
``"validation"``), or None for every model. The command line's ``--split all``
is None (:func:`vptoolkit.cli.options.split_option`)."""

NAME_SEPARATOR: Final = "__"
"""Joins the folder parts and the file stem of a model's path into its name (see above)."""


def model_name(relative: str) -> str:
    """The name of the model at ``relative``, a ``/``-separated path under the folder given.

    The path without its last suffix, its parts joined by :data:`NAME_SEPARATOR`;
    a file directly in the folder keeps its stem.

    Examples
    --------
    >>> model_name("teapot.stl"), model_name("a/teapot.stl")
    ('teapot', 'a__teapot')
    """
    parts = PurePosixPath(relative).parts
    return NAME_SEPARATOR.join((*parts[:-1], PurePosixPath(parts[-1]).stem))

DATASET_VERSION: Final = "1.0.0"
"""Version ``MAJOR.MINOR.PATCH`` of a release packed without one."""

FOV_DEG: Final = 45.0
"""Vertical (and, the image being square, horizontal) field of view in degrees."""

DISTANCE_FACTOR: Final = 1.0 / math.sin(math.radians(45.0))
"""Camera distance from the bounding-box centre, in bounding-box diagonals."""

UP: Final = (0.0, -1.0, 0.0)
"""Image up vector in model coordinates (the authors' renderer)."""

FALLBACK_UP: Final = (0.0, 0.0, 1.0)
"""Up vector used where the view direction is parallel to :data:`UP`."""


PICTURE_UP: Final = (0.0, 1.0, 0.0)
"""Image up of exported camera poses and of pictures, in model coordinates (+y, as
Open3D, trimesh and glTF)."""
