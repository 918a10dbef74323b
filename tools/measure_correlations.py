"""How the registered measures agree: rank correlations over the views, into docs/results.md.

For every bundled sample mesh (``vptoolkit/samples``) and every redistributable
real mesh of ``tests/assets/real`` (MIT, see its README), all registered
measures are computed for the same Fibonacci views
(:func:`vptoolkit.measures.quality.compute_view_quality` with
``measures="all"``, raster backend). For each mesh and each pair of measures,
Spearman's rank correlation over the views is taken on the normalised values
(1 = best for every measure: the raw values with the lower-is-better measures'
sign flipped, a view that sees nothing the worst), so +1 means two measures
order the views alike and -1 that one's best views are the other's worst. The
section holds the mean of each pair over the meshes, the mean over the pairs
within and between the families, and the pairs that agree and disagree most,
as the survey of Bonaventura et al. (2018) compares its measures pair by pair.

A measure that is constant over one mesh's views (DVS on a ball, the curvature
measures on a box) ranks nothing there; that mesh is left out of its pairs'
means, and the section names such meshes.

The section between ``<!-- measure_correlations:start -->`` and
``<!-- measure_correlations:end -->`` of ``--results`` (default
docs/results.md) is replaced (appended at the end if missing).

Usage::

    python tools/measure_correlations.py            # 1000 views at 256 px, 14 meshes, minutes
    python tools/measure_correlations.py --quick    # 100 views at 64 px, 2 meshes, printed only
    python tools/measure_correlations.py --quick --results /tmp/results.md   # and written there
"""

from __future__ import annotations

import argparse
import json
import time
from datetime import date
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from results_doc import (
    add_results_option,
    command_line,
    format_seconds,
    machine,
    markdown_table,
    write_section,
)

from vptoolkit.io import find_mesh_files, load_mesh
from vptoolkit.measures.measure import FAMILIES
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.measures.registry import get_measure, resolve_measures
from vptoolkit.mesh import Mesh
from vptoolkit.samples import sample_names, sample_path
from vptoolkit.settings import MeasureSettings

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "docs" / "results.md"
REAL_MESHES = ROOT / "tests" / "assets" / "real"
SECTION = "measure_correlations"
QUICK_MESHES = ("teapot.stl", "rabbit.obj")
"""The two meshes of ``--quick``: a bundled sample and a real test mesh."""

EXTREMES = 8
"""Pairs listed as agreeing most, and as disagreeing most."""


