"""The registry of viewpoint quality measures.

Every measure is a :class:`Measure` value declared in one small module of
:mod:`vptoolkit.measures.catalog` as its module attribute ``MEASURE``; the
registry finds the modules of that package itself, so adding a measure is
adding one module. Names are the short names of Bonaventura et al. (2018)
(``"VE"``, ``"SL"``, ...) and are the names stored in files.

The registry is the one vocabulary of measures: every function, file and
command-line flag that takes a measure takes any registered name, or refuses
one that cannot serve there in one line with the reason. Names are accepted
in any case and reported in the registry's spelling (``"ve"`` is ``"VE"``,
:func:`canonical_name`). Two presets name several measures at once
(:data:`PRESETS`): ``"paper"``, the paper's four (:data:`PAPER_MEASURES`),
and ``"all"``, every registered measure.

What a measure reads is declared in :attr:`Measure.needs`, one or more of
:data:`NEEDS`; :func:`vptoolkit.measures.compute_view_quality` draws and
computes only what the requested measures need.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING, Final

import numpy as np
from numpy.typing import NDArray

from vptoolkit.errors import InputError

if TYPE_CHECKING:
    from vptoolkit.measures.data import ViewData

__all__ = [
    "FAMILIES",
    "IMAGE_NEEDS",
    "NEEDS",
    "PAPER_MEASURES",
    "PRESETS",
    "Measure",
    "all_measures",
    "canonical_name",
    "get_measure",
    "measure_index",
    "resolve_measures",
]

PAPER_MEASURES: Final = ("VE", "VR", "VKL", "VMI")
"""The paper's four measures, the preset ``"paper"``, in the fixed order of every
``(..., 4)`` array of the paper's measures and of the dataset store's stored arrays:
VE (viewpoint entropy) and VR (visibility ratio), higher is better; VKL
(viewpoint Kullback-Leibler divergence) and VMI (viewpoint mutual information),
lower is better."""

PRESETS: Final = ("paper", "all")
"""Words that name several measures (:func:`resolve_measures`), in any case:
``"paper"`` the paper's four (:data:`PAPER_MEASURES`), ``"all"`` every registered
measure in the registry's order."""

FAMILIES: Final = ("area", "information", "silhouette", "depth", "stability", "surface")
"""The survey's families, in the order ``--measures all`` lists them."""

NEEDS: Final = frozenset({"pixels", "depth", "silhouette", "curvature", "saliency", "neighbours"})
"""What a measure can need.

``pixels``
    the per-face pixel counts ``a_z(v)`` of every view (always drawn);
``depth``
    per-view depth statistics (histogram, maximum, a small depth image);
``silhouette``
    per-view silhouette statistics (contour length, turning angles);
``curvature``
    a per-face curvature of the mesh, computed once per mesh;
``saliency``
    a per-face saliency of the mesh, computed once per mesh from all views;
``neighbours``
    the neighbouring views of each view on the sphere.
"""


IMAGE_NEEDS: Final = frozenset({"depth", "silhouette"})
"""The needs that the drawing pass serves with per-view image statistics
(``iter_view_histograms(..., features=True)``)."""


@dataclass(frozen=True)
class Measure:
    """One viewpoint quality measure.

    Attributes
    ----------
    name : str
        Short name, stored in files (``"VE"``).
    title : str
        What it is called in words (``"viewpoint entropy"``).
    family : str
        One of :data:`FAMILIES`.
    higher_is_better : bool
        Whether a higher raw value marks a better view.
    needs : frozenset of str
        What it reads, a subset of :data:`NEEDS`.
    compute : callable
        ``compute(data) -> (n_views,) float64`` raw values from a
        :class:`~vptoolkit.measures.data.ViewData`; NaN where the measure
        is undefined for a view (one that sees nothing).
    source : str
        Where the measure comes from (authors, year).
    rank : int
        Position within its family in ``--measures all``.
    """

    name: str
    title: str
    family: str
    higher_is_better: bool
    needs: frozenset[str]
    compute: Callable[[ViewData], NDArray[np.float64]]
    source: str
    rank: int = 0

    def __post_init__(self) -> None:
        if self.family not in FAMILIES:
            raise ValueError(f"{self.name}: unknown family {self.family!r}")
        unknown = set(self.needs) - NEEDS
        if unknown:
            raise ValueError(f"{self.name}: unknown needs {sorted(unknown)}")

    @property
    def needs_image_statistics(self) -> bool:
        """Whether the views must be drawn with depth and silhouette statistics."""
        return bool(self.needs & IMAGE_NEEDS)


