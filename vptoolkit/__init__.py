"""vptoolkit: find good viewpoints on 3D models.

Subpackages and modules, one concept each (``docs/architecture.md`` has every
module, layer by layer):

- ``errors``, ``conventions``, ``optional``, ``checks``, ``files``,
  ``progress``, ``parallel``: exception tree; measure order, view count,
  camera defaults and splits; lazy optional packages; argument checks;
  atomic writes and the JSON reader; the progress bar; the process pool.
  ``_numba`` (private): numba, imported once with the package's threading
  layer. ``_version`` (private): the version, written once.
- ``mesh``, ``point_cloud``, ``appearance``, ``io``, ``samples``,
  ``predictions``: the Mesh and PointCloud containers; a model's colours and
  texture, kept apart; reading models (decided by content) and writing
  meshes, OFF/OBJ/PLY/STL/glTF/NPY; small licensed sample meshes;
  ``Predictions`` (names and directions) and its ``.npz``.
- ``geometry``, ``point_areas``, ``cloud_sample``, ``sphere``, ``camera``, ``upright``,
  ``rotations``, ``settings``: face areas, bounding and principal frames; the
  surface area each point of a cloud stands for; the points a dataset stores
  of a cloud (its own, thinned or repeated, normals kept or fit); Fibonacci view directions and the
  principal-frame coarse sphere; the pinhole camera; a model's up axis;
  seeded rotations; ``MeasureSettings``, how the measures draw a model.
- ``visibility``: per-view, per-face pixel counts (numba rasteriser or
  Open3D ray casting), and per-point ones of point clouds (splats).
- ``measures``, ``view_sets``: VE, VR, VKL and VMI per view, normalised per
  model, and with occlusion ignored, in closed form; complementary view sets.
- ``clean``, ``points``, ``point_features``, ``scan``, ``synthetic``: the
  pymeshlab cleaning pipeline; surface and farthest point sampling; what each
  point carries from its mesh (the relative area of its face, found again for
  stored points by ``_face_location`` (private), a numba nearest-face
  kernel); partial, noisy clouds from virtual range scans; procedural
  category-like shapes.
- ``dataset``, ``data``, ``inputs``: building, packing and verifying datasets
  and releases; the light loader (numpy with zarr or h5py) and its torch
  adapter; the one router of model files (meshes, point clouds) and datasets.
  ``dataset_card`` holds no code: the dataset card template and
  ``SCHEMA.md``, the stores' data contract.
- ``learn``: the point network, its labels, training, prediction and prior.
- ``evaluate``, ``best_view``, ``predictors``: scoring directions the
  authors' way and the rotated protocol; the anytime best-view search within
  a budget of views (``search``), its priors by name (``prior``) and over
  many inputs (``run``); every predictor behind one call, found by name.
- ``collection``: best views and thumbnails of a whole collection of files,
  parallel, resumable, into one Parquet table.
- ``pictures``: shaded pictures, sphere maps, contact sheets, thumbnails and
  the HTML report.
- ``cli``: the ``vptool`` command line.
"""

from __future__ import annotations

from vptoolkit._version import __version__
from vptoolkit.best_view.answer import BestViews
from vptoolkit.best_view.search import SearchSettings, search_best_views
from vptoolkit.conventions import N_VIEWS
from vptoolkit.errors import (
    CheckpointError,
    ExistingRunError,
    InputError,
    MeasurementError,
    MeshLoadError,
    MissingDependencyError,
    VerificationError,
    VptoolkitError,
)
from vptoolkit.io import load_mesh, save_mesh
from vptoolkit.measures.quality import ViewQuality, compute_view_quality
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.mesh import Mesh
from vptoolkit.sphere import fibonacci_sphere, nearest_view

__all__ = [
    "BestViews",
    "PAPER_MEASURES",
    "SearchSettings",
    "N_VIEWS",
    "CheckpointError",
    "ExistingRunError",
    "InputError",
    "MeasurementError",
    "Mesh",
    "MeshLoadError",
    "MissingDependencyError",
    "VerificationError",
    "ViewQuality",
    "VptoolkitError",
    "__version__",
    "compute_view_quality",
    "fibonacci_sphere",
    "load_mesh",
    "nearest_view",
    "save_mesh",
    "search_best_views",
]
