"""A canonical input frame: the principal axes of a point cloud, signed by its third moments.

A point network without built-in rotation equivariance has to learn from
rotated copies that a rotated model wants a rotated view, which is far too
sample-hungry for a CPU budget (``docs/results.md``). Putting every input into
a frame computed from the points themselves removes the rotation before the
network sees it, and rotating the prediction back gives an answer that turns
with the input by construction.

The frame of a cloud ``x_1 .. x_N`` (Hotelling's principal axes, with the
sign fixed by skewness):

1. centre on the mean ``m``; covariance ``S = 1/N sum (x_i - m)(x_i - m)^T``;
2. the rows of ``C`` are the unit eigenvectors of ``S``, largest eigenvalue
   first;
3. each row is signed so that the third central moment of the points
   projected on it, ``mu_3 = 1/N sum <x_i - m, c>^3``, is non-negative: the
   long tail of the cloud lies on the positive side of every axis.

``C`` is orthogonal (``C C^T = I``); its determinant may be -1, i.e. the
canonical cloud ``(x - m) C^T`` can be a mirror image. That is harmless: the
prediction ``d`` made in the canonical frame maps back with ``d C`` whether
``C`` reflects or not, and signing each axis by its own moment keeps the
three choices independent of each other.

Equivariance
    For a rotation (or any orthogonal map) ``R`` applied as ``x -> x R^T``,
    ``S -> R S R^T``, the eigenvectors turn with it and the third moments are
    unchanged, so ``C(x R^T) = C(x) R^T`` and the canonical cloud is the same
    point set. This holds exactly as long as the eigenvalues are distinct
    and no ``mu_3`` is zero.

Ambiguity
    Near-isotropic clouds (a ball, a cube) have unstable axes, and
    symmetric ones a ``mu_3`` of about 0, whose sign is decided by sampling
    noise. During training an axis whose ``|mu_3|`` is below
    ``ambiguity * sigma^3`` (``sigma^2`` its eigenvalue) gets a random sign
    (an augmentation over exactly the frames the network may meet), and the
    random rotations of the training data cover unstable axes. In evaluation
    the sign of ``mu_3`` is used as it is, which is deterministic and
    equivariant.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Final

from vptoolkit.errors import InputError
from vptoolkit.optional import require

if TYPE_CHECKING:
    import torch
    from torch import Tensor
else:
    torch = require("torch", extra="learn")
    Tensor = torch.Tensor

__all__ = ["INPUT_FRAMES", "SIGN_AMBIGUITY", "canonical_frame", "to_frame", "from_frame"]

INPUT_FRAMES: Final = ("pca", "none")
"""Input frames of :class:`vptoolkit.learn.model.ModelConfig`.

Either the principal axes or the input's own.
"""

SIGN_AMBIGUITY: Final = 0.05
"""``|mu_3| / sigma^3`` below which an axis's sign counts as ambiguous in training."""


def canonical_frame(points: Tensor, *, generator: torch.Generator | None = None,
                    ambiguity: float = SIGN_AMBIGUITY) -> tuple[Tensor, Tensor]:
    """The principal-axis frame of each cloud, signed by third moments.

    Parameters
    ----------
    points : (B, N, 3) float
        Point clouds in any position, orientation and scale.
    generator : torch.Generator, optional
        When given, axes whose ``|mu_3| < ambiguity * sigma^3`` get a sign
        drawn from it (training); when None every sign follows ``mu_3``
        (evaluation; a zero moment counts as positive).
    ambiguity : float
        Threshold of an ambiguous sign (default: :data:`SIGN_AMBIGUITY`).

    Returns
    -------
    frame : (B, 3, 3) float
        Rows are the canonical axes, largest variance first; orthogonal, in
        the dtype of ``points``.
    centre : (B, 1, 3) float
        The mean of each cloud.

    Notes
    -----
    Computed in float64 without gradient: the frame is a function of the
    input alone. The centred points are first divided by their largest
    absolute coordinate, so the frame and the ambiguity test do not depend on
    the cloud's size (no absolute variance bound). A cloud whose points
    coincide (their spread at most ``1e-12`` of their largest coordinate, the
    rounding of float64) gets the identity frame.
    """
    if points.ndim != 3 or points.shape[-1] != 3 or points.shape[1] < 1:
        raise InputError(f"points: expected shape (B, N, 3) with N >= 1, got {tuple(points.shape)}")
    with torch.no_grad():
        values = points.detach().to(torch.float64)
        centre = values.mean(dim=1, keepdim=True)
        centred = values - centre
        extent = centred.abs().amax(dim=(1, 2), keepdim=True)
        centred = centred / torch.where(extent > 0, extent, torch.ones_like(extent))
        covariance = centred.transpose(1, 2) @ centred / values.shape[1]
        eigenvalues, eigenvectors = torch.linalg.eigh(covariance)  # ascending
        axes = eigenvectors.flip(-1).transpose(1, 2)  # rows, largest variance first
        variance = eigenvalues.flip(-1).clamp_min(0.0)
        projected = centred @ axes.transpose(1, 2)  # (B, N, 3)
        third = projected.pow(3).mean(dim=1)  # (B, 3)
        signs = torch.where(third < 0, -1.0, 1.0).to(torch.float64)
        if generator is not None:
            scale = variance.pow(1.5).clamp_min(1e-300)
            is_ambiguous = third.abs() < ambiguity * scale
            drawn = torch.randint(0, 2, signs.shape, generator=generator, device=generator.device)
            drawn = (drawn.to(signs.device) * 2 - 1).to(torch.float64)
            signs = torch.where(is_ambiguous, drawn, signs)
        frame = axes * signs.unsqueeze(-1)
        # Points that coincide up to float64 rounding of their position: no axis to find.
        is_degenerate = extent[:, 0, 0] <= 1e-12 * values.abs().amax(dim=(1, 2))
        if bool(is_degenerate.any()):
            identity = torch.eye(3, dtype=torch.float64, device=frame.device).expand_as(frame)
            frame = torch.where(is_degenerate[:, None, None], identity, frame)
    return frame.to(points.dtype), centre.to(points.dtype)


def to_frame(points: Tensor, frame: Tensor, centre: Tensor) -> Tensor:
    """Points in the canonical frame: ``(x - centre) C^T``, shape (B, N, 3)."""
    return (points - centre) @ frame.transpose(1, 2)


def from_frame(directions: Tensor, frame: Tensor) -> Tensor:
    """Directions ``(B, M, 3)`` given in the canonical frame, back in the input's: ``d C``."""
    return directions @ frame