def mean_ranks(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Ranks 1..n of ``values`` in increasing order, equal values sharing their mean rank."""
    _, inverse, counts = np.unique(values, return_inverse=True, return_counts=True)
    last = np.cumsum(counts)  # the rank of the last of each group of equal values
    ranks: NDArray[np.float64] = (last - (counts - 1) / 2.0)[inverse]
    return ranks


def rank_correlations(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Spearman's rank correlation between every two columns.

    Parameters
    ----------
    values : (n_views, M) float64
        One column per measure, finite.

    Returns
    -------
    rho : (M, M) float64
        Pearson's correlation of the columns' ranks (ties take their mean
        rank, as ``scipy.stats.spearmanr`` ranks them); 1 on the diagonal;
        NaN in the row and column of a constant column, which ranks nothing.
    """
    ranks = np.column_stack([mean_ranks(column) for column in np.asarray(values).T])
    centred = ranks - ranks.mean(axis=0)
    norms = np.sqrt((centred**2).sum(axis=0))
    varies = norms > 0
    scaled = np.divide(centred, norms, out=np.zeros_like(centred), where=varies)
    rho: NDArray[np.float64] = np.clip(scaled.T @ scaled, -1.0, 1.0)
    rho[~varies, :] = np.nan
    rho[:, ~varies] = np.nan
    np.fill_diagonal(rho, 1.0)
    return rho


def study_meshes(quick: bool) -> list[tuple[str, Mesh]]:
    """``(file name, mesh)`` of the bundled samples and the real test meshes, or the quick two."""
    paths = [sample_path(name) for name in sample_names()] + find_mesh_files(REAL_MESHES)
    if quick:
        paths = [path for path in paths if path.name in QUICK_MESHES]
    return [(path.name, load_mesh(path)) for path in paths]


def measure_mesh(mesh: Mesh, settings: MeasureSettings) -> tuple[NDArray[np.float64], list[str]]:
    """The rank correlations of all measures over one mesh's views, and the measures constant
    over them."""
    quality = compute_view_quality(mesh, settings, measures="all")
    constant = [name for name, column in zip(quality.measures, quality.normalized.T)
                if np.ptp(column) == 0]
    return rank_correlations(quality.normalized), constant


def cell(value: float) -> str:
    """A correlation with two decimals, its sign always written; a dash where undefined."""
    return "–" if not np.isfinite(value) else f"{value:+.2f}"


def family_means(mean: NDArray[np.float64], names: tuple[str, ...]) -> list[str]:
    """Mean correlation of the pairs within each family (diagonal) and between two families."""
    families = [family for family in FAMILIES
                if any(get_measure(name).family == family for name in names)]
    members = {family: [i for i, name in enumerate(names) if get_measure(name).family == family]
               for family in families}
    rows = []
    for first in families:
        cells = []
        for second in families:
            block = mean[np.ix_(members[first], members[second])]
            if first == second:
                block = block[~np.eye(len(block), dtype=bool)]
            cells.append(cell(float(np.nanmean(block))) if np.isfinite(block).any() else "–")
        rows.append([first, *cells])
    return markdown_table(["family", *families], rows)


def extreme_pairs(mean: NDArray[np.float64], names: tuple[str, ...]) -> tuple[str, str]:
    """The :data:`EXTREMES` pairs of different families whose mean correlation is highest,
    and the ones where it is lowest, as ``A-B +0.97`` lists."""
    pairs = [(float(mean[i, j]), names[i], names[j])
             for i in range(len(names)) for j in range(i + 1, len(names))
             if get_measure(names[i]).family != get_measure(names[j]).family
             and np.isfinite(mean[i, j])]
    pairs.sort()
    listed = [f"{a}-{b} {cell(value)}" for value, a, b in pairs]
    return ", ".join(reversed(listed[-EXTREMES:])), ", ".join(listed[:EXTREMES])


def section_text(names: tuple[str, ...], meshes: list[tuple[str, Mesh]],
                 matrices: list[NDArray[np.float64]], constant: dict[str, list[str]],
                 settings: MeasureSettings, seconds: float) -> str:
    """The markdown of the results section."""
    stack = np.array(matrices)
    defined = np.isfinite(stack).sum(axis=0)
    mean = np.divide(np.nansum(stack, axis=0), defined,
                     out=np.full(defined.shape, np.nan), where=defined > 0)
    header = ["", *names]
    rows = [[name, *(cell(v) for v in mean[i])] for i, name in enumerate(names)]
    agree, disagree = extreme_pairs(mean, names)
    listed = ", ".join(f"{name} ({mesh.n_faces} faces)" for name, mesh in meshes)
    skipped = "; ".join(f"{', '.join(found)} on {mesh}" for mesh, found in constant.items()
                        if found)
    lines = [
        f"## How the {len(names)} measures agree: rank correlations over the views", "",
        f"Command: `{command_line(__file__)}`; {date.today().isoformat()}, {machine()}; "
        f"wall time {format_seconds(seconds)}.", "",
        f"Meshes ({len(meshes)}): {listed}; the bundled samples and the real meshes of "
        f"`tests/assets/real`. {settings.views} Fibonacci views at {settings.resolution} px, "
        f"{settings.backend} backend, `compute_view_quality(mesh, settings, measures=\"all\")`.",
        "",
        "Cell: Spearman's rank correlation between two measures over one mesh's views, "
        "mean over the meshes. It is taken on the normalised values (1 = best for every "
        "measure, i.e. the raw values with the lower-is-better measures' sign flipped), so "
        "+1 means the two measures order the views alike and -1 that one measure's best "
        "views are the other's worst. "
        + (f"A measure constant over a mesh's views ranks nothing there, and that mesh is "
           f"left out of its pairs' means: {skipped}." if skipped else
           "No measure was constant over a mesh's views."),
        "", *markdown_table(header, rows), "",
        "Mean over the pairs within a family (diagonal) and between two families:", "",
        *family_means(mean, names), "",
        f"Pairs of different families that agree most: {agree}.", "",
        f"Pairs of different families that disagree most: {disagree}.",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"100 views at 64 px on {' and '.join(QUICK_MESHES)}; printed "
                             "only, unless --results names another file")
    parser.add_argument("--views", type=int, default=1000,
                        help="Fibonacci views per mesh (default: 1000)")
    parser.add_argument("--resolution", type=int, default=256,
                        help="image side in pixels (default: 256)")
    parser.add_argument("--json", type=Path,
                        help="also write every mesh's matrix to this JSON file")
    add_results_option(parser, SECTION, default=RESULTS)
    args = parser.parse_args()
    if args.quick:
        settings = MeasureSettings(views=100, resolution=64)
    else:
        settings = MeasureSettings(views=args.views, resolution=args.resolution)
    names = resolve_measures("all")
    started = time.perf_counter()
    meshes = study_meshes(args.quick)
    matrices, constant = [], {}
    for file_name, mesh in meshes:
        matrix, constant[file_name] = measure_mesh(mesh, settings)
        matrices.append(matrix)
    seconds = time.perf_counter() - started
    text = section_text(names, meshes, matrices, constant, settings, seconds)
    print(text)
    if args.json is not None:
        args.json.write_text(json.dumps(
            {"measures": names, "views": settings.views, "resolution": settings.resolution,
             "meshes": {file_name: [[float(v) if np.isfinite(v) else None for v in row]
                                    for row in matrix]
                        for (file_name, _), matrix in zip(meshes, matrices)}}, indent=1))
    if args.results is not None and not (args.quick and args.results == RESULTS):
        write_section(args.results, args.section, text)


if __name__ == "__main__":
    main()
