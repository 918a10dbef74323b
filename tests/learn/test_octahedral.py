"""The octahedral sphere grid of the DLDL label maps."""

from __future__ import annotations

from fixtures.environment import require_package

require_package("torch")

import torch  # noqa: E402

from vptoolkit.learn.octahedral import (  # noqa: E402
    octahedral_decode,
    octahedral_encode,
    sphere_map_cell,
    sphere_map_directions,
)


def test_octahedral_map_round_trip():
    directions = torch.randn(2000, 3, dtype=torch.float64,
                             generator=torch.Generator().manual_seed(1))
    directions /= directions.norm(dim=-1, keepdim=True)
    assert torch.allclose(octahedral_decode(octahedral_encode(directions)), directions, atol=1e-12)
    centres = sphere_map_directions(32, dtype=torch.float64)
    assert centres.shape == (32, 32, 3)
    assert torch.equal(sphere_map_cell(centres.reshape(-1, 3)), torch.arange(32 * 32))
