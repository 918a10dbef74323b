"""The measuring session gives the values frozen before it existed, bit for bit.

``tests/assets/measured_values.npz`` holds the raw values of two sample meshes
(``suzanne.ply``, ``mug.obj``; 60 Fibonacci views at 64 px) for the paper's
four, VE alone and every registered measure, and the answers of best-view
searches (24 views at 64 px, with and without a prior, the paper's four and a
mix of the paper's and other measures). Any change of a value fails; the file
is rewritten, by running this module, only for a deliberate change of what a
measure computes.
"""

import sys

import numpy as np
import pytest

from fixtures.paths import ASSETS
from vptoolkit.best_view.search import SearchSettings, search_best_views
from vptoolkit.io import load_mesh
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings

FROZEN_VALUES = ASSETS / "measured_values.npz"
FROZEN_MESHES = ("suzanne.ply", "mug.obj")
QUALITY_SPECS = ("paper", "VE", "all")
SEARCH_SPECS = {"paper": None, "mixed": "VKL,NVT,SL,I2,SS,VE"}
PRIOR = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def _quality_case(name: str, spec: str) -> dict[str, np.ndarray]:
    mesh = load_mesh(sample_path(name))
    quality = compute_view_quality(mesh, MeasureSettings(views=60, resolution=64), measures=spec)
    return {f"{name.split('.')[0]}/quality/{spec}": quality.raw}


def _search_case(name: str, spec: str, with_prior: bool) -> dict[str, np.ndarray]:
    mesh = load_mesh(sample_path(name))
    found = search_best_views(mesh, SearchSettings(budget=24, resolution=64),
                              prior=PRIOR if with_prior else None, measures=SEARCH_SPECS[spec])
    key = f"{name.split('.')[0]}/search/{spec}/{'prior' if with_prior else 'sphere'}"
    return {f"{key}/directions": found.directions, f"{key}/raw": found.raw}


@pytest.fixture(scope="module")
def frozen():
    with np.load(FROZEN_VALUES, allow_pickle=False) as archive:
        return dict(archive)


@pytest.mark.parametrize("spec", QUALITY_SPECS)
@pytest.mark.parametrize("name", FROZEN_MESHES)
def test_compute_view_quality_keeps_the_frozen_values(frozen, name, spec):
    for key, value in _quality_case(name, spec).items():
        assert np.array_equal(value, frozen[key], equal_nan=True), key


@pytest.mark.parametrize("with_prior", [False, True])
@pytest.mark.parametrize("spec", list(SEARCH_SPECS))
@pytest.mark.parametrize("name", FROZEN_MESHES)
def test_search_best_views_keeps_the_frozen_answers(frozen, name, spec, with_prior):
    for key, value in _search_case(name, spec, with_prior).items():
        assert np.array_equal(value, frozen[key], equal_nan=True), key


def _rewrite() -> None:
    arrays: dict[str, np.ndarray] = {}
    for name in FROZEN_MESHES:
        for spec in QUALITY_SPECS:
            arrays.update(_quality_case(name, spec))
        for spec in SEARCH_SPECS:
            for with_prior in (False, True):
                arrays.update(_search_case(name, spec, with_prior))
    np.savez_compressed(FROZEN_VALUES, **arrays)


if __name__ == "__main__" and "--rewrite" in sys.argv:
    _rewrite()
