"""The octahedral parametrisation of the unit sphere, the grid of the DLDL sphere maps.

Meyer et al. 2010; Cigolle et al. 2014: a direction ``d`` is projected onto
the octahedron ``|x| + |y| + |z| = 1`` and the lower half (``z < 0``) is
folded over the diagonals, so the whole sphere maps one-to-one onto the square
``[-1, 1]^2`` without seams inside it. Cell ``(row, col)`` of a ``R x R`` map
covers ``u`` in ``[-1 + 2 col / R, -1 + 2 (col + 1) / R]`` and ``w`` likewise
for ``row``; cells differ in solid angle by at most a factor of about 3.
The DLDL labels (:mod:`vptoolkit.learn.labels`) and the sphere-map decoder
(:mod:`vptoolkit.learn.layers`) use this grid.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Final

from vptoolkit.errors import InputError
from vptoolkit.optional import require

if TYPE_CHECKING:
    import torch
    import torch.nn.functional as F
    from torch import Tensor
else:
    torch = require("torch", extra="learn")
    F = torch.nn.functional
    Tensor = torch.Tensor

__all__ = [
    "MAP_RESOLUTION",
    "octahedral_encode",
    "octahedral_decode",
    "sphere_map_directions",
    "sphere_map_cell",
]

MAP_RESOLUTION: Final = 32
"""Side of the DLDL sphere map in cells (the paper's 32 x 32)."""


def octahedral_encode(directions: Tensor) -> Tensor:
    """Octahedral coordinates of directions.

    Parameters
    ----------
    directions : (..., 3) float
        Non-zero vectors.

    Returns
    -------
    uv : (..., 2) float
        In ``[-1, 1]^2``; the upper hemisphere (``z >= 0``) fills the diamond
        ``|u| + |w| <= 1``, the lower one the four corners.
    """
    p = directions / directions.abs().sum(dim=-1, keepdim=True).clamp_min(1e-12)
    x, y, z = p.unbind(dim=-1)
    sign_x = torch.where(x >= 0, 1.0, -1.0).to(p.dtype)
    sign_y = torch.where(y >= 0, 1.0, -1.0).to(p.dtype)
    folded_u = (1.0 - y.abs()) * sign_x
    folded_w = (1.0 - x.abs()) * sign_y
    is_lower = z < 0
    return torch.stack([torch.where(is_lower, folded_u, x), torch.where(is_lower, folded_w, y)],
                       dim=-1)


def octahedral_decode(uv: Tensor) -> Tensor:
    """Unit directions from octahedral coordinates (inverse of :func:`octahedral_encode`).

    Parameters
    ----------
    uv : (..., 2) float
        In ``[-1, 1]^2``.

    Returns
    -------
    directions : (..., 3) float
        Unit vectors.
    """
    u, w = uv.unbind(dim=-1)
    z = 1.0 - u.abs() - w.abs()
    sign_u = torch.where(u >= 0, 1.0, -1.0).to(uv.dtype)
    sign_w = torch.where(w >= 0, 1.0, -1.0).to(uv.dtype)
    is_lower = z < 0
    x = torch.where(is_lower, (1.0 - w.abs()) * sign_u, u)
    y = torch.where(is_lower, (1.0 - u.abs()) * sign_w, w)
    return F.normalize(torch.stack([x, y, z], dim=-1), dim=-1, eps=1e-12)


def sphere_map_directions(resolution: int = MAP_RESOLUTION, *,
                          dtype: torch.dtype = torch.float32) -> Tensor:
    """The direction at the centre of every cell of an octahedral sphere map.

    Parameters
    ----------
    resolution : int
        Side ``R`` of the map (default: 32).
    dtype : torch.dtype
        Floating type of the result (default: float32).

    Returns
    -------
    directions : (R, R, 3) float
        Unit vector at the centre of cell ``(row, col)``; rows follow the
        second octahedral coordinate ``w``, columns the first, ``u``.
    """
    if isinstance(resolution, bool) or not isinstance(resolution, int) or resolution < 1:
        raise InputError(f"resolution: expected a positive integer, got {resolution!r}")
    centres = -1.0 + (torch.arange(resolution, dtype=torch.float64) + 0.5) * (2.0 / resolution)
    w, u = torch.meshgrid(centres, centres, indexing="ij")
    return octahedral_decode(torch.stack([u, w], dim=-1)).to(dtype)


def sphere_map_cell(directions: Tensor, resolution: int = MAP_RESOLUTION) -> Tensor:
    """The flat index ``row * R + col`` of the map cell holding each direction.

    Parameters
    ----------
    directions : (..., 3) float
    resolution : int
        Side ``R`` of the map (default: 32).

    Returns
    -------
    cell : (...) int64
        In ``0 .. R*R - 1``.
    """
    uv = octahedral_encode(directions)
    index = ((uv + 1.0) * (resolution / 2.0)).floor().long().clamp(0, resolution - 1)
    return index[..., 1] * resolution + index[..., 0]
