"""The viewpoint network: output shapes and invariances, seeded weights and dropout, torch's
threads and devices."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from fixtures.environment import require_package
from fixtures.networks import TINY_CONFIG

require_package("torch")
require_package("safetensors")

import torch  # noqa: E402

from vptoolkit.errors import InputError  # noqa: E402
from vptoolkit.learn import model as M  # noqa: E402
from vptoolkit.learn.config import DEFAULT_LEVELS, HEADS, LevelConfig, ModelConfig  # noqa: E402
from vptoolkit.learn.model import resolve_device  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.fixture(scope="module")
def network(one_thread: None) -> M.ViewpointNet:
    return M.ViewpointNet(seed=0).eval()


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


def test_devices_resolve_and_cuda_is_never_required():
    assert resolve_device("cpu").type == "cpu"
    assert resolve_device("auto").type == ("cuda" if torch.cuda.is_available() else "cpu")
    if not torch.cuda.is_available():
        with pytest.raises(InputError, match="sees no CUDA device"):
            resolve_device("cuda")
    with pytest.raises(InputError, match="device: expected"):
        resolve_device("tpu")
