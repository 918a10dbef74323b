"""Figures: the bundled samples drawn as before (flat blue-grey, the measures' framing) and now.

Writes two contact sheets of the twelve bundled samples
(:func:`vptoolkit.samples.sample_names`), 128 px a tile, all from the
direction ``(1, 0.7, 1.3)`` with image up ``+y``:

* ``appearance_before.png``: ``RenderStyle(margin=None)`` and no appearance,
  the pictures of earlier releases;
* ``appearance_after.png``: the default style (framed to a margin of 0.05
  of the side) in each model's own colours and texture
  (:func:`vptoolkit.io.load_with_appearance`).

Then times a 256 px picture of ``Duck.glb`` with and without its texture
(software engine; the two alternate, median of 9 each, so that the load of
a shared machine weighs on both alike).

Usage::

    python tools/appearance_figures.py docs/figures
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from vptoolkit.io import load_with_appearance, require_surface
from vptoolkit.pictures.contact_sheet import contact_sheet
from vptoolkit.pictures.png import save_png
from vptoolkit.pictures.shading import RenderStyle
from vptoolkit.pictures.software_engine import SoftwareRenderer
from vptoolkit.samples import sample_names, sample_path

DIRECTION = (1.0, 0.7, 1.3)
TILE = 128


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="where the two PNG files go")
    folder = parser.parse_args().folder
    models = []
    for name in sample_names():
        model, appearance = load_with_appearance(sample_path(name))
        models.append((name, require_surface(model, name), appearance))
    for state, style, painted in (("before", RenderStyle(margin=None), False),
                                  ("after", RenderStyle(), True)):
        with SoftwareRenderer(size=TILE, style=style) as engine:
            tiles = [engine.render(mesh, DIRECTION,
                                   appearance=appearance if painted else None)[0]
                     for _, mesh, appearance in models]
        sheet = contact_sheet(tiles, [name for name, _, _ in models], columns=6)
        save_png(sheet, folder / f"appearance_{state}.png")
        print(f"wrote {folder / f'appearance_{state}.png'}")
    model, appearance = load_with_appearance(sample_path("Duck.glb"))
    duck = require_surface(model, "Duck.glb")
    states = {"without texture": None, "with texture": appearance}
    seconds: dict[str, list[float]] = {label: [] for label in states}
    with SoftwareRenderer(size=256) as engine:
        engine.render(duck, DIRECTION, appearance=appearance)  # compiled and warm
        for _ in range(9):
            for label, given in states.items():
                start = time.perf_counter()
                engine.render(duck, DIRECTION, appearance=given)
                seconds[label].append(time.perf_counter() - start)
    for label, times in seconds.items():
        print(f"Duck.glb 256 px {label}: {statistics.median(times):.3f} s (median of 9)")


if __name__ == "__main__":
    main()
