"""The viewpoint network: hierarchy, Monte Carlo convolution, heads and checkpoints."""

from __future__ import annotations

import json
import pickle
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.networks import TINY_CONFIG

require_package("torch")
require_package("safetensors")

import torch  # noqa: E402

from vptoolkit.errors import CheckpointError, InputError  # noqa: E402
from vptoolkit.io import load_mesh  # noqa: E402
from vptoolkit.learn import model as M  # noqa: E402
from vptoolkit.learn.checkpoint import MODEL_FORMAT, PRETRAINED, checkpoint_paths  # noqa: E402
from vptoolkit.learn.config import DEFAULT_LEVELS, HEADS, LevelConfig, ModelConfig  # noqa: E402
from vptoolkit.learn.hierarchy import (  # noqa: E402
    ball_query,
    cell_neighbourhood,
    grid_subsample,
    input_level,
    point_density,
)
from vptoolkit.points import network_input, sample_surface  # noqa: E402
from vptoolkit.samples import sample_path  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.fixture(scope="module")
def clouds(one_thread: None) -> torch.Tensor:
    """(2, 2048, 3) network inputs of two sample meshes, in their own coordinates."""
    inputs = []
    for name in ("bunny", "mug"):
        surface = sample_surface(load_mesh(sample_path(name)), 6000, seed=0).points
        inputs.append(network_input(surface, 2048, 512, rng=np.random.default_rng(0)))
    return torch.from_numpy(np.stack(inputs).astype(np.float32))


@pytest.fixture(scope="module")
def network(one_thread: None) -> M.ViewpointNet:
    return M.ViewpointNet(seed=0).eval()




# ---------------------------------------------------------------- outputs


@pytest.mark.parametrize("head", HEADS)
def test_output_shapes_and_unit_directions(head, clouds):
    model = M.ViewpointNet(ModelConfig(head=head)).eval()
    with torch.no_grad():
        outputs = model(clouds)
    directions = outputs["directions"]
    assert directions.shape == (2, 4, 3)
    assert torch.allclose(directions.norm(dim=-1), torch.ones(2, 4), atol=1e-5)
    if head == "sr":
        assert outputs["abs_directions"].shape == (2, 4, 3)
        assert outputs["sign_logits"].shape == (2, 4, 8)
        assert (outputs["abs_directions"] > 0).all()
    if head == "dldl":
        assert outputs["maps"].shape == (2, 4, 32, 32)


def test_training_mode_outputs_have_gradients(clouds):
    model = M.ViewpointNet(TINY_CONFIG).train()
    outputs = model(clouds)
    outputs["directions"].sum().backward()
    assert all(p.grad is not None for name, p in model.named_parameters()
               if "heads" in name or "encoder" in name)


def test_documented_parameter_counts_match(network):
    table = dict(re.findall(r"^\s+(direction|sr|dldl)\s+([\d,]+)\s*$", M.__doc__,
                            flags=re.MULTILINE))
    assert set(table) == set(HEADS)
    for head, documented in table.items():
        assert (M.count_parameters(M.ViewpointNet(ModelConfig(head=head)))
                == int(documented.replace(",", "")))
    encoder = M.count_parameters(network.encoder)
    assert f"{encoder:,} parameters" in M.__doc__
    for conv in network.encoder.convs:
        assert f"{M.count_parameters(conv):,}" in M.__doc__
    assert f"{M.count_parameters(network.heads[0]):,} parameters" in M.__doc__


def test_point_order_does_not_matter_in_eval_mode(network, clouds):
    permutation = torch.randperm(clouds.shape[1], generator=torch.Generator().manual_seed(3))
    with torch.no_grad():
        first = network(clouds)["directions"]
        second = network(clouds[:, permutation])["directions"]
    assert torch.allclose(first, second, atol=1e-5)


def test_position_and_size_do_not_matter(network, clouds):
    with torch.no_grad():
        first = network(clouds)["directions"]
        second = network(clouds * 4.0 + torch.tensor([8.0, -2.0, 0.5]))["directions"]
    assert torch.allclose(first, second, atol=1e-3)


def test_duplicating_every_point_changes_nothing(clouds):
    # Twice the density everywhere: the density-normalised Monte Carlo weights cancel it.
    levels = tuple(
        LevelConfig(spec.grid_level, spec.radius, 512, spec.channels, spec.neighbourhood)
        for spec in DEFAULT_LEVELS
    )
    model = M.ViewpointNet(ModelConfig(levels=levels)).eval()
    with torch.no_grad():
        single = model(clouds)["directions"]
        double = model(torch.cat([clouds, clouds], dim=1))["directions"]
    assert torch.allclose(single, double, atol=1e-4)


def test_batch_members_do_not_influence_each_other_in_eval_mode(network, clouds):
    with torch.no_grad():
        together = network(clouds)["directions"]
        alone = network(clouds[1:])["directions"]
    assert torch.allclose(together[1:], alone, atol=1e-5)


