"""Coverage of view sets on the bundled and procedural meshes, into docs/results.md.

For every bundled sample mesh and two procedural shapes per category
(:mod:`vptoolkit.synthetic`), the views are drawn once and compared at
k = 1..4 views:

* the best VE view alone and the best VR view alone;
* the top-k views of one measure (the k highest normalised VE, or VR), which
  cluster around the best view (the paper: "the latter can be a very similar
  view direction");
* the greedy sets of :mod:`vptoolkit.view_sets`: information (starts at the
  best VE view), quality (VE, starts there too) and coverage (starts at the
  best VR view).

Cells are the mean coverage (area-weighted fraction of the surface seen by at
least one of the views) over the meshes, in percent. The section between
``<!-- viewsets:start -->`` and ``<!-- viewsets:end -->`` of docs/results.md
is replaced (appended at the end if missing), and a contact sheet of two
meshes' coverage sets goes to docs/figures/.

Usage::

    python tools/view_set_results.py            # 1000 views at 512 px, a minute or two
    python tools/view_set_results.py --quick    # 200 views at 128 px, not written to docs/
"""

from __future__ import annotations

import argparse
import time
from datetime import date
from pathlib import Path

import numpy as np
from results_doc import command_line, format_seconds, machine, markdown_table, write_section

from vptoolkit.io import load_mesh
from vptoolkit.mesh import Mesh
from vptoolkit.pictures.contact_sheet import view_set_sheet
from vptoolkit.pictures.engine import open_renderer
from vptoolkit.pictures.png import save_png
from vptoolkit.pictures.shading import RenderStyle
from vptoolkit.samples import sample_names, sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import angle_between_deg
from vptoolkit.synthetic import CATEGORIES, make_shape
from vptoolkit.view_sets.search import best_view_set, set_coverage
from vptoolkit.view_sets.visibility import FaceVisibility

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "docs" / "results.md"
FIGURES = ROOT / "docs" / "figures"
K = 4
STRATEGIES = ("best VE view alone", "best VR view alone", "top-k VE views", "top-k VR views",
              "greedy information", "greedy quality (VE)", "greedy coverage")


def spread_deg(directions: np.ndarray) -> float:
    """Mean angle between the pairs of a set's directions, in degrees."""
    pairs = [(a, b) for a in range(len(directions)) for b in range(a + 1, len(directions))]
    if not pairs:
        return 0.0
    return float(np.mean([angle_between_deg(directions[a], directions[b]) for a, b in pairs]))


def padded(values: np.ndarray) -> np.ndarray:
    """Coverage after 1..K views; a set that stopped early keeps its last value."""
    return np.concatenate([values, np.full(K - len(values), values[-1])])[:K]


def evaluate_mesh(mesh: Mesh, n_views: int, resolution: int) -> dict[str, object]:
    settings = MeasureSettings(views=n_views, resolution=resolution)
    visibility = FaceVisibility.from_mesh(mesh, settings)
    quality = visibility.quality()
    rows: dict[str, np.ndarray] = {}
    spreads: dict[str, float] = {}
    for column, measure in ((0, "VE"), (1, "VR")):
        order = np.argsort(-quality[:, column], kind="stable")[:K]
        coverage = set_coverage(visibility, order)
        rows[f"best {measure} view alone"] = np.array([coverage[0], *[np.nan] * (K - 1)])
        rows[f"top-k {measure} views"] = coverage
        spreads[f"top-k {measure} views"] = spread_deg(visibility.views[order])
    to_target = {}
    for name, objective in (("greedy information", "information"),
                            ("greedy quality (VE)", "quality"), ("greedy coverage", "coverage")):
        chosen = best_view_set(visibility, K, objective=objective, quality=quality[:, 0])
        rows[name] = padded(chosen.coverage)
        spreads[name] = spread_deg(chosen.directions)
        to_target[name] = len(best_view_set(visibility, None, objective=objective,
                                            until_coverage=0.95, quality=quality[:, 0]))
    reachable = best_view_set(visibility, 1).reachable
    return {"rows": rows, "spreads": spreads, "to_target": to_target, "reachable": reachable}


