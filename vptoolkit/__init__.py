"""vptoolkit: find good viewpoints on 3D models.

Subpackages and modules, one concept each:

- ``errors``, ``conventions``, ``optional``: exception tree; measure order,
  view count and camera defaults; lazy access to heavy optional packages.
- ``mesh``, ``io``, ``samples``: the Mesh container; reading and writing
  OFF/OBJ/PLY/STL/glTF; small licensed sample meshes.
- ``geometry``, ``sphere``, ``camera``: face areas and bounding frame;
  Fibonacci view directions; the pinhole camera.
- ``visibility``: per-view, per-face pixel counts (numba rasteriser or
  Open3D ray casting).
- ``measures``: VE, VR, VKL and VMI per view, normalised per model.
- ``best_view``: the anytime best-view search within a budget of drawn views.
- ``clean``, ``points``: pymeshlab cleaning pipeline; surface sampling and
  farthest point sampling.
- ``cli``: the ``vptool`` command line.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from vptoolkit.best_view import BestViews, search_best_views
from vptoolkit.conventions import MEASURES, N_VIEWS
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
from vptoolkit.measures import ViewQuality, compute_view_quality
from vptoolkit.mesh import Mesh
from vptoolkit.sphere import fibonacci_sphere, nearest_view

try:
    __version__ = version("vptoolkit")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0"

__all__ = [
    "BestViews",
    "MEASURES",
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