# ---------------------------------------------------------------- hierarchy


def test_input_level_is_sorted_by_morton_code(clouds):
    level = input_level(clouds)
    assert level.points.shape == (2 * 2048, 3) and level.n_models == 2
    for model in range(2):
        codes = level.codes[level.batch == model]
        assert (codes[1:] >= codes[:-1]).all()
    assert level.points.abs().max() <= 0.5 + 1e-6
    extent = level.points[level.batch == 0].amax(0) - level.points[level.batch == 0].amin(0)
    assert extent.norm().item() == pytest.approx(1.0, abs=1e-5)


def test_grid_subsample_gives_one_barycentre_per_occupied_cell(clouds):
    level = input_level(clouds)
    cells = grid_subsample(level, 4)
    for model in range(2):
        points = level.points[level.batch == model].numpy()
        occupied = np.unique(np.floor((points.astype(np.float64) + 0.5) * 16).clip(0, 15), axis=0)
        barycentres = cells.points[cells.batch == model].numpy()
        assert len(barycentres) == len(occupied)
        inside = np.floor((barycentres.astype(np.float64) + 0.5) * 16).clip(0, 15)
        assert {tuple(row) for row in inside} == {tuple(row) for row in occupied}


def test_ball_query_finds_exactly_the_points_in_the_ball(clouds):
    source = grid_subsample(input_level(clouds), 5)
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
    level = input_level(clouds)
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
    level = input_level(clouds)
    neighbourhood = cell_neighbourhood(level, 4, 4096)
    members = neighbourhood.index[neighbourhood.mask]
    assert torch.equal(members.sort().values, torch.arange(len(level.points)))


def test_point_density_counts_points_per_cell(clouds):
    level = input_level(clouds[:1])
    density = point_density(level, 3)
    cells = np.floor((level.points.double().numpy() + 0.5) * 8).clip(0, 7)
    _, inverse, counts = np.unique(cells, axis=0, return_inverse=True, return_counts=True)
    assert np.array_equal(density.numpy(), counts[inverse.reshape(-1)].astype(np.float32))


# ---------------------------------------------------------------- determinism and randomness


def test_initial_weights_come_from_the_seed_not_the_global_state():
    before = torch.get_rng_state()
    first = M.ViewpointNet(TINY_CONFIG, seed=5).state_dict()
    second = M.ViewpointNet(TINY_CONFIG, seed=5).state_dict()
    other = M.ViewpointNet(TINY_CONFIG, seed=6).state_dict()
    assert torch.equal(torch.get_rng_state(), before)
    assert all(torch.equal(first[name], second[name]) for name in first)
    assert not all(torch.equal(first[name], other[name]) for name in first)


def test_dropout_draws_from_its_generator(clouds):
    model = M.ViewpointNet(TINY_CONFIG).train()
    before = torch.get_rng_state()
    results = []
    for seed in (1, 1, 2):
        model.load_state_dict(M.ViewpointNet(TINY_CONFIG).state_dict())
        model.set_generator(torch.Generator().manual_seed(seed))
        results.append(model(clouds)["directions"].detach())
    assert torch.equal(torch.get_rng_state(), before)
    assert torch.equal(results[0], results[1])
    assert not torch.equal(results[0], results[2])


# ---------------------------------------------------------------- checkpoints


@pytest.mark.parametrize("head", HEADS)
def test_checkpoint_round_trip_gives_identical_outputs(head, tmp_path, clouds, monkeypatch):
    model = M.ViewpointNet(ModelConfig(head=head), seed=3)
    model.train()
    model(clouds)  # move the batch-norm statistics away from their initial values
    model.eval()
    weights, config_path = M.save_model(model, tmp_path / "net.safetensors",
                                        metadata={"labels": "test"})
    assert (weights.name, config_path.name) == ("net.safetensors", "net.json")
    config = json.loads(config_path.read_text())
    assert config["format"] == MODEL_FORMAT and config["architecture"]["head"] == head
    assert config["measures"] == ["VE", "VR", "VKL", "VMI"] and config["labels"] == "test"
    assert config["n_parameters"] == M.count_parameters(model)

    def no_unpickling(*args, **kwargs):
        raise AssertionError("a checkpoint was unpickled")

    monkeypatch.setattr(pickle, "load", no_unpickling)
    monkeypatch.setattr(pickle, "loads", no_unpickling)
    monkeypatch.setattr(pickle, "Unpickler", no_unpickling)
    monkeypatch.setattr(torch, "load", no_unpickling)
    loaded, loaded_config = M.load_model(tmp_path / "net.json")
    monkeypatch.undo()
    assert not loaded.training and loaded_config == config
    with torch.no_grad():
        expected = model(clouds)
        actual = loaded(clouds)
    assert expected.keys() == actual.keys()
    for key in expected:
        assert torch.equal(expected[key], actual[key]), key


