"""The result of a view-set search: the chosen views, their gains, and their files.

:class:`ViewSet` holds the views in selection order with the coverage and
objective after each, and writes itself as a JSON record (the build stores
one per model) or an ``.npz`` file.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.checks import check_int, check_suffix
from vptoolkit.errors import InputError
from vptoolkit.files import atomic_write
from vptoolkit.view_sets.visibility import MIN_PIXELS

__all__ = ["ViewSet"]


@dataclass(frozen=True, eq=False)
class ViewSet:
    """Views chosen together, in selection order.

    Attributes
    ----------
    name : str
        Name of the model.
    objective : str
        ``"coverage"``, ``"information"`` or ``"quality"``.
    indices : (k,) int64
        Chosen rows of ``views``, in selection order.
    directions : (k, 3) float64
        Their unit directions (model centre towards the camera).
    score : (k,) float64
        The objective after each pick: coverage fraction (``"coverage"``,
        ``"quality"``) or entropy in bits (``"information"``).
    coverage : (k,) float64
        Area-weighted fraction of the surface seen after each pick.
    reachable : float
        Coverage of all sampled views together (the most any set reaches).
    n_views : int
        Number of sampled views searched.
    min_pixels : int
        Pixels a face needs in a view to count as seen.
    measure : str or None
        Measure of the ``"quality"`` objective, else None.
    """

    name: str
    objective: str
    indices: NDArray[np.int64]
    directions: NDArray[np.float64]
    score: NDArray[np.float64]
    coverage: NDArray[np.float64]
    reachable: float
    n_views: int
    min_pixels: int = MIN_PIXELS
    measure: str | None = None

    def __len__(self) -> int:
        return int(len(self.indices))

    def summary(self) -> dict[str, Any]:
        """JSON-safe record: one entry per pick with view, direction and cumulative values."""
        return {
            "name": self.name,
            "objective": self.objective,
            "measure": self.measure,
            "n_views": self.n_views,
            "min_pixels": self.min_pixels,
            "reachable": round(float(self.reachable), 6),
            "picks": [
                {
                    "pick": position + 1,
                    "view_index": int(index),
                    "direction": [round(float(c), 6) for c in direction],
                    "score": round(float(score), 6),
                    "coverage": round(float(coverage), 6),
                }
                for position, (index, direction, score, coverage) in enumerate(
                    zip(self.indices, self.directions, self.score, self.coverage))
            ],
        }

    def record(self) -> dict[str, Any]:
        """The set as a dataset's model record stores it (JSON types, 6 decimals).

        ``{"objective", "min_pixels", "indices", "coverage", "reachable"}``;
        :meth:`from_record` reads it back.
        """
        return {
            "objective": self.objective,
            "min_pixels": self.min_pixels,
            "indices": [int(i) for i in self.indices],
            "coverage": [round(float(c), 6) for c in self.coverage],
            "reachable": round(float(self.reachable), 6),
        }

    @classmethod
    def from_record(cls, record: dict[str, Any], views: ArrayLike, *, name: str,
                    k: int | None = None) -> ViewSet:
        """A set from :meth:`record`'s form and the views its indices refer to.

        Parameters
        ----------
        record : dict
            As :meth:`record` writes it.
        views : (n_views, 3) array_like
            The sampled views of the dataset.
        name : str
            Name of the model.
        k : int, optional
            Keep the first ``k`` picks only (a greedy set's prefix is the
            greedy set for fewer views).
        """
        directions = np.asarray(views, dtype=np.float64)  # as stored, not renormalised
        if directions.ndim != 2 or directions.shape[1] != 3:
            raise InputError(f"views: expected shape (n_views, 3), got {directions.shape}")
        try:
            indices = np.asarray(record["indices"], dtype=np.int64)
            coverage = np.asarray(record["coverage"], dtype=np.float64)
            objective, reachable = str(record["objective"]), float(record["reachable"])
            min_pixels = int(record["min_pixels"])
        except (KeyError, TypeError, ValueError) as err:
            raise InputError(f"{name}: view_set record is malformed ({err})") from err
        if indices.ndim != 1 or indices.shape != coverage.shape or (
                len(indices) and not 0 <= indices.min() <= indices.max() < len(directions)):
            raise InputError(f"{name}: view_set record does not fit {len(directions)} views")
        keep = len(indices) if k is None else check_int(k, "k", minimum=1)
        return cls(name=name, objective=objective, indices=indices[:keep],
                   directions=directions[indices[:keep]], score=coverage[:keep],
                   coverage=coverage[:keep], reachable=reachable, n_views=len(directions),
                   min_pixels=min_pixels)

    def save_npz(self, path: str | os.PathLike[str]) -> Path:
        """Write the set to an ``.npz`` (``indices``, ``directions``, ``score``,
        ``coverage``, ``reachable``, ``objective``, ``summary`` as JSON), atomically."""
        target = check_suffix(path, ".npz")
        with atomic_write(target) as handle:
            np.savez(
                handle,
                indices=self.indices,
                directions=self.directions,
                score=self.score,
                coverage=self.coverage,
                reachable=np.float64(self.reachable),
                objective=np.str_(self.objective),
                name=np.str_(self.name),
                summary=np.str_(json.dumps(self.summary(), sort_keys=True)),
            )
        return target
