"""Label methods and losses of vptoolkit.learn.labels on hand-made cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fixtures.environment import require_package

require_package("torch")

import torch  # noqa: E402

from vptoolkit.errors import InputError  # noqa: E402
from vptoolkit.learn import labels as L  # noqa: E402
from vptoolkit.learn.octahedral import (  # noqa: E402
    octahedral_decode,
)
from vptoolkit.sphere import fibonacci_sphere  # noqa: E402


def unit(*vectors: tuple[float, float, float]) -> torch.Tensor:
    array = torch.tensor(vectors, dtype=torch.float64)
    return array / array.norm(dim=-1, keepdim=True)


def angle_deg(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return torch.rad2deg(torch.arccos((a * b).sum(-1).clamp(-1.0, 1.0)))


# Four views on the axes; two of them (+x and +y) are labels for ML.
VIEWS = unit((1, 0, 0), (0, 1, 0), (0, 0, 1), (-1, 0, 0))


def one_measure(quality: list[float]) -> torch.Tensor:
    """(1, V, 1) quality for one model and one measure."""
    return torch.tensor(quality, dtype=torch.float64)[None, :, None]


def test_single_label_loss_is_cosine_distance():
    prediction = unit((1, 1, 0))[None]
    target = unit((1, 0, 0))[None]
    loss = L.single_label_loss(prediction, target)
    assert loss.shape == (1, 1)
    assert loss.item() == pytest.approx(1 - math.cos(math.radians(45)))
    assert L.single_label_loss(target, target).item() == pytest.approx(0.0)


def test_multiple_labels_loss_picks_the_nearest_label():
    quality = one_measure([1.0, 0.995, 0.2, 0.98])  # +x and +y are labels, -x (0.98) is not
    near_y = unit((0.2, 1, 0.1))[None].requires_grad_(True)
    loss = L.multiple_labels_loss(near_y, VIEWS, quality)
    assert loss.item() == pytest.approx(1 - near_y[0, 0, 1].item())
    loss.sum().backward()
    # the gradient of 1 - <v_hat, +y> is -(+y): it flows to the nearest label only
    assert torch.allclose(near_y.grad[0, 0], -VIEWS[1])


def test_multiple_labels_ignore_views_below_the_threshold():
    quality = one_measure([1.0, 0.5, 0.2, 0.98])
    near_minus_x = unit((-1, 0.1, 0))[None]
    loss = L.multiple_labels_loss(near_minus_x, VIEWS, quality)
    assert loss.item() == pytest.approx(1 - near_minus_x[0, 0, 0].item())  # only +x is a label
    assert L.multiple_labels_loss(near_minus_x, VIEWS, quality,
                                  threshold=0.97).item() == pytest.approx(
        1 - near_minus_x[0, 0] @ VIEWS[3]
    )


def test_multiple_labels_accept_per_sample_views():
    quality = one_measure([1.0, 1.0, 0.0, 0.0]).expand(2, -1, -1)
    rotated = torch.stack([VIEWS, -VIEWS])  # the second model's views rotated by 180 degrees
    prediction = unit((1, 0, 0), (-1, 0, 0))[:, None]
    loss = L.multiple_labels_loss(prediction, rotated, quality)
    assert torch.allclose(loss, torch.zeros(2, 1, dtype=torch.float64))


def test_gaussian_labels_move_to_the_closer_of_two_equal_maxima():
    quality = one_measure([1.0, 1.0, 0.3, 0.3])
    near_x = unit((1, 0.4, 0.2))[None]
    near_y = unit((0.4, 1, 0.2))[None]
    assert L.gaussian_label_index(near_x, VIEWS, quality).item() == 0
    assert L.gaussian_label_index(near_y, VIEWS, quality).item() == 1


def test_gaussian_labels_keep_distant_better_views_in_reach():
    # A far view of quality 1 against a near view of quality 0.85: with s = 1 the
    # locality weight only ranges over exp(-2/8) + 1 .. 2, so the better view wins.
    quality = one_measure([1.0, 0.85, 0.0, 0.0])
    prediction = unit((0, 1, 0))[None]
    assert L.gaussian_label_index(prediction, VIEWS, quality).item() == 0
    # ... while a near view of quality 0.95 beats it (0.95 * 2 > 1 * (exp(-sqrt 2 / 8) + 1)).
    assert L.gaussian_label_index(prediction, VIEWS, one_measure([1.0, 0.95, 0, 0])).item() == 1


def test_gaussian_weight_uses_the_distance_not_its_square():
    # target = argmax q(v) (exp(-|v - v_hat| / (2 sigma^2)) + s); pick a case where
    # squaring the distance would change the decision.
    prediction = unit((0, 1, 0))[None]
    far = VIEWS[0]  # distance sqrt(2) from the prediction
    distance = math.sqrt(2.0)
    weight_far = math.exp(-distance / 8) + 1
    # a near view (distance 0) of quality q ties with the far one when 2 q = weight_far
    tie = weight_far / 2
    above = one_measure([1.0, tie + 1e-6, 0, 0])
    below = one_measure([1.0, tie - 1e-6, 0, 0])
    assert L.gaussian_label_index(prediction, VIEWS, above).item() == 1
    assert L.gaussian_label_index(prediction, VIEWS, below).item() == 0
    assert far @ prediction[0, 0] == pytest.approx(0.0)


def test_gaussian_label_loss_has_no_gradient_through_the_target():
    quality = one_measure([1.0, 1.0, 0.3, 0.3])
    prediction = unit((1, 0.4, 0.2))[None].requires_grad_(True)
    loss = L.gaussian_label_loss(prediction, VIEWS, quality)
    loss.sum().backward()
    assert torch.allclose(prediction.grad[0, 0], -VIEWS[0])


def test_label_phase_switches_ml_to_gl_halfway():
    phases = [L.label_phase("ml+gl", epoch, 10) for epoch in range(10)]
    assert phases == ["ml"] * 5 + ["gl"] * 5
    assert L.label_phase("ML+GL", 1499, 3000) == "ml" and L.label_phase("ml+gl", 1500, 3000) == "gl"
    assert L.label_phase("sr", 7, 10) == "sr"


def test_unknown_label_method_names_the_argument():
    with pytest.raises(InputError, match="labels: unknown label method 'foo'"):
        L.check_label_method("foo")


def test_sign_categories_round_trip_through_the_patterns():
    vectors = torch.tensor([[sx * 0.3, sy * 0.5, sz * 0.8]
                            for sx in (1, -1) for sy in (1, -1) for sz in (1, -1)])
    categories = L.sign_category(vectors)
    assert sorted(categories.tolist()) == list(range(8))
    assert torch.equal(L.SIGN_PATTERNS[categories], torch.sign(vectors))
    logits = torch.nn.functional.one_hot(categories, 8).float() * 10.0
    decoded = L.decode_spherical_regression(vectors.abs(), logits)
    assert torch.allclose(decoded, vectors)


def test_spherical_exponential_is_a_positive_unit_vector():
    logits = torch.tensor([[0.0, 1.0, -2.0], [50.0, 0.0, 0.0], [-30.0, -30.0, -30.0]])
    result = L.spherical_exponential(logits)
    assert torch.allclose(result.norm(dim=-1), torch.ones(3))
    assert (result > 0).all()
    assert torch.allclose(result[1], torch.tensor([1.0, 0.0, 0.0]), atol=1e-6)


def test_spherical_regression_loss_is_small_at_the_label_and_grows_with_a_wrong_sign():
    target = unit((0.3, -0.5, 0.8)).float()[None]
    good_logits = torch.full((1, 1, 8), -10.0)
    good_logits[0, 0, L.sign_category(target)[0, 0]] = 10.0
    loss = L.spherical_regression_loss(target.abs(), good_logits, target)
    assert loss.shape == (1, 1) and loss.item() < 1e-6
    wrong_logits = good_logits.roll(1, dims=-1)
    assert L.spherical_regression_loss(target.abs(), wrong_logits, target).item() > 10.0


def cell_diameter_deg(resolution: int) -> float:
    """Largest corner-to-corner angle of any cell of the octahedral map."""
    edges = -1.0 + torch.arange(resolution + 1, dtype=torch.float64) * (2.0 / resolution)
    w, u = torch.meshgrid(edges, edges, indexing="ij")
    corners = octahedral_decode(torch.stack([u, w], dim=-1))
    first = angle_deg(corners[:-1, :-1], corners[1:, 1:])
    second = angle_deg(corners[1:, :-1], corners[:-1, 1:])
    return float(torch.maximum(first, second).max())


def test_quality_map_best_cell_decodes_near_the_true_best_view():
    views = torch.from_numpy(fibonacci_sphere(1000))
    generator = torch.Generator().manual_seed(0)
    tolerance = cell_diameter_deg(32)
    assert tolerance < 16.0
    for _ in range(50):
        peak = torch.randn(3, dtype=torch.float64, generator=generator)
        peak /= peak.norm()
        quality = ((1.0 + views @ peak) / 2.0) ** 4  # smooth, one maximum
        best = views[quality.argmax()]
        maps = L.quality_maps(views[None], quality[None, :, None])
        assert maps.shape == (1, 1, 32, 32)
        assert maps.max().item() == pytest.approx(quality.max().item(), abs=0.02)
        decoded = L.decode_sphere_maps(maps)[0, 0]
        assert angle_deg(decoded, best).item() <= tolerance


def test_distribution_loss_is_the_mean_squared_error():
    maps = torch.zeros(2, 4, 32, 32)
    targets = torch.ones(2, 4, 32, 32) * 0.5
    assert torch.allclose(L.distribution_loss(maps, targets), torch.full((2, 4), 0.25))


def test_nearest_view_quality_scores_the_nearest_sampled_view():
    quality = torch.tensor([[1.0, 0.1], [0.5, 0.2], [0.0, 1.0], [0.3, 0.3]],
                           dtype=torch.float64)[None]
    # near +x for measure 0, +z for measure 1
    predictions = unit((0.9, 0.2, 0.0), (0.1, 0.0, 2.0))[None]
    scores = L.nearest_view_quality(predictions, VIEWS, quality)
    assert scores.tolist() == [[1.0, 1.0]]


def test_label_loss_dispatches_every_phase():
    generator = torch.Generator().manual_seed(0)
    views = torch.from_numpy(fibonacci_sphere(50)).float().expand(2, -1, -1)
    quality = torch.rand(2, 50, 4, generator=generator)
    quality = quality / quality.amax(dim=1, keepdim=True)
    best = torch.gather(views, 1, quality.argmax(dim=1).unsqueeze(-1).expand(-1, -1, 3))
    batch = {"views": views, "quality": quality, "best_views": best}
    directions = torch.nn.functional.normalize(torch.randn(2, 4, 3, generator=generator), dim=-1)
    outputs = {
        "directions": directions,
        "abs_directions": directions.abs(),
        "sign_logits": torch.randn(2, 4, 8, generator=generator),
        "maps": torch.rand(2, 4, 32, 32, generator=generator),
    }
    for phase in ("sl", "ml", "gl", "sr", "dldl"):
        loss = L.label_loss(phase, outputs, batch)
        assert loss.shape == (2, 4) and torch.isfinite(loss).all(), phase
    outputs["directions"] = best
    for phase in ("sl", "ml", "gl"):
        assert torch.allclose(L.label_loss(phase, outputs, batch), torch.zeros(2, 4),
                              atol=1e-6), phase
    with pytest.raises(InputError, match="label_phase"):
        L.label_loss("ml+gl", outputs, batch)


def test_wrong_shapes_raise_input_errors():
    with pytest.raises(InputError, match="quality"):
        L.multiple_labels_loss(unit((1, 0, 0))[None], VIEWS,
                               torch.ones(1, 3, 1, dtype=torch.float64))
    with pytest.raises(InputError, match="best_views"):
        L.single_label_loss(torch.zeros(2, 4, 3), torch.zeros(2, 3, 3))
    assert np.isclose(L.GL_SIGMA, 2.0) and np.isclose(L.GL_SHIFT, 1.0)
    assert np.isclose(L.ML_THRESHOLD, 0.99)