def test_checkpoint_folder_layout(tmp_path):
    M.save_model(M.ViewpointNet(TINY_CONFIG), tmp_path / "run")
    assert (sorted(p.name for p in (tmp_path / "run").iterdir())
            == ["model.json", "model.safetensors"])
    model, _ = M.load_model(tmp_path / "run")
    assert model.config == TINY_CONFIG


def test_half_precision_checkpoint_is_half_the_size_and_predicts_the_same(tmp_path, clouds):
    model = M.ViewpointNet(seed=1).eval()
    full, _ = M.save_model(model, tmp_path / "full")
    half, config_path = M.save_model(model, tmp_path / "half", half=True)
    assert json.loads(config_path.read_text())["weights_dtype"] == "float16"
    assert half.stat().st_size < 0.52 * full.stat().st_size
    loaded, _ = M.load_model(tmp_path / "half")
    assert all(p.dtype == torch.float32 for p in loaded.parameters())
    with torch.no_grad():
        expected = model(clouds)["directions"]
        actual = loaded(clouds)["directions"]
    cosine = (expected * actual).sum(-1) / (expected.norm(dim=-1) * actual.norm(dim=-1))
    assert torch.rad2deg(torch.arccos(cosine.clamp(max=1.0))).max() < 1.0


def test_default_is_the_bundled_pretrained_checkpoint(tmp_path, monkeypatch):
    weights, config_path = checkpoint_paths("default")
    assert weights == PRETRAINED / "model.safetensors" and weights.stat().st_size <= 25_000_000
    model, config = M.load_model("default")
    assert config["labels"] in ("sl", "ml", "gl", "ml+gl", "sr", "dldl")
    assert config["weights_dtype"] == "float16"
    pretrained = config["pretrained"]
    assert pretrained["command"].startswith("python tools/reproduce_labels.py")
    # trained on real meshes that are not redistributed, and the record says so
    data = pretrained["training_data"]
    assert data["redistributed"] is False and data["counts"]["train"] > 1000
    assert len(data["classes"]) == 59
    monkeypatch.chdir(tmp_path)
    (tmp_path / "default").mkdir()  # a folder of that name is reached as a path, not "default"
    assert checkpoint_paths("default")[0] == PRETRAINED / "model.safetensors"
    assert checkpoint_paths("./default")[0] == Path("default") / "model.safetensors"
    assert checkpoint_paths(Path("default"))[0] == Path("default") / "model.safetensors"


def test_loading_bad_checkpoints_raises(tmp_path):
    with pytest.raises(InputError, match="no such checkpoint"):
        M.load_model(tmp_path / "missing")
    M.save_model(M.ViewpointNet(TINY_CONFIG), tmp_path / "small.safetensors")
    M.save_model(M.ViewpointNet(), tmp_path / "big.safetensors")
    (tmp_path / "big.safetensors").replace(tmp_path / "small.safetensors")
    with pytest.raises(CheckpointError, match="small.safetensors: weights do not match"):
        M.load_model(tmp_path / "small.safetensors")
    (tmp_path / "other.json").write_text('{"format": "something-else"}')
    (tmp_path / "other.safetensors").write_bytes(b"")
    with pytest.raises(InputError, match="other.json: not a vptoolkit model"):
        M.load_model(tmp_path / "other.json")


# ---------------------------------------------------------------- configuration


def test_configuration_round_trips_and_validates():
    assert ModelConfig.from_dict(json.loads(json.dumps(TINY_CONFIG.to_dict()))) == TINY_CONFIG
    with pytest.raises(InputError, match="head: unknown head"):
        ModelConfig(head="mlp")
    with pytest.raises(InputError, match=r"levels\[1\].radius"):
        ModelConfig(levels=(LevelConfig(2, 0.25, 16, 8), LevelConfig(2, 0.05, 16, 8)))
    with pytest.raises(InputError, match="^architecture: unknown width$"):
        ModelConfig.from_dict({"width": 3})
    with pytest.raises(InputError, match="points: expected shape"):
        M.ViewpointNet(TINY_CONFIG)(torch.zeros(5, 3))


def test_importing_vptoolkit_learn_does_not_import_torch():
    code = "import sys, vptoolkit, vptoolkit.learn; print('torch' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True)
    assert result.stdout.strip() == "False"


def test_torch_threads_is_scoped():
    before = torch.get_num_threads()
    with M.torch_threads(2):
        assert torch.get_num_threads() == 2
    assert torch.get_num_threads() == before
    with M.torch_threads(None):
        assert torch.get_num_threads() == before
    with pytest.raises(InputError, match="threads: expected a positive integer"):
        with M.torch_threads(0):
            pass