def table(results: list[dict[str, object]]) -> list[str]:
    header = ["strategy", *(f"{k} view{'s' if k > 1 else ''}" for k in range(1, K + 1)),
              "mean angle between 4 picks", "views to 95 % of reachable"]
    rows = []
    for strategy in STRATEGIES:
        values = np.array([r["rows"][strategy] for r in results])  # type: ignore[index]
        cells = ["–" if np.isnan(v).all() else f"{100 * np.nanmean(v):.1f}" for v in values.T]
        spread = [r["spreads"].get(strategy) for r in results]  # type: ignore[attr-defined]
        angle = "–" if spread[0] is None else f"{np.mean(spread):.0f}°"
        counts = [r["to_target"].get(strategy) for r in results]  # type: ignore[attr-defined]
        needed = "–" if counts[0] is None else f"{np.mean(counts):.1f} (max {max(counts)})"
        rows.append([strategy, *cells, angle, needed])
    lines = markdown_table(header, rows)
    reachable = np.mean([r["reachable"] for r in results])
    lines.append("")
    lines.append(f"Reachable coverage (all sampled views together), mean: {100 * reachable:.1f} %.")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="few views, low resolution, "
                        "printed only")
    args = parser.parse_args()
    n_views, resolution = (200, 128) if args.quick else (1000, 512)
    started = time.perf_counter()
    bundled = [load_mesh(sample_path(name)) for name in sample_names()]
    procedural = [make_shape(category, seed=seed) for category in CATEGORIES for seed in (0, 1)]
    collections = {"bundled": bundled, "procedural": procedural}
    results = {name: [evaluate_mesh(mesh, n_views, resolution) for mesh in meshes]
               for name, meshes in collections.items()}
    seconds = time.perf_counter() - started

    lines = ["## Complementary view sets (the paper's future work)", "",
             f"Command: `{command_line(__file__)}`; {date.today().isoformat()}, "
             f"{machine()}; wall time {format_seconds(seconds)}.", "",
             f"Meshes: the {len(bundled)} bundled samples "
             f"({', '.join(sorted(m.name for m in bundled))}) and {len(procedural)} procedural "
             "shapes (`vptoolkit.synthetic`, seeds 0 and 1 of each of "
             f"{len(CATEGORIES)} categories); {n_views} Fibonacci views at {resolution} px, "
             "raster backend, a face counts as seen with one pixel (the paper's VR visibility).",
             "",
             "Cells: coverage, the area-weighted fraction of the surface seen by at least one of "
             "the first k views, mean over the meshes in %. Top-k: the k views of highest "
             "normalised quality of one measure. Greedy: `vptool views --objective ...` "
             "(`vptoolkit.view_sets.search.best_view_set`); information and quality start at "
             "the best VE view, coverage at the best VR view. Mean angle: between every pair of "
             "the 4 picks; views to 95 %: greedy picks until the set sees 95 % of what all "
             "views see.",
             ""]
    for name, rows in results.items():
        lines += [f"**{name.capitalize()} meshes ({len(rows)})**", ""] + table(rows) + [""]
    headline = {name: (np.mean([r["rows"]["top-k VE views"][-1] for r in rows]),
                       np.mean([r["rows"]["greedy coverage"][-1] for r in rows]))
                for name, rows in results.items()}
    lines += ["Four views of highest VE see "
              + " and ".join(f"{100 * top:.1f} % ({name})" for name, (top, _) in headline.items())
              + " of the surface; the four greedy coverage views see "
              + " and ".join(f"{100 * greedy:.1f} %" for _, (_, greedy) in headline.items())
              + ". The top-k views of one measure cluster around its best view, so they add "
              "little after the first; a greedy set adds what the views before it missed. "
              "The information objective rewards spreading the pixels evenly over the faces, "
              "not new area, so it can stall: it needed up to "
              + " and ".join(f"{max(r['to_target']['greedy information'] for r in rows)} views "
                             f"({name})" for name, rows in results.items())
              + " to reach 95 % of the reachable coverage, where greedy coverage needed "
              + " and ".join(f"{max(r['to_target']['greedy coverage'] for r in rows)}"
                             for rows in results.values()) + ".", "",
              "![Coverage view sets of the bunny and a procedural chair](figures/view_sets.png)"]
    section = "\n".join(lines)
    print(section)
    if args.quick:
        return
    FIGURES.mkdir(parents=True, exist_ok=True)
    settings = MeasureSettings(views=n_views, resolution=resolution)
    with open_renderer(size=200) as plain, \
            open_renderer(size=200, style=RenderStyle(up=(0.0, 0.0, 1.0))) as z_up:
        sheets = [view_set_sheet(load_mesh(sample_path("bunny.ply")), K, settings=settings,
                                 engine=plain)[0],
                  view_set_sheet(make_shape("chair", seed=0), K, settings=settings,
                                 engine=z_up)[0]]
    width = max(sheet.shape[1] for sheet in sheets)
    stacked = np.concatenate([np.pad(s, ((0, 0), (0, width - s.shape[1]), (0, 0)),
                                     constant_values=255) for s in sheets])
    save_png(stacked, FIGURES / "view_sets.png")
    write_section(RESULTS, "viewsets", section)
    print(f"wrote {RESULTS} and {FIGURES / 'view_sets.png'}")


if __name__ == "__main__":
    main()
