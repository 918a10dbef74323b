"""The registry of viewpoint quality measures.

Every measure is a :class:`~vptoolkit.measures.measure.Measure` value
declared in one small module of :mod:`vptoolkit.measures.catalog`, which
lists them in order (:data:`~vptoolkit.measures.catalog.CATALOG`); the
registry names them in that order. Names are the short names of Bonaventura et al. (2018)
(``"VE"``, ``"SL"``, ...) and are the names stored in files.

The registry is the one vocabulary of measures: every function, file and
command-line flag that takes a measure takes any registered name, or refuses
one that cannot serve there in one line with the reason. Names are accepted
in any case and reported in the registry's spelling (``"ve"`` is ``"VE"``,
:func:`canonical_name`). Two presets name several measures at once
(:data:`PRESETS`): ``"paper"``, the paper's four (:data:`PAPER_MEASURES`),
and ``"all"``, every registered measure.

What a measure reads is declared in
:attr:`Measure.needs <vptoolkit.measures.measure.Measure.needs>`, one or more
of :data:`~vptoolkit.measures.measure.NEEDS`;
:func:`vptoolkit.measures.quality.compute_view_quality` draws and computes only what the
requested measures need.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from functools import cache
from typing import Final

from vptoolkit.errors import InputError
from vptoolkit.measures.measure import POINT_NEEDS, Measure
from vptoolkit.measures.sums import PAPER_COLUMNS

__all__ = [
    "PAPER_MEASURES",
    "PRESETS",
    "all_measures",
    "canonical_name",
    "get_measure",
    "measure_index",
    "point_measures",
    "resolve_measures",
]

PAPER_MEASURES: Final = PAPER_COLUMNS
"""The paper's four measures, the preset ``"paper"``, in the fixed order of every
``(..., 4)`` array of the paper's measures and of the dataset store's stored arrays:
VE (viewpoint entropy) and VR (visibility ratio), higher is better; VKL
(viewpoint Kullback-Leibler divergence) and VMI (viewpoint mutual information),
lower is better."""

PRESETS: Final = ("paper", "all")
"""Words that name several measures (:func:`resolve_measures`), in any case:
``"paper"`` the paper's four (:data:`PAPER_MEASURES`), ``"all"`` every registered
measure in the registry's order."""


@cache
def all_measures() -> Mapping[str, Measure]:
    """Every registered measure by name, in the order of the catalog
    (:data:`vptoolkit.measures.catalog.CATALOG`: by family, then as listed there)."""
    from vptoolkit.measures.catalog import CATALOG

    names = [measure.name for measure in CATALOG]
    if len(set(names)) != len(names):
        raise RuntimeError(f"two catalog entries declare the same measure name: {names}")
    return {measure.name: measure for measure in CATALOG}


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
    """The measure called ``name``, in any case; :class:`~vptoolkit.errors.InputError`
    if none is."""
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


_POINT_REFUSALS: Final = {"silhouette": "silhouettes", "depth": "depth",
                          "curvature": "a face curvature"}
"""What each need outside :data:`~vptoolkit.measures.measure.POINT_NEEDS` reads, in
:func:`point_measures`' message."""


def point_measures(spec: str | Iterable[str] | None = None, label: str = "points"
                   ) -> tuple[str, ...]:
    """The measures of :func:`resolve_measures`, each checked to be defined on a point cloud.

    A measure is defined on points when its needs lie within
    :data:`vptoolkit.measures.measure.POINT_NEEDS` (:attr:`Measure.on_points
    <vptoolkit.measures.measure.Measure.on_points>`): the paper's four, NVT,
    PA, HM, I2, I3, INS, SAL and EVMI.

    Parameters
    ----------
    spec : str, iterable of str or None
        What :func:`resolve_measures` takes.
    label : str
        The cloud named first in the message (default: "points").

    Returns
    -------
    tuple of str
        The names, in the order given.

    Raises
    ------
    InputError
        One line naming the measures not defined on points, what they read
        that a cloud does not have, and the measures defined on points
        (``bunny: SL, CE are not defined on a point cloud (reading silhouettes
        or a face curvature); on points: NVT, ...``); or
        :func:`resolve_measures`' message.
    """
    names = resolve_measures(spec)
    refused = [name for name in names if not get_measure(name).on_points]
    if refused:
        missing = set().union(*(get_measure(name).needs - POINT_NEEDS for name in refused))
        reading = [words for need, words in _POINT_REFUSALS.items() if need in missing]
        read = ", ".join(reading[:-1]) + " or " + reading[-1] if len(reading) > 1 else reading[0]
        defined = ", ".join(name for name, measure in all_measures().items() if measure.on_points)
        raise InputError(f"{label}: {', '.join(refused)} {'is' if len(refused) == 1 else 'are'} "
                         f"not defined on a point cloud (reading {read}); on points: {defined}")
    return names
