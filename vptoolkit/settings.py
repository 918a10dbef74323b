"""How the measures draw a model: one frozen, validated value, ``MeasureSettings``.

The views, the triangle-ID image side, the camera and the pixel counting
backend travel together from the command line to the rasteriser; every range
check on them is here, in :meth:`MeasureSettings.__post_init__`, and the value
is stored beside results as a JSON record (:meth:`MeasureSettings.to_dict`).
Every public function that takes the value checks it with
:func:`check_settings`, so anything else is refused in one line.
Defaults come from :mod:`vptoolkit.conventions` (``N_VIEWS`` views,
``RESOLUTION`` pixels, ``Camera()``) and ``"raster"``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Final, Literal

import numpy as np
from numpy.typing import NDArray

from vptoolkit.camera import Camera
from vptoolkit.checks import check_int, check_keys
from vptoolkit.conventions import N_VIEWS, RESOLUTION
from vptoolkit.errors import InputError
from vptoolkit.sphere import fibonacci_sphere

__all__ = ["BACKENDS", "Backend", "MAX_RESOLUTION", "MeasureSettings", "check_settings"]

Backend = Literal["raster", "raycast"]
BACKENDS: Final[tuple[str, ...]] = ("raster", "raycast")
"""Pixel counting backends: the numba rasteriser (default) and Open3D's ray casting."""

MAX_RESOLUTION: Final = 16384
"""Largest triangle-ID image side in pixels (one int64 frame of it is 2 GiB)."""

_KEYS = ("views", "resolution", "camera", "backend")


@dataclass(frozen=True)
class MeasureSettings:
    """How the measures draw a model, checked once when made.

    Parameters
    ----------
    views : int
        Number of view directions on the Fibonacci sphere, at least 1
        (default: ``N_VIEWS`` = 1000).
    resolution : int
        Side of the square triangle-ID image in pixels, 1 to ``MAX_RESOLUTION``
        (default: ``RESOLUTION`` = 1024).
    camera : Camera
        Camera conventions (default: ``Camera()``).
    backend : {"raster", "raycast"}
        Pixel counting backend (default: ``"raster"``).

    Raises
    ------
    InputError
        A one-line message naming the field, e.g.
        ``resolution: must be at most 16384, got 20000``.

    Examples
    --------
    >>> MeasureSettings(views=100, resolution=64).to_dict()["views"]
    100
    """

    views: int = N_VIEWS
    resolution: int = RESOLUTION
    camera: Camera = field(default_factory=Camera)
    backend: Backend = "raster"

    def __post_init__(self) -> None:
        object.__setattr__(self, "views", check_int(self.views, "views", minimum=1))
        object.__setattr__(self, "resolution", check_int(
            self.resolution, "resolution", minimum=1, maximum=MAX_RESOLUTION))
        if not isinstance(self.camera, Camera):
            raise InputError(f"camera: expected a Camera, got {type(self.camera).__name__}")
        if self.backend not in BACKENDS:
            raise InputError(
                f"backend: must be one of {', '.join(BACKENDS)}, got {self.backend!r}")

    def directions(self) -> NDArray[np.float64]:
        """The ``views`` Fibonacci-sphere directions, ``(views, 3) float64``."""
        return fibonacci_sphere(self.views)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe record: ``views``, ``resolution``, ``camera`` (its record), ``backend``."""
        return {"views": self.views, "resolution": self.resolution,
                "camera": self.camera.to_dict(), "backend": self.backend}

    @classmethod
    def from_dict(cls, record: dict[str, Any]) -> MeasureSettings:
        """The settings of a :meth:`to_dict` record; a missing or unknown key is an InputError."""
        record = check_keys(record, _KEYS, "measure settings")
        camera = record["camera"]
        if not isinstance(camera, dict):
            raise InputError(f"camera: expected a mapping, got {type(camera).__name__}")
        return cls(views=record["views"], resolution=record["resolution"],
                   camera=Camera.from_dict(camera), backend=record["backend"])


def check_settings(value: object, name: str = "settings") -> MeasureSettings:
    """Return ``value`` if it is a :class:`MeasureSettings`, else raise a one-line InputError.

    An integer is the old positional number of views, so its message says
    what to pass instead, e.g. ``settings: expected MeasureSettings, got int
    100 (pass MeasureSettings(views=100))``.
    """
    if isinstance(value, MeasureSettings):
        return value
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        raise InputError(f"{name}: expected MeasureSettings, got int {value} "
                         f"(pass MeasureSettings(views={value}))")
    raise InputError(f"{name}: expected MeasureSettings, got {type(value).__name__}")
