"""Label methods for viewpoint learning and their losses.

Optimal viewpoints are rarely unique (symmetry, similar views), so which view a
network is trained towards matters (Schelling et al. 2021, section 4.1). A
model has ``V`` sampled views ``v`` with a normalised quality
``q(v) = VQ*(v)`` in [0, 1] per measure (1 = best); a prediction is a unit
vector ``v_hat``. Every loss below is per sample and per measure, shape
``(B, M)`` for ``B`` models and ``M`` measures (the network's, in its head
order: ``quality`` holds one column per measure, however many); the training
loop takes the mean.

=========  =====================================================================
method     loss
=========  =====================================================================
``sl``     single label: ``1 - <v_hat, v+>``, ``v+`` the stored best view
``ml``     multiple labels: ``min over {v : q(v) >= 0.99} of 1 - <v_hat, v>``
``gl``     Gaussian labels: ``1 - <v_hat, v_g>``,
           ``v_g = argmax_v q(v) (exp(-|v - v_hat| / (2 sigma^2)) + s)``
``ml+gl``  ``ml`` for the first half of the epochs, then ``gl`` (the paper's method)
``sr``     spherical regression (Liao et al. 2019): ``1 - <|v_hat|, |v+|>`` plus the
           cross entropy of the sign category of ``v+``
``dldl``   label distribution learning (Gao et al. 2017): per-pixel squared error
           between a predicted and the true 32 x 32 quality map of the sphere
=========  =====================================================================

Views and labels live in the network's input frame: under rotation
augmentation the views are rotated with the points, so ``views`` is given per
sample, ``(B, V, 3)`` (a shared ``(V, 3)`` array is broadcast).

The GL target follows the authors' code: the Gaussian is taken of the
Euclidean distance ``|v - v_hat|`` itself, not of its square, with
``sigma = 2`` and ``s = 1``; it is recomputed from the current (detached)
prediction at every step, so no gradient flows through the choice of target.

Sphere maps (DLDL) use the octahedral parametrisation of the unit sphere of
:mod:`vptoolkit.learn.octahedral`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Final

from vptoolkit.errors import InputError
from vptoolkit.learn.octahedral import (
    MAP_RESOLUTION,
    sphere_map_directions,
)
from vptoolkit.optional import require

if TYPE_CHECKING:
    import torch
    from torch import Tensor
else:
    torch = require("torch", extra="learn")
    Tensor = torch.Tensor

__all__ = [
    "LABEL_METHODS",
    "DIRECTION_METHODS",
    "ML_THRESHOLD",
    "GL_SIGMA",
    "GL_SHIFT",
    "SIGN_PATTERNS",
    "check_label_method",
    "head_for_method",
    "label_phase",
    "cosine_loss",
    "single_label_loss",
    "multiple_labels_loss",
    "gaussian_label_index",
    "gaussian_label_loss",
    "sign_category",
    "spherical_exponential",
    "decode_spherical_regression",
    "spherical_regression_loss",
    "quality_maps",
    "decode_sphere_maps",
    "distribution_loss",
    "nearest_view_quality",
    "label_loss",
]

LABEL_METHODS: Final = ("sl", "ml", "gl", "ml+gl", "sr", "dldl")
"""Every label method, by its name in the paper (lower case)."""

DIRECTION_METHODS: Final = ("sl", "ml", "gl", "ml+gl")
"""Methods whose network predicts a unit direction per measure directly."""

ML_THRESHOLD: Final = 0.99
"""Quality threshold ``alpha`` of the multiple labels (the paper's 0.99)."""

GL_SIGMA: Final = 2.0
"""Width ``sigma`` of the Gaussian labels' locality weight (the paper's 2)."""

GL_SHIFT: Final = 1.0
"""Shift ``s`` of the Gaussian labels' locality weight (the paper's 1)."""

def _sign_patterns() -> Tensor:
    rows = [[-1.0 if c & bit else 1.0 for bit in (4, 2, 1)] for c in range(8)]
    return torch.tensor(rows, dtype=torch.float32)


SIGN_PATTERNS: Final = _sign_patterns()
"""(8, 3) float32: the signs of ``x, y, z`` in each sign category.

Category ``c`` has bit 2 set when ``x < 0``, bit 1 when ``y < 0`` and bit 0
when ``z < 0``; zero counts as positive.
"""


# ---------------------------------------------------------------- method names


def check_label_method(method: str) -> str:
    """Return ``method`` in lower case, or raise if it is not a label method.

    Raises
    ------
    InputError
        If ``method`` is not one of :data:`LABEL_METHODS` (any case).
    """
    if not isinstance(method, str) or method.lower() not in LABEL_METHODS:
        raise InputError(f"labels: unknown label method {method!r}, expected one of "
                         f"{list(LABEL_METHODS)}")
    return method.lower()


def head_for_method(method: str) -> str:
    """The network head a label method trains: ``"direction"``, ``"sr"`` or ``"dldl"``."""
    method = check_label_method(method)
    return method if method in ("sr", "dldl") else "direction"


def label_phase(method: str, epoch: int, epochs: int) -> str:
    """The loss used in one epoch: ``ml+gl`` is ``ml`` for ``epoch < epochs // 2``, then ``gl``.

    Parameters
    ----------
    method : str
        One of :data:`LABEL_METHODS`.
    epoch : int
        Zero-based epoch.
    epochs : int
        Total number of epochs of the run (the paper: 3000, switching at 1500).

    Returns
    -------
    phase : str
        The method itself for every method but ``ml+gl``.
    """
    method = check_label_method(method)
    if method != "ml+gl":
        return method
    return "ml" if epoch < epochs // 2 else "gl"


# ---------------------------------------------------------------- helpers


def _as_batch_views(views: Tensor, batch: int) -> Tensor:
    if views.ndim == 2:
        views = views.unsqueeze(0).expand(batch, -1, -1)
    if views.ndim != 3 or views.shape[-1] != 3 or views.shape[0] != batch:
        raise InputError(f"views: expected shape (B, V, 3) or (V, 3) with B={batch}, "
                         f"got {tuple(views.shape)}")
    return views


def _check_directions(directions: Tensor, name: str = "directions") -> None:
    if directions.ndim != 3 or directions.shape[-1] != 3:
        raise InputError(f"{name}: expected shape (B, M, 3), got {tuple(directions.shape)}")


def _check_quality(quality: Tensor, views: Tensor, n_measures: int) -> None:
    if quality.shape != (*views.shape[:2], n_measures):
        raise InputError(
            f"quality: expected shape {(*views.shape[:2], n_measures)} to match views and "
            f"{n_measures} measures, got {tuple(quality.shape)}"
        )


def _dots(directions: Tensor, views: Tensor) -> Tensor:
    """(B, M, V) cosines between each prediction and each view."""
    return torch.einsum("bmc,bvc->bmv", directions, views.to(directions.dtype))


def _unit(vectors: Tensor, eps: float = 1e-12) -> Tensor:
    return vectors / vectors.norm(dim=-1, keepdim=True).clamp_min(eps)


# ---------------------------------------------------------------- SL, ML, GL


def cosine_loss(directions: Tensor, targets: Tensor) -> Tensor:
    """Cosine distance ``1 - <d, t>`` of unit vectors.

    Parameters
    ----------
    directions, targets : (..., 3) float
        Unit vectors, broadcast against each other.

    Returns
    -------
    loss : (...) float
        In [0, 2]; 0 when equal.
    """
    return 1.0 - (directions * targets).sum(dim=-1)


def single_label_loss(directions: Tensor, best_views: Tensor) -> Tensor:
    """Single label (SL): cosine distance to one stored best view per measure.

    .. math::
        \\ell_{SL}(\\hat v) = 1 - \\hat v \\cdot v^+

    Parameters
    ----------
    directions : (B, M, 3) float
        Unit predictions.
    best_views : (B, M, 3) float
        The best view of each model and measure, in the input frame.

    Returns
    -------
    loss : (B, M) float
    """
    _check_directions(directions)
    if best_views.shape != directions.shape:
        raise InputError(f"best_views: expected shape {tuple(directions.shape)}, "
                         f"got {tuple(best_views.shape)}")
    return cosine_loss(directions, best_views.to(directions.dtype))


def multiple_labels_loss(
    directions: Tensor, views: Tensor, quality: Tensor, *, threshold: float = ML_THRESHOLD
) -> Tensor:
    """Multiple labels (ML): cosine distance to the nearest view of quality ``>= threshold``.

    .. math::
        \\ell_{ML}(\\hat v) = \\min_{v \\in \\mathcal{V}^+} \\left(1 - \\hat v \\cdot v\\right),
        \\qquad \\mathcal{V}^+ = \\{v : q(v) \\ge \\alpha\\}

    (Schelling et al. 2021, eqs. 3-4, ``alpha = 0.99``). The gradient flows to
    the nearest label only. A model whose labels are all below the threshold
    (impossible for normalised quality, whose best view is 1) falls back to
    its best view.

    Parameters
    ----------
    directions : (B, M, 3) float
        Unit predictions.
    views : (B, V, 3) or (V, 3) float
        Unit view directions in the input frame.
    quality : (B, V, M) float
        Normalised quality per view and measure.
    threshold : float
        Label threshold ``alpha`` (default: 0.99).

    Returns
    -------
    loss : (B, M) float
    """
    _check_directions(directions)
    views = _as_batch_views(views, directions.shape[0])
    _check_quality(quality, views, directions.shape[1])
    is_label = quality.transpose(1, 2) >= threshold  # (B, M, V)
    best = quality.transpose(1, 2) >= quality.amax(dim=1).unsqueeze(-1)
    is_label = torch.where(is_label.any(dim=-1, keepdim=True), is_label, best)
    dots = _dots(directions, views).masked_fill(~is_label, float("-inf"))
    return 1.0 - dots.amax(dim=-1)


def gaussian_label_index(
    directions: Tensor, views: Tensor, quality: Tensor, *, sigma: float = GL_SIGMA,
    shift: float = GL_SHIFT
) -> Tensor:
    """Gaussian labels (GL): the index of the view that maximises the weighted quality.

    .. math::
        v^+_g(\\hat v) = \\operatorname*{argmax}_{v} \\; q(v)
        \\left(\\exp\\left(\\frac{-\\lVert v - \\hat v \\rVert_2}{2\\sigma^2}\\right) + s\\right)

    (Schelling et al. 2021, eqs. 5-8; the distance is not squared, as in the
    authors' code). Computed without gradient from the normalised
    ``directions``. Ties go to the lowest view index.

    Parameters
    ----------
    directions : (B, M, 3) float
        Current predictions (need not be unit length; they are normalised).
    views : (B, V, 3) or (V, 3) float
        Unit view directions in the input frame.
    quality : (B, V, M) float
        Normalised quality per view and measure.
    sigma : float
        Width of the locality weight (default: 2).
    shift : float
        Additive term ``s`` that keeps distant good views in reach (default: 1).

    Returns
    -------
    index : (B, M) int64
        Index into the views of each target.
    """
    _check_directions(directions)
    views = _as_batch_views(views, directions.shape[0])
    _check_quality(quality, views, directions.shape[1])
    with torch.no_grad():
        unit = _unit(directions.detach())
        distance = torch.cdist(unit, views.to(unit.dtype))  # (B, M, V)
        weight = torch.exp(-distance / (2.0 * sigma * sigma)) + shift
        return (quality.transpose(1, 2).to(unit.dtype) * weight).argmax(dim=-1)


def gaussian_label_loss(
    directions: Tensor, views: Tensor, quality: Tensor, *, sigma: float = GL_SIGMA,
    shift: float = GL_SHIFT
) -> Tensor:
    """Gaussian labels (GL): cosine distance to :func:`gaussian_label_index`'s view.

    .. math::
        \\ell_{GL}(\\hat v) = 1 - \\hat v \\cdot v^+_g(\\hat v)

    Parameters
    ----------
    directions : (B, M, 3) float
        Unit predictions.
    views : (B, V, 3) or (V, 3) float
    quality : (B, V, M) float
    sigma, shift : float
        As :func:`gaussian_label_index` (defaults: 2 and 1).

    Returns
    -------
    loss : (B, M) float
    """
    views = _as_batch_views(views, directions.shape[0])
    index = gaussian_label_index(directions, views, quality, sigma=sigma, shift=shift)
    targets = torch.gather(views.to(directions.dtype), 1, index.unsqueeze(-1).expand(-1, -1, 3))
    return cosine_loss(directions, targets)


# ---------------------------------------------------------------- SR


def sign_category(directions: Tensor) -> Tensor:
    """Sign category of each direction (see :data:`SIGN_PATTERNS`).

    Parameters
    ----------
    directions : (..., 3) float

    Returns
    -------
    category : (...) int64
        ``4 [x < 0] + 2 [y < 0] + [z < 0]``, in ``0 .. 7``.
    """
    negative = (directions < 0).long()
    return 4 * negative[..., 0] + 2 * negative[..., 1] + negative[..., 2]


def spherical_exponential(logits: Tensor) -> Tensor:
    """Spherical exponential: a non-negative unit vector from unbounded logits.

    .. math::
        |\\hat v|_i = \\frac{e^{o_i}}{\\sqrt{\\sum_j e^{2 o_j}}}

    (Liao et al. 2019, the ``S_exp`` output of spherical regression.)

    Parameters
    ----------
    logits : (..., 3) float

    Returns
    -------
    abs_directions : (..., 3) float
        Unit length, every component positive.
    """
    return torch.exp(logits - torch.logsumexp(2.0 * logits, dim=-1, keepdim=True) / 2.0)


def decode_spherical_regression(abs_directions: Tensor, sign_logits: Tensor) -> Tensor:
    """Combine absolute values and the most likely sign category into directions.

    Parameters
    ----------
    abs_directions : (..., 3) float
        Non-negative unit vectors (:func:`spherical_exponential`).
    sign_logits : (..., 8) float
        Scores of the eight sign categories.

    Returns
    -------
    directions : (..., 3) float
        ``abs_directions`` with the signs of the best category; unit length.
    """
    patterns = SIGN_PATTERNS.to(abs_directions.device, abs_directions.dtype)
    signs = patterns[sign_logits.argmax(dim=-1)]
    return abs_directions * signs


def spherical_regression_loss(abs_directions: Tensor, sign_logits: Tensor,
                              targets: Tensor) -> Tensor:
    """Spherical regression (SR) loss: cosine distance of absolute values plus sign cross entropy.

    .. math::
        \\ell_{SR} = 1 - |\\hat v| \\cdot |v^+| + \\mathrm{CE}(\\mathrm{logits}, c(v^+))

    with ``c`` the sign category (:func:`sign_category`), after Liao et al.
    2019 and Schelling et al. 2021, section 5.2.

    Parameters
    ----------
    abs_directions : (B, M, 3) float
        Predicted absolute values, non-negative unit vectors.
    sign_logits : (B, M, 8) float
        Predicted sign category scores.
    targets : (B, M, 3) float
        Unit label directions (the stored best views).

    Returns
    -------
    loss : (B, M) float
    """
    _check_directions(abs_directions, "abs_directions")
    if targets.shape != abs_directions.shape:
        raise InputError(f"targets: expected shape {tuple(abs_directions.shape)}, "
                         f"got {tuple(targets.shape)}")
    if sign_logits.shape != (*abs_directions.shape[:2], 8):
        raise InputError(f"sign_logits: expected shape {(*abs_directions.shape[:2], 8)}, "
                         f"got {tuple(sign_logits.shape)}")
    targets = targets.to(abs_directions.dtype)
    regression = cosine_loss(abs_directions, targets.abs())
    classification = torch.nn.functional.cross_entropy(
        sign_logits.reshape(-1, 8), sign_category(targets).reshape(-1), reduction="none"
    ).reshape(regression.shape)
    return regression + classification


# ---------------------------------------------------------------- DLDL sphere maps


def quality_maps(views: Tensor, quality: Tensor, *, resolution: int = MAP_RESOLUTION) -> Tensor:
    """The DLDL targets: the quality of the view nearest to each cell centre.

    Parameters
    ----------
    views : (B, V, 3) float
        Unit view directions in the input frame.
    quality : (B, V, M) float
        Normalised quality per view and measure.
    resolution : int
        Side ``R`` of the maps (default: 32).

    Returns
    -------
    maps : (B, M, R, R) float
        Cell ``(row, col)`` holds ``q`` of the view nearest (in angle) to the
        direction :func:`sphere_map_directions` gives for that cell.
    """
    if views.ndim != 3 or views.shape[-1] != 3:
        raise InputError(f"views: expected shape (B, V, 3), got {tuple(views.shape)}")
    batch, _, n_measures = quality.shape
    _check_quality(quality, views, n_measures)
    cells = sphere_map_directions(resolution, dtype=views.dtype).to(views.device).reshape(-1, 3)
    with torch.no_grad():
        nearest = torch.einsum("cd,bvd->bcv", cells, views).argmax(dim=-1)  # (B, R*R)
    # (B, R*R, M)
    values = torch.gather(quality, 1, nearest.unsqueeze(-1).expand(-1, -1, n_measures))
    return values.transpose(1, 2).reshape(batch, n_measures, resolution, resolution)


def decode_sphere_maps(maps: Tensor) -> Tensor:
    """The direction of the highest cell of each map.

    Parameters
    ----------
    maps : (B, M, R, R) float

    Returns
    -------
    directions : (B, M, 3) float
        Unit centre direction of the arg-max cell (the first one on ties).
    """
    if maps.ndim != 4 or maps.shape[-1] != maps.shape[-2]:
        raise InputError(f"maps: expected shape (B, M, R, R), got {tuple(maps.shape)}")
    resolution = maps.shape[-1]
    cells = sphere_map_directions(resolution, dtype=maps.dtype).to(maps.device).reshape(-1, 3)
    return cells[maps.flatten(start_dim=2).argmax(dim=-1)]


def distribution_loss(maps: Tensor, target_maps: Tensor) -> Tensor:
    """DLDL loss: mean per-pixel squared error between predicted and true maps.

    Parameters
    ----------
    maps, target_maps : (B, M, R, R) float

    Returns
    -------
    loss : (B, M) float
    """
    if maps.shape != target_maps.shape:
        raise InputError(f"target_maps: expected shape {tuple(maps.shape)}, "
                         f"got {tuple(target_maps.shape)}")
    return (maps - target_maps.to(maps.dtype)).square().mean(dim=(-2, -1))


# ---------------------------------------------------------------- scoring and dispatch


def nearest_view_quality(directions: Tensor, views: Tensor, quality: Tensor) -> Tensor:
    """Normalised quality of the sampled view nearest to each prediction.

    The authors' evaluation protocol, in torch for the training loop (the
    numpy scorer for files is :mod:`vptoolkit.evaluate`).

    Parameters
    ----------
    directions : (B, M, 3) float
        Predictions, any non-zero length.
    views : (B, V, 3) or (V, 3) float
        Unit view directions in the same frame as ``directions``.
    quality : (B, V, M) float
        Normalised quality per view and measure.

    Returns
    -------
    score : (B, M) float
        In [0, 1]; 1 = the prediction's nearest view is the best one.
    """
    _check_directions(directions)
    views = _as_batch_views(views, directions.shape[0])
    _check_quality(quality, views, directions.shape[1])
    nearest = _dots(_unit(directions), views).argmax(dim=-1)  # (B, M)
    return torch.gather(quality.transpose(1, 2), 2, nearest.unsqueeze(-1)).squeeze(-1)


def label_loss(phase: str, outputs: Mapping[str, Tensor], batch: Mapping[str, Tensor]) -> Tensor:
    """The loss of one training step for one label phase.

    Parameters
    ----------
    phase : str
        ``"sl"``, ``"ml"``, ``"gl"``, ``"sr"`` or ``"dldl"`` (``"ml+gl"`` is
        resolved per epoch with :func:`label_phase`).
    outputs : mapping
        The network outputs (:meth:`vptoolkit.learn.model.ViewpointNet.forward`):
        ``"directions"`` (B, M, 3), plus ``"abs_directions"`` (B, M, 3) and
        ``"sign_logits"`` (B, M, 8) for ``sr``, ``"maps"`` (B, M, R, R) for ``dldl``,
        and ``"frame"`` (B, 3, 3) when the network works in a canonical input
        frame: the ``sr`` and ``dldl`` targets are then mapped into it
        (``v C^T``).
    batch : mapping
        ``"views"`` (B, V, 3), ``"quality"`` (B, V, M) and ``"best_views"``
        (B, M, 3), all in the input frame (the items of
        :class:`vptoolkit.data.torch.ViewpointTorchDataset`).

    Returns
    -------
    loss : (B, M) float
    """
    phase = check_label_method(phase)
    if phase == "ml+gl":
        raise InputError("phase: resolve 'ml+gl' to 'ml' or 'gl' with label_phase() first")
    directions = outputs["directions"]
    if "frame" in outputs and phase in ("sr", "dldl"):
        # These heads answer in the network's canonical frame: bring the labels there.
        frame_t = outputs["frame"].transpose(1, 2).to(batch["views"].dtype)
        batch = {**batch, "views": _as_batch_views(batch["views"], directions.shape[0]) @ frame_t,
                 "best_views": batch["best_views"] @ frame_t}
    if phase == "sl":
        return single_label_loss(directions, batch["best_views"])
    if phase == "ml":
        return multiple_labels_loss(directions, batch["views"], batch["quality"])
    if phase == "gl":
        return gaussian_label_loss(directions, batch["views"], batch["quality"])
    if phase == "sr":
        return spherical_regression_loss(outputs["abs_directions"], outputs["sign_logits"],
                                         batch["best_views"])
    maps = outputs["maps"]
    targets = quality_maps(batch["views"].to(maps.dtype), batch["quality"].to(maps.dtype),
                           resolution=maps.shape[-1])
    return distribution_loss(maps, targets)
