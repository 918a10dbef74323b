"""The consensus of several answers: the densest candidate under a von Mises-Fisher kernel."""

import doctest

import numpy as np
import pytest
from scipy.stats import special_ortho_group

import vptoolkit.learn.consensus as consensus_module
from vptoolkit.errors import InputError
from vptoolkit.learn.consensus import CONSENSUS_KAPPA, consensus_directions


def unit(*vector: float) -> np.ndarray:
    values = np.array(vector, dtype=float)
    return values / np.linalg.norm(values)


def tilted(axis: np.ndarray, degrees: float, azimuth_deg: float) -> np.ndarray:
    """The unit direction ``degrees`` away from the unit ``axis``, at ``azimuth_deg`` around it."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    first = np.cross(axis, helper)
    first /= np.linalg.norm(first)
    second = np.cross(axis, first)
    theta, phi = np.radians(degrees), np.radians(azimuth_deg)
    return (np.cos(theta) * axis
            + np.sin(theta) * (np.cos(phi) * first + np.sin(phi) * second))


def one_column(*candidates: np.ndarray) -> np.ndarray:
    """Candidates of one model and one measure as a ``(1, K, 1, 3)`` array."""
    return np.array(candidates)[None, :, None]


def random_candidates(seed: int, shape: tuple[int, int, int]) -> np.ndarray:
    """``(n_models, K, n_measures, 3)`` directions of random lengths (0.5 to 2)."""
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(*shape, 3))
    directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
    return directions * rng.uniform(0.5, 2.0, size=(*shape, 1))


def test_the_docstring_example_holds():
    found = doctest.testmod(consensus_module, optionflags=doctest.ELLIPSIS)
    assert found.attempted >= 1 and found.failed == 0


def test_one_candidate_comes_back_normalised():
    candidates = random_candidates(0, (3, 1, 4))
    chosen = consensus_directions(candidates)
    assert chosen.shape == (3, 4, 3) and chosen.dtype == np.float64
    np.testing.assert_allclose(chosen, candidates[:, 0] / np.linalg.norm(
        candidates[:, 0], axis=-1, keepdims=True), rtol=0, atol=1e-15)


def test_a_cluster_beats_a_lone_outlier_and_an_antipodal_pair():
    z = unit(0, 0, 1)
    cluster = [tilted(z, 8.0, azimuth) for azimuth in (0.0, 120.0, 240.0)]
    outlier, pair = unit(1, 0, 0), [unit(0, 1, 0), unit(0, -1, 0)]
    for candidates in ([outlier, *pair, *cluster], [*cluster, outlier, *pair],
                       [pair[0], cluster[0], outlier, cluster[1], pair[1], cluster[2]]):
        chosen = consensus_directions(one_column(*candidates))[0, 0]
        assert min(np.abs(chosen - member).max() for member in cluster) < 1e-12
    # two close answers outweigh two opposite ones: the medoid is never between the two sides
    close = [tilted(z, 5.0, 0.0), tilted(z, 5.0, 180.0)]
    chosen = consensus_directions(one_column(pair[0], pair[1], *close))[0, 0]
    assert min(np.abs(chosen - member).max() for member in close) < 1e-12


def test_the_answer_is_a_candidate_never_an_average():
    candidates = random_candidates(1, (4, 7, 3))
    units = candidates / np.linalg.norm(candidates, axis=-1, keepdims=True)
    chosen = consensus_directions(candidates)
    for model in range(4):
        for measure in range(3):
            gaps = np.abs(units[model, :, measure] - chosen[model, measure]).max(axis=-1)
            assert gaps.min() < 1e-12
    # two equal clusters on either side of x: their mean would be x, which no candidate is
    left = [tilted(unit(0, 1, 0), 3.0, azimuth) for azimuth in (0.0, 180.0)]
    right = [tilted(unit(0, -1, 0), 3.0, azimuth) for azimuth in (0.0, 180.0)]
    chosen = consensus_directions(one_column(*left, *right))[0, 0]
    assert abs(chosen[1]) > 0.99


def test_ties_go_to_the_first_candidate():
    a, b = unit(0, 0, 1), unit(1, 0, 0)
    np.testing.assert_array_equal(consensus_directions(one_column(a, b))[0, 0], a)
    np.testing.assert_array_equal(consensus_directions(one_column(b, a))[0, 0], b)
    np.testing.assert_array_equal(consensus_directions(one_column(b, a, a, b))[0, 0], b)
    # three orthogonal answers: every density is exactly 1 + 2 exp(-kappa), so the first
    axes = [unit(1, 0, 0), unit(0, 1, 0), unit(0, 0, -1)]
    for start in range(3):
        turned = axes[start:] + axes[:start]
        np.testing.assert_array_equal(consensus_directions(one_column(*turned))[0, 0], turned[0])


def test_kappa_sets_how_near_agreeing_answers_must_be():
    # a pair of identical answers against three spread 30 degrees around x
    z, x = unit(0, 0, 1), unit(1, 0, 0)
    spread = [tilted(x, 30.0, azimuth) for azimuth in (0.0, 120.0, 240.0)]
    candidates = one_column(z, z, *spread)
    np.testing.assert_array_equal(consensus_directions(candidates)[0, 0], z)
    assert CONSENSUS_KAPPA == 10.0
    # a broad kernel weighs the three spread answers above the pair
    broad = consensus_directions(candidates, kappa=0.01)[0, 0]
    assert min(np.abs(broad - member).max() for member in spread) < 1e-12


@pytest.mark.parametrize("reflect", [False, True])
def test_rotating_the_candidates_rotates_the_answer(reflect):
    rotation = special_ortho_group.rvs(3, random_state=np.random.default_rng(5))
    if reflect:
        rotation = rotation @ np.diag([1.0, 1.0, -1.0])
    assert np.allclose(rotation @ rotation.T, np.eye(3))
    # clustered answers: each model and measure has a clear densest candidate
    rng = np.random.default_rng(6)
    centres = rng.normal(size=(5, 1, 4, 3))
    candidates = centres / np.linalg.norm(centres, axis=-1, keepdims=True) + 0.4 * rng.normal(
        size=(5, 9, 4, 3))
    chosen = consensus_directions(candidates)
    np.testing.assert_allclose(consensus_directions(candidates @ rotation.T), chosen @ rotation.T,
                               rtol=0, atol=1e-12)


def test_each_model_and_measure_is_decided_on_its_own():
    candidates = random_candidates(2, (3, 5, 4))
    chosen = consensus_directions(candidates)
    for model in range(3):
        for measure in range(4):
            alone = consensus_directions(candidates[model : model + 1, :, measure : measure + 1])
            np.testing.assert_array_equal(alone[0, 0], chosen[model, measure])
    # reordering models and measures reorders the answers, nothing else
    models, measures = [2, 0, 1], [3, 1, 0, 2]
    np.testing.assert_array_equal(consensus_directions(candidates[models][:, :, measures]),
                                  chosen[models][:, measures])
    # an empty batch of models is fine
    assert consensus_directions(np.zeros((0, 3, 2, 3))).shape == (0, 2, 3)


@pytest.mark.parametrize("shape", [(5, 3), (2, 4, 3), (1, 2, 1, 3, 1), (1, 2, 1, 2), (1, 0, 1, 3)])
def test_a_wrong_shape_or_no_candidate_is_refused(shape):
    with pytest.raises(InputError, match=r"^candidates: expected shape \(n_models, K, n_measures"):
        consensus_directions(np.ones(shape))


@pytest.mark.parametrize("bad", [0.0, np.nan, np.inf])
def test_a_zero_or_non_finite_candidate_is_refused(bad):
    candidates = random_candidates(3, (2, 3, 2))
    candidates[1, 2, 0] = bad if bad == 0.0 else [bad, 0.0, 1.0]
    with pytest.raises(InputError, match="^candidates: every candidate must be a finite non-zero"):
        consensus_directions(candidates)


@pytest.mark.parametrize("kappa", [0, 0.0, -1.0, np.nan, True, False, "10", None])
def test_kappa_must_be_a_positive_number(kappa):
    with pytest.raises(InputError, match="^kappa: expected a positive number"):
        consensus_directions(random_candidates(4, (1, 2, 1)), kappa=kappa)
