"""View sets: greedy coverage against exhaustive search, first picks, targets, closed forms."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from fixtures.meshes import box_mesh
from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.measures.sums import quality_from_histograms
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.view_sets.result import ViewSet
from vptoolkit.view_sets.search import best_view_set, measure_view_set, set_coverage
from vptoolkit.view_sets.visibility import FaceVisibility

N_VIEWS, RESOLUTION = 40, 64
SETTINGS = MeasureSettings(views=N_VIEWS, resolution=RESOLUTION)


@pytest.fixture(scope="module", params=["suzanne.ply", "teapot.stl", "table.obj"])
def visibility(request) -> FaceVisibility:
    return FaceVisibility.from_mesh(load_mesh(sample_path(request.param)), SETTINGS)


def best_k_set_coverage(visibility: FaceVisibility, k: int) -> float:
    """The optimum by exhaustive search over every k-subset of the sampled views."""
    seen = visibility.seen_matrix()
    areas = visibility.face_areas
    best = 0.0
    for combination in itertools.combinations(range(visibility.n_views), k):
        best = max(best, float(areas @ seen[list(combination)].any(axis=0)))
    return best / float(areas.sum())


@pytest.mark.parametrize("k", [1, 2, 3])
def test_greedy_coverage_is_within_its_guarantee_of_exhaustive_search(visibility, k):
    optimum = best_k_set_coverage(visibility, k)
    greedy = best_view_set(visibility, k).coverage[-1]
    assert greedy <= optimum + 1e-12
    assert greedy >= (1.0 - (1.0 - 1.0 / k) ** k) * optimum  # Nemhauser et al., > 1 - 1/e
    if k == 1:
        assert greedy == pytest.approx(optimum, abs=1e-12)
    # near-ties band: each later gain within 5 % of greedy's
    alpha = 0.95
    quality_set = best_view_set(visibility, k, objective="quality", tolerance=1.0 - alpha)
    assert quality_set.coverage[-1] >= (1.0 - (1.0 - alpha / k) ** (k - 1)) * optimum - 1e-12


def test_coverage_of_one_view_is_its_visibility_ratio():
    mesh = load_mesh(sample_path("suzanne.ply"))
    quality = compute_view_quality(mesh, SETTINGS)
    visibility = FaceVisibility.from_mesh(mesh, SETTINGS)
    single = np.array([set_coverage(visibility, [view])[0] for view in range(N_VIEWS)])
    np.testing.assert_allclose(single, quality.raw[:, 1], rtol=1e-12)


def test_first_picks_are_the_best_single_views(visibility):
    quality = visibility.quality()
    ve, vr = int(np.argmax(quality[:, 0])), int(np.argmax(quality[:, 1]))
    assert best_view_set(visibility, 2).indices[0] == vr
    assert best_view_set(visibility, 2, objective="information").indices[0] == ve
    assert best_view_set(visibility, 2, objective="quality").indices[0] == ve
    assert best_view_set(visibility, 2, objective="quality", measure="vr").indices[0] == vr


def test_information_score_is_the_entropy_of_the_joint_face_distribution(visibility):
    view_set = best_view_set(visibility, 3, objective="information")
    counts = np.concatenate([run.to_dense() for run in visibility.runs])[view_set.indices]
    for picks in (1, 2, 3):
        joint = counts[:picks].sum(axis=0).astype(float)
        p = joint[joint > 0] / joint.sum()
        assert view_set.score[picks - 1] == pytest.approx(-(p * np.log2(p)).sum(), rel=1e-12)
    # H({v}) = VE(v), so the first pick is the view of highest VE
    raw = quality_from_histograms(visibility.runs, visibility.face_areas,
                                  n_views=visibility.n_views)
    assert view_set.score[0] == pytest.approx(np.nanmax(raw[:, 0]), rel=1e-12)


def test_greedy_information_picks_the_best_entropy_at_every_step(visibility):
    """Brute force over every candidate at every step agrees with the incremental search."""
    view_set = best_view_set(visibility, 3, objective="information")
    counts = np.concatenate([run.to_dense() for run in visibility.runs]).astype(float)
    chosen: list[int] = []
    for _ in range(3):
        entropies = []
        for view in range(visibility.n_views):
            joint = counts[chosen + [view]].sum(axis=0)
            p = joint[joint > 0] / joint.sum()
            entropies.append(-np.inf if view in chosen else -(p * np.log2(p)).sum())
        chosen.append(int(np.argmax(entropies)))
    assert view_set.indices.tolist() == chosen


def test_a_cube_is_covered_by_two_opposite_corner_views():
    view_set = best_view_set(box_mesh(), 4, settings=MeasureSettings(views=200, resolution=64))
    assert len(view_set) == 2  # a third view adds nothing, so the search stops
    np.testing.assert_allclose(view_set.coverage, [0.5, 1.0], atol=1e-12)
    assert view_set.reachable == pytest.approx(1.0)
    first, second = np.sign(view_set.directions)
    assert (first == -second).all()  # opposite octants


def test_until_coverage_stops_at_the_first_set_that_reaches_the_target(visibility):
    view_set = best_view_set(visibility, None, until_coverage=0.9)
    goal = 0.9 * view_set.reachable
    assert view_set.coverage[-1] >= goal - 1e-12
    assert len(view_set) == 1 or view_set.coverage[-2] < goal
    capped = best_view_set(visibility, 2, until_coverage=1.0)
    assert len(capped) <= 2
    np.testing.assert_array_equal(capped.indices, view_set.indices[: len(capped)])


def test_same_inputs_give_the_same_set(visibility):
    first = best_view_set(visibility, 4, objective="quality")
    again = best_view_set(visibility, 4, objective="quality")
    np.testing.assert_array_equal(first.indices, again.indices)
    np.testing.assert_array_equal(first.coverage, again.coverage)


def test_measure_view_set_draws_once_and_matches_compute_view_quality():
    mesh = load_mesh(sample_path("teapot.stl"))
    quality, view_set = measure_view_set(mesh, 3, settings=SETTINGS)
    alone = compute_view_quality(mesh, SETTINGS)
    np.testing.assert_array_equal(quality.raw, alone.raw)
    np.testing.assert_array_equal(quality.best_index, alone.best_index)
    assert isinstance(view_set, ViewSet) and view_set.indices.shape == (3,)
    assert view_set.directions.shape == (3, 3) and view_set.indices[0] == alone.best_index[1]
    assert np.all(np.diff(view_set.coverage) >= 0)


def test_save_npz_loads_without_pickle(visibility, tmp_path):
    view_set = best_view_set(visibility, 3)
    path = view_set.save_npz(tmp_path / "set.npz")
    with np.load(path, allow_pickle=False) as stored:
        np.testing.assert_array_equal(stored["indices"], view_set.indices)
        np.testing.assert_array_equal(stored["coverage"], view_set.coverage)
        assert str(stored["objective"]) == "coverage"
    with pytest.raises(InputError, match="set.txt: output must end in .npz"):
        view_set.save_npz(tmp_path / "set.txt")


@pytest.mark.parametrize("options, message", [
    ({"objective": "beauty"}, "objective: expected one of coverage, information, quality"),
    ({"k": 0}, "k: must be at least 1"),
    ({"k": None}, "k: give a number of views, a coverage target, or both"),
    ({"until_coverage": 1.5}, r"until_coverage: must lie in \(0, 1\]"),
    ({"tolerance": 1.0}, r"tolerance: must lie in \[0, 1\)"),
    ({"min_pixels": 0}, "min_pixels: must be at least 1"),
    ({"measure": "VX"}, "measure: unknown measure 'VX'"),
], ids=["objective", "k-zero", "nothing", "target", "tolerance", "pixels", "measure"])
def test_bad_options_raise_one_line_naming_the_argument(visibility, options, message):
    arguments = {"k": 2, **options}
    k = arguments.pop("k")
    with pytest.raises(InputError, match=message):
        best_view_set(visibility, k, **arguments)


def test_a_larger_pixel_threshold_never_covers_more(visibility):
    loose = set_coverage(visibility, np.arange(5))
    strict = set_coverage(visibility, np.arange(5), min_pixels=4)
    assert (strict <= loose + 1e-15).all()
    impossible = set_coverage(visibility, np.arange(5), min_pixels=RESOLUTION**2 + 1)
    assert (impossible == 0).all()
