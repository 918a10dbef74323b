"""The point hierarchy: Morton order, grid levels, neighbourhoods and densities."""

from __future__ import annotations

import numpy as np
import pytest

from fixtures.environment import require_package

require_package("torch")
require_package("safetensors")

import torch  # noqa: E402

from vptoolkit.learn.hierarchy import (  # noqa: E402
    ball_query,
    cell_neighbourhood,
    grid_subsample,
    input_level,
    point_density,
)

pytestmark = pytest.mark.usefixtures("one_thread")


def test_input_level_is_sorted_by_morton_code(clouds):
    level, _ = input_level(clouds)
    assert level.points.shape == (2 * 2048, 3) and level.n_models == 2
    for model in range(2):
        codes = level.codes[level.batch == model]
        assert (codes[1:] >= codes[:-1]).all()
    assert level.points.abs().max() <= 0.5 + 1e-6
    extent = level.points[level.batch == 0].amax(0) - level.points[level.batch == 0].amin(0)
    assert extent.norm().item() == pytest.approx(1.0, abs=1e-5)


def test_grid_subsample_gives_one_barycentre_per_occupied_cell(clouds):
    level, _ = input_level(clouds)
    cells = grid_subsample(level, 4)
    for model in range(2):
        points = level.points[level.batch == model].numpy()
        occupied = np.unique(np.floor((points.astype(np.float64) + 0.5) * 16).clip(0, 15), axis=0)
        barycentres = cells.points[cells.batch == model].numpy()
        assert len(barycentres) == len(occupied)
        inside = np.floor((barycentres.astype(np.float64) + 0.5) * 16).clip(0, 15)
        assert {tuple(row) for row in inside} == {tuple(row) for row in occupied}


def test_ball_query_finds_exactly_the_points_in_the_ball(clouds):
    source = grid_subsample(input_level(clouds)[0], 5)
    centres = grid_subsample(source, 3)
    radius = 1 / 8
    neighbourhood = ball_query(source, centres, radius, 1024)
    distance = torch.cdist(centres.points.double(), source.points.double())
    same_model = centres.batch[:, None] == source.batch[None, :]
    expected = (distance <= radius) & same_model
    assert (neighbourhood.count < 1024).all()
    for row in range(len(centres.points)):
        found = set(neighbourhood.index[row][neighbourhood.mask[row]].tolist())
        assert found == set(torch.nonzero(expected[row]).squeeze(-1).tolist())


def test_crowded_neighbourhoods_are_thinned_evenly(clouds):
    level, _ = input_level(clouds)
    neighbourhood = cell_neighbourhood(level, 2, 8)
    full = cell_neighbourhood(level, 2, 4096)
    assert neighbourhood.index.shape[1] == 8
    assert torch.equal(neighbourhood.count, full.count.clamp(max=8))
    assert (full.count > 100).sum() > 10
    for row in range(len(full.count)):
        members = full.index[row][full.mask[row]].tolist()
        kept = neighbourhood.index[row][neighbourhood.mask[row]].tolist()
        assert len(set(kept)) == len(kept) and set(kept) <= set(members)
        if len(members) >= 16:  # every eighth of the cell's run contributes one point
            positions = [members.index(index) * 8 // len(members) for index in kept]
            assert positions == list(range(8))


def test_cell_neighbourhoods_partition_the_points(clouds):
    level, _ = input_level(clouds)
    neighbourhood = cell_neighbourhood(level, 4, 4096)
    members = neighbourhood.index[neighbourhood.mask]
    assert torch.equal(members.sort().values, torch.arange(len(level.points)))


def test_point_density_counts_points_per_cell(clouds):
    level, _ = input_level(clouds[:1])
    density = point_density(level, 3)
    cells = np.floor((level.points.double().numpy() + 0.5) * 8).clip(0, 7)
    _, inverse, counts = np.unique(cells, axis=0, return_inverse=True, return_counts=True)
    assert np.array_equal(density.numpy(), counts[inverse.reshape(-1)].astype(np.float32))