@cache
def all_measures() -> Mapping[str, Measure]:
    """Every registered measure by name, in family order and then by rank."""
    import vptoolkit.measures.catalog as catalog

    found: list[Measure] = []
    for module in pkgutil.iter_modules(catalog.__path__):
        if module.name.startswith("_"):
            continue
        value = importlib.import_module(f"{catalog.__name__}.{module.name}").MEASURE
        found.append(value)
    found.sort(key=lambda m: (FAMILIES.index(m.family), m.rank, m.name))
    names = [m.name for m in found]
    if len(set(names)) != len(names):
        raise RuntimeError(f"two catalog modules declare the same measure name: {names}")
    return {m.name: m for m in found}


@cache
def _folded_names() -> Mapping[str, str]:
    """Every registered name by its upper-case form."""
    return {name.upper(): name for name in all_measures()}


def canonical_name(name: str, argument: str = "measure") -> str:
    """The registry's spelling of a measure name given in any case (``"vkl"``: ``"VKL"``).

    Raises
    ------
    InputError
        One line, starting with ``argument`` (the argument or option that
        gave the name), naming the unknown measure and the known ones.
    """
    known = _folded_names()
    if not isinstance(name, str) or name.strip().upper() not in known:
        raise InputError(f"{argument}: unknown measure {name!r}; "
                         f"known: {', '.join(known.values())}")
    return known[name.strip().upper()]


def get_measure(name: str) -> Measure:
    """The measure called ``name``, in any case; :class:`~vptoolkit.errors.InputError` if none is."""
    return all_measures()[canonical_name(name)]


def measure_index(name: str, measures: Iterable[str] = PAPER_MEASURES) -> int:
    """Position of a measure, named in any case, among ``measures``.

    Parameters
    ----------
    name : str
        A registered measure name, in any case.
    measures : iterable of str
        The names of the columns (or rows) to look in, in the registry's
        spelling (default: :data:`PAPER_MEASURES`).

    Returns
    -------
    int
        The index of the measure in ``measures``.

    Raises
    ------
    InputError
        One line: an unknown name, or a registered one not among ``measures``.
    """
    wanted = canonical_name(name)
    names = list(measures)
    if wanted not in names:
        raise InputError(f"measure: {wanted} is not among the measures here "
                         f"({', '.join(names)})")
    return names.index(wanted)


def resolve_measures(spec: str | Iterable[str] | None = None) -> tuple[str, ...]:
    """Measure names from what a user wrote.

    Parameters
    ----------
    spec : str, iterable of str or None
        ``None`` or ``"paper"``: the paper's four (:data:`PAPER_MEASURES`);
        ``"all"``: every registered measure; otherwise names in any case, as
        an iterable or one comma-separated string (``"VE,SL,MD"``), kept in
        the order given.

    Returns
    -------
    tuple of str
        Known, distinct names in the registry's spelling.

    Raises
    ------
    InputError
        An unknown or repeated name, or no name at all.
    """
    if spec is None:
        return PAPER_MEASURES
    if isinstance(spec, str):
        word = spec.strip()
        if word.lower() == "all":
            return tuple(all_measures())
        if word.lower() == "paper":
            return PAPER_MEASURES
        names = [part.strip() for part in word.split(",") if part.strip()]
    else:
        names = [str(part) for part in spec]
    if not names:
        raise InputError("measures: no measure named")
    names = [canonical_name(name, "measures") for name in names]
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise InputError(f"measures: {', '.join(repeated)} named twice")
    return tuple(names)
