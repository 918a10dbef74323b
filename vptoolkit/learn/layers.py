"""The layers of the viewpoint network: Monte Carlo convolution, the encoder and the heads.

:class:`MonteCarloConv` integrates features over a neighbourhood of the point
hierarchy (:mod:`vptoolkit.learn.hierarchy`) weighted by the inverse point
density; :class:`PointEncoder` stacks one per level; :class:`DirectionHead`
and :class:`SphereMapDecoder` turn the latent vector into a direction or a
sphere map. See :mod:`vptoolkit.learn.model` for the sizes.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, cast

from vptoolkit.learn.config import ModelConfig
from vptoolkit.learn.hierarchy import (
    GLOBAL_RADIUS,
    Neighbourhood,
    build_hierarchy,
    check_clouds,
    gather_rows,
)
from vptoolkit.optional import require

if TYPE_CHECKING:
    import torch
    from torch import Tensor, nn
else:
    torch = require("torch", extra="learn")
    nn = torch.nn
    Tensor = torch.Tensor

__all__ = ["GeneratorDropout", "MonteCarloConv", "PointEncoder", "DirectionHead",
           "SphereMapDecoder"]


class GeneratorDropout(nn.Module):
    """Dropout whose masks come from a :class:`torch.Generator`.

    Identical to :class:`torch.nn.Dropout` except that the random masks are
    drawn from ``self.generator`` (set by :meth:`ViewpointNet.set_generator`)
    rather than the global random state; without one, a generator seeded
    with 0 is created on first use.

    Args:
        p (float): Probability of zeroing an element. (default: 0.5)

    Shapes:
        - **input:** :math:`(*)`
        - **output:** :math:`(*)`, same shape
    """

    def __init__(self, p: float = 0.5) -> None:
        super().__init__()
        self.p = float(p)
        self.generator: torch.Generator | None = None

    def forward(self, x: Tensor) -> Tensor:
        if not self.training or self.p == 0.0:
            return x
        if self.generator is None:
            self.generator = torch.Generator(device=x.device).manual_seed(0)
        draws = torch.rand(x.shape, generator=self.generator, dtype=x.dtype, device=x.device)
        keep = draws >= self.p
        return x * keep / (1.0 - self.p)

    def extra_repr(self) -> str:
        return f"p={self.p}"


class MonteCarloConv(nn.Module):
    r"""The Monte Carlo convolution of Hermosilla et al. (2018).

    A continuous convolution over the points of a neighbourhood, estimated
    by Monte Carlo integration with importance weights: each neighbour
    counts in inverse proportion to the point density there, so the result
    estimates the kernel-weighted mean over the *surface* in the
    neighbourhood whatever the sampling density. The kernel is an MLP of
    the scaled offset with ``K`` outputs, combined with the features through
    a linear map (the efficient form of PointConv, Wu et al. 2019):

    .. math::
        \mathbf{x}'_i = \mathbf{W} \operatorname{vec}\left(
        \sum_{j \in \mathcal{N}(i)} w_{ij}\,
        g_{\Theta}\!\left(\frac{\mathbf{y}_j - \mathbf{c}_i}{r}\right)
        \mathbf{x}_j^{\top} \right) + \mathbf{b},
        \qquad
        w_{ij} = \frac{\hat p(\mathbf{y}_j)^{-1}}
                      {\sum_{k \in \mathcal{N}(i)} \hat p(\mathbf{y}_k)^{-1}}

    with centres :math:`\mathbf{c}_i`, neighbours :math:`\mathbf{y}_j`,
    their features :math:`\mathbf{x}_j`, density estimates :math:`\hat p`
    (:func:`point_density`), scale :math:`r` and the kernel MLP
    :math:`g_{\Theta}: \mathbb{R}^3 \to \mathbb{R}^K` (3 - hidden - K,
    ReLU). The weights are self-normalised, so :math:`\hat p` is needed up
    to a constant only; MCCNN divides by :math:`|\mathcal{N}(i)|` instead,
    which equals this for uniform sampling.

    Args:
        in_channels (int): Input feature size :math:`C_{in}`.
        out_channels (int): Output feature size :math:`C_{out}`.
        radius (float): Scale :math:`r` of the offsets (the ball radius).
        kernel_size (int): Kernel MLP outputs :math:`K`. (default: 16)
        kernel_hidden (int): Kernel MLP hidden units. (default: 16)

    Shapes:
        - **input:**
          source points :math:`(P, 3)`, source features :math:`(P, C_{in})`,
          densities :math:`(P)`, centres :math:`(M, 3)`,
          a :class:`Neighbourhood` of width :math:`S` (:math:`(M, S)`)
        - **output:** :math:`(M, C_{out})`
    """

    def __init__(self, in_channels: int, out_channels: int, *, radius: float,
                 kernel_size: int = 16, kernel_hidden: int = 16) -> None:
        super().__init__()
        self.in_channels = in_channels
        self.out_channels = out_channels
        self.radius = float(radius)
        self.kernel_size = kernel_size
        self.kernel = nn.Sequential(nn.Linear(3, kernel_hidden), nn.ReLU(),
                                    nn.Linear(kernel_hidden, kernel_size))
        self.linear = nn.Linear(kernel_size * in_channels, out_channels)

    def forward(self, source_points: Tensor, source_features: Tensor, density: Tensor,
                centre_points: Tensor, neighbourhood: Neighbourhood) -> Tensor:
        index, mask, count = neighbourhood
        # (M, S, 3)
        offsets = (gather_rows(source_points, index) - centre_points.unsqueeze(1)) / self.radius
        inverse_density = mask.to(offsets.dtype) / gather_rows(density, index)
        weights = inverse_density / inverse_density.sum(dim=1, keepdim=True).clamp_min(1e-12)
        kernel = self.kernel(offsets) * weights.unsqueeze(-1)  # (M, S, K)
        aggregated = kernel.transpose(1, 2) @ gather_rows(source_features, index)  # (M, K, C_in)
        return self.linear(aggregated.flatten(start_dim=1))

    def extra_repr(self) -> str:
        return (f"{self.in_channels}, {self.out_channels}, radius={self.radius:g}, "
                f"kernel_size={self.kernel_size}")


class PointEncoder(nn.Module):
    """Point clouds to one latent vector: Monte Carlo convolutions over a point hierarchy.

    Each level is :class:`MonteCarloConv`, batch norm and ReLU, from the
    points of the previous level to the cell barycentres of the next
    (:func:`build_hierarchy`); the last one integrates the whole model around
    its bounding-box centre. The input features are the normalised
    coordinates, followed by the point features ``config.point_features``
    (:mod:`vptoolkit.point_features`) when it names any. See the module
    docstring for the default sizes.

    Args:
        config (ModelConfig): The architecture.

    Shapes:
        - **input:** points :math:`(B, N, 3 + F)`: coordinates, then the
          :math:`F` point features
        - **output:** :math:`(B, C_{latent})`
    """

    def __init__(self, config: ModelConfig) -> None:
        super().__init__()
        self.config = config
        convs = []
        norms = []
        in_channels = config.input_channels
        for spec in config.levels:
            convs.append(MonteCarloConv(in_channels, spec.channels, radius=spec.radius,
                                        kernel_size=config.kernel_size,
                                        kernel_hidden=config.kernel_hidden))
            norms.append(nn.BatchNorm1d(spec.channels))
            in_channels = spec.channels
        convs.append(MonteCarloConv(in_channels, config.latent_channels, radius=GLOBAL_RADIUS,
                                    kernel_size=config.global_kernel_size,
                                    kernel_hidden=config.kernel_hidden))
        norms.append(nn.BatchNorm1d(config.latent_channels))
        self.convs = nn.ModuleList(convs)
        self.norms = nn.ModuleList(norms)

    def forward(self, points: Tensor) -> Tensor:
        check_clouds(points, self.config.input_channels)
        dtype = cast(MonteCarloConv, self.convs[0]).linear.weight.dtype
        points = points.to(dtype)
        hierarchy = build_hierarchy(points[..., :3], self.config)
        levels = hierarchy.levels
        features = levels[0].points
        n_models = levels[0].n_models
        if points.shape[-1] > 3:  # point features, put in level 0's order
            extra = points[..., 3:]
            order = hierarchy.order.unsqueeze(-1).expand(-1, -1, extra.shape[-1])
            features = torch.cat([features, torch.gather(extra, 1, order).reshape(
                -1, extra.shape[-1])], dim=1)
        centre = torch.zeros(n_models, 3, dtype=features.dtype, device=features.device)
        targets = [level.points for level in levels[1:]] + [centre]
        for i, (conv, norm) in enumerate(zip(self.convs, self.norms)):
            source = levels[i]
            features = torch.relu(norm(conv(source.points, features, hierarchy.densities[i],
                                            targets[i], hierarchy.neighbourhoods[i])))
        return features


class DirectionHead(nn.Module):
    """MLP from the latent vector to one output vector, for one measure.

    ``Linear - BatchNorm - ReLU - Dropout`` for every hidden width, then a
    final ``Linear``.

    Args:
        in_channels (int): Latent size.
        hidden (sequence of int): Hidden widths.
        out_channels (int): Output size (3 for a direction, 8 for sign logits).
        dropout (float): Dropout rate. (default: 0.5)

    Shapes:
        - **input:** :math:`(B, C_{in})`
        - **output:** :math:`(B, C_{out})`
    """

    def __init__(self, in_channels: int, hidden: Sequence[int], out_channels: int,
                 dropout: float = 0.5) -> None:
        super().__init__()
        layers: list[nn.Module] = []
        width = in_channels
        for size in hidden:
            layers += [nn.Linear(width, size), nn.BatchNorm1d(size), nn.ReLU(),
                       GeneratorDropout(dropout)]
            width = size
        layers.append(nn.Linear(width, out_channels))
        self.mlp = nn.Sequential(*layers)

    def forward(self, latent: Tensor) -> Tensor:
        return self.mlp(latent)


class _ResidualBlock(nn.Module):
    """Two 3 x 3 convolutions with batch norm and ReLU, plus the identity."""

    def __init__(self, channels: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(channels, channels, 3, padding=1, bias=False)
        self.norm1 = nn.BatchNorm2d(channels)
        self.conv2 = nn.Conv2d(channels, channels, 3, padding=1, bias=False)
        self.norm2 = nn.BatchNorm2d(channels)

    def forward(self, x: Tensor) -> Tensor:
        y = torch.relu(self.norm1(self.conv1(x)))
        return torch.relu(x + self.norm2(self.conv2(y)))


class SphereMapDecoder(nn.Module):
    """2D decoder from the latent vector to a 32 x 32 sphere map (DLDL head).

    After the paper's appendix "Distribution Learning": a 4 x 4
    deconvolution (1 -> 4 cells a side), two residual blocks, a 4 x 4
    stride-4 deconvolution (-> 16), two residual blocks and a 2 x 2 stride-2
    deconvolution (-> 32) to one channel, with batch norm and ReLU between
    the layers. Cells follow the octahedral map of
    :func:`vptoolkit.learn.octahedral.sphere_map_directions`.

    Args:
        in_channels (int): Latent size.
        channels (tuple of int): Widths at 4 x 4 and 16 x 16. (default: (64, 16))

    Shapes:
        - **input:** :math:`(B, C_{in})`
        - **output:** :math:`(B, 32, 32)`
    """

    def __init__(self, in_channels: int, channels: Sequence[int] = (64, 16)) -> None:
        super().__init__()
        wide, narrow = channels
        self.layers = nn.Sequential(
            nn.ConvTranspose2d(in_channels, wide, 4, stride=1, bias=False),
            nn.BatchNorm2d(wide),
            nn.ReLU(),
            _ResidualBlock(wide),
            _ResidualBlock(wide),
            nn.ConvTranspose2d(wide, narrow, 4, stride=4, bias=False),
            nn.BatchNorm2d(narrow),
            nn.ReLU(),
            _ResidualBlock(narrow),
            _ResidualBlock(narrow),
            nn.ConvTranspose2d(narrow, 1, 2, stride=2),
        )

    def forward(self, latent: Tensor) -> Tensor:
        return self.layers(latent[:, :, None, None])[:, 0]
