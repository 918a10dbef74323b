"""A network's checkpoint: weights and configuration files, read without pickles, and the
bundled one."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import pytest

from fixtures.environment import require_package
from fixtures.networks import TINY_CONFIG

require_package("torch")
require_package("safetensors")

import torch  # noqa: E402

from vptoolkit.errors import CheckpointError, InputError  # noqa: E402
from vptoolkit.learn import model as M  # noqa: E402
from vptoolkit.learn.checkpoint import MODEL_FORMAT, PRETRAINED, checkpoint_paths  # noqa: E402
from vptoolkit.learn.config import HEADS, ModelConfig  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_thread")


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
