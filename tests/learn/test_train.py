"""Training, resuming and predicting on a tiny dataset built from the sample meshes."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fixtures.builds import build_samples
from fixtures.environment import require_package
from fixtures.networks import TINY_CONFIG
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.settings import MeasureSettings

require_package("torch")
require_package("safetensors")
require_package("zarr")

import torch  # noqa: E402

from vptoolkit.data import open_dataset  # noqa: E402
from vptoolkit.errors import ExistingRunError, InputError  # noqa: E402
from vptoolkit.evaluate.protocol import random_view_scores, score_protocol  # noqa: E402
from vptoolkit.learn import train as T  # noqa: E402
from vptoolkit.learn.config import ModelConfig  # noqa: E402
from vptoolkit.learn.model import load_model  # noqa: E402
from vptoolkit.learn.options import TrainOptions  # noqa: E402
from vptoolkit.learn.predict import (  # noqa: E402
    CATEGORY_MODELS_FORMAT,
    Predictions,
    network_predictor,
    predict,
)
from vptoolkit.samples import sample_path  # noqa: E402

SHAPES = ("bottle", "bunny", "lego", "mug", "suzanne", "table", "teapot", "torus")
FAST = {"n_points": 512, "n_fps": 128, "rotate": False, "val_split": "train"}

pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.fixture(scope="module")
def dataset_dir(tmp_path_factory: pytest.TempPathFactory, one_thread: None) -> Path:
    """Eight sample meshes measured from 100 views at 64 px: six train, one val, one test."""
    options = BuildOptions(MeasureSettings(views=100, resolution=64), n_points=2000, clean=False)
    out = build_samples(tmp_path_factory.mktemp("learn"), SHAPES, category="shapes",
                        options=options)
    torch.set_num_threads(1)  # numba.set_num_threads in the build sets torch's OpenMP threads too
    return out


@pytest.fixture(scope="module")
def trained(dataset_dir: Path, tmp_path_factory: pytest.TempPathFactory,
            one_thread: None) -> T.TrainResult:
    """The paper's network and ML+GL labels, 60 one-batch epochs on six training models, rotated."""
    output = tmp_path_factory.mktemp("run") / "net.safetensors"
    options = TrainOptions(labels="ml+gl", epochs=60, batch_size=6, lr=1e-3, lr_step=20,
                           lr_decay=0.5, seed=0, **{**FAST, "rotate": True})
    return T.train_model(dataset_dir, output, options, device="cpu")


def test_tiny_run_lowers_the_loss_and_beats_a_random_view(trained, dataset_dir):
    losses = [entry["loss"] for entry in trained.history]
    assert trained.epochs == 60 and trained.n_train == 6 and trained.n_val == 6
    assert [entry["phase"] for entry in trained.history] == ["ml"] * 30 + ["gl"] * 30
    assert np.mean(losses[25:30]) < 0.8 * np.mean(losses[:3])  # ML's loss falls under rotations
    assert trained.history[0]["lr"] == 1e-3
    assert trained.history[-1]["lr"] == pytest.approx(1e-3 / 4)

    # The kept checkpoint on fresh inputs (another point selection than training and validation)
    # under rotations it never saw: it must beat a random view on the models it learned.
    with open_dataset(dataset_dir) as dataset:
        train = dataset.split("train")
        scores = score_protocol(train, network_predictor(trained.checkpoint, seed=7, dataset=train),
                                n_rotations=3,
                                seed=11)
        random = random_view_scores(train)
    assert scores.mean.mean() > random.mean.mean() + 5.0, (scores.mean, random.mean)
    assert (scores.mean > random.mean).sum() >= 3, (scores.mean, random.mean)
    best = trained.history[trained.best_epoch - 1]
    assert (best["val_score"] == trained.best_score
            == max(entry["val_score"] for entry in trained.history))


def test_checkpoint_configuration_records_the_run(trained):
    config = json.loads(trained.config_path.read_text())
    assert config["format"] == "vptoolkit-viewpoint-model"
    assert config["labels"] == "ml+gl" and config["measures"] == ["VE", "VR", "VKL", "VMI"]
    assert config["architecture"] == ModelConfig(point_features=("face_area",)).to_dict()
    assert config["input"] == {"n_points": 512, "n_fps": 128}
    training = config["training"]
    assert training["arguments"]["lr"] == 1e-3 and training["arguments"]["labels"] == "ml+gl"
    assert training["command"].startswith("vptoolkit.learn.train.train_model(")
    assert "TrainOptions(labels='ml+gl', epochs=60, batch_size=6," in training["command"]
    assert ({"dataset_path", "output", "save_every", "workers", "device"}
            <= set(training["arguments"]))
    recorded = {key: value for key, value in training["arguments"].items()
                if key in {item.name for item in dataclasses.fields(TrainOptions)}}
    assert TrainOptions.from_dict(recorded) == TrainOptions(
        labels="ml+gl", epochs=60, batch_size=6, lr_step=20, lr_decay=0.5,
        **{**FAST, "rotate": True})
    assert training["epochs"] == 60 and training["epochs_completed"] == 60
    assert training["best_epoch"] == trained.best_epoch
    assert training["best_score"] == trained.best_score
    assert set(training["best_scores"]) == {"VE", "VR", "VKL", "VMI"}
    assert len(training["history"]) == 60
    assert config["toolkit_version"] and config["torch_version"] == torch.__version__
    names = sorted(p.name for p in trained.checkpoint.parent.iterdir())
    assert names == ["net.json", "net.last.json", "net.last.safetensors", "net.safetensors"]
    model, loaded = load_model(trained.checkpoint)
    assert loaded == config and not model.training


def tiny_options(**changes: Any) -> TrainOptions:
    """Four epochs of the tiny network on 512 unrotated points, validated on the train split."""
    values = {"labels": "ml+gl", "epochs": 4, "batch_size": 2, **FAST, **changes}
    head = {"sr": "sr", "dldl": "dldl"}.get(values["labels"], "direction")
    values.setdefault("architecture", dataclasses.replace(TINY_CONFIG, head=head))
    return TrainOptions(**values)


def tiny_run(dataset_dir: Path, output: Path, options: TrainOptions | None = None,
             **run: Any) -> T.TrainResult:
    return T.train_model(dataset_dir, output, options or tiny_options(), device="cpu", **run)


def weights(path: Path) -> dict[str, torch.Tensor]:
    from safetensors.torch import load_file

    return load_file(str(path))


def without_seconds(history: tuple[dict[str, Any], ...]) -> list[dict[str, Any]]:
    return [{key: value for key, value in entry.items() if key != "seconds"} for entry in history]


def test_resumed_run_equals_an_uninterrupted_one(dataset_dir, tmp_path, monkeypatch):
    whole = tiny_run(dataset_dir, tmp_path / "whole")

    calls = {"n": 0}
    real_epoch = T._train_epoch

    def stop_after_two(*args: Any, **kwargs: Any) -> float:
        if calls["n"] == 2:
            raise KeyboardInterrupt
        calls["n"] += 1
        return real_epoch(*args, **kwargs)

    monkeypatch.setattr(T, "_train_epoch", stop_after_two)
    with pytest.raises(KeyboardInterrupt):
        tiny_run(dataset_dir, tmp_path / "parts", save_every=2)
    monkeypatch.undo()
    state = json.loads((tmp_path / "parts" / "model.last.json").read_text())
    assert state["epoch"] == 2
    resumed = tiny_run(dataset_dir, tmp_path / "parts", resume=True, threads=1, save_every=3)

    assert without_seconds(resumed.history) == without_seconds(whole.history)
    assert resumed.best_epoch == whole.best_epoch
    for name in ("model.safetensors", "model.last.safetensors"):
        first, second = weights(tmp_path / "whole" / name), weights(tmp_path / "parts" / name)
        assert first.keys() == second.keys()
        assert all(torch.equal(first[key], second[key]) for key in first), name


def test_resume_can_extend_a_finished_run(dataset_dir, tmp_path):
    tiny_run(dataset_dir, tmp_path / "run", tiny_options(labels="sl", epochs=2))
    extended = tiny_run(dataset_dir, tmp_path / "run", tiny_options(labels="sl", epochs=3),
                        resume=True)
    assert [entry["epoch"] for entry in extended.history] == [1, 2, 3]


def test_a_run_with_the_default_step_resumes_with_more_epochs(dataset_dir, tmp_path, monkeypatch):
    tiny_run(dataset_dir, tmp_path / "run", tiny_options(epochs=1))  # step 1
    longer = tiny_options(epochs=23)
    assert longer.lr_step == 2
    with pytest.raises(InputError, match=r"cannot resume with other options \(lr_step: 1 -> 3\)"):
        tiny_run(dataset_dir, tmp_path / "run", tiny_options(epochs=23, lr_step=3), resume=True)

    calls = {"n": 0}
    real_epoch = T._train_epoch

    def stop_after_one(*args: Any, **kwargs: Any) -> float:
        if calls["n"] == 1:
            raise KeyboardInterrupt
        calls["n"] += 1
        return real_epoch(*args, **kwargs)

    monkeypatch.setattr(T, "_train_epoch", stop_after_one)
    with pytest.raises(KeyboardInterrupt):
        tiny_run(dataset_dir, tmp_path / "run", longer, resume=True, save_every=1)
    state = json.loads((tmp_path / "run" / "model.last.json").read_text())
    assert state["epoch"] == 2 and state["arguments"]["lr_step"] == 2


def test_existing_runs_are_not_overwritten_by_accident(dataset_dir, tmp_path):
    tiny_run(dataset_dir, tmp_path / "run", tiny_options(epochs=1))
    with pytest.raises(ExistingRunError, match="already holds a training run"):
        tiny_run(dataset_dir, tmp_path / "run", tiny_options(epochs=1))
    with pytest.raises(InputError, match=r"cannot resume with other options \(seed: 0 -> 1\)"):
        tiny_run(dataset_dir, tmp_path / "run", tiny_options(epochs=1, seed=1), resume=True)
    replaced = tiny_run(dataset_dir, tmp_path / "run", tiny_options(epochs=1, seed=1),
                        overwrite=True)
    assert replaced.epochs == 1


@pytest.mark.parametrize("labels", ["sl", "ml", "gl", "sr", "dldl"])
def test_every_label_method_trains_and_predicts(labels, dataset_dir, tmp_path):
    result = tiny_run(dataset_dir, tmp_path / labels, tiny_options(labels=labels, epochs=2))
    assert all(np.isfinite(entry["loss"]) for entry in result.history)
    model, config = load_model(result.checkpoint)
    assert config["labels"] == labels
    assert model.config.head == {"sr": "sr", "dldl": "dldl"}.get(labels, "direction")
    predictions = predict(result.checkpoint, dataset_dir, split="test")
    assert predictions.directions.shape == (1, 4, 3)
    assert np.allclose(np.linalg.norm(predictions.directions, axis=-1), 1.0)


def test_predict_meshes_point_files_and_datasets(trained, dataset_dir, tmp_path):
    from vptoolkit.io import load_mesh
    from vptoolkit.learn.model import ViewpointNet, save_model
    from vptoolkit.points import sample_surface

    duck = sample_path("Duck")
    surface = sample_surface(load_mesh(duck), 3000, seed=0)
    (tmp_path / "six").mkdir()
    (tmp_path / "three").mkdir()
    np.save(tmp_path / "six" / "duck.npy",
            np.hstack([surface.points, surface.normals]).astype(np.float32))
    np.save(tmp_path / "three" / "duck.npy", surface.points.astype(np.float32))
    predictions = predict(trained.checkpoint, [dataset_dir, duck], split=None, batch_size=3)
    with open_dataset(dataset_dir) as dataset:
        assert predictions.names == (*dataset.names, "Duck")
    assert predictions.measures == ("VE", "VR", "VKL", "VMI")
    assert predictions.directions.shape == (9, 4, 3) and predictions.directions.dtype == np.float64
    assert np.allclose(np.linalg.norm(predictions.directions, axis=-1), 1.0)
    again = predict(trained.checkpoint, [duck], seed=0)
    assert np.allclose(again.directions[0], predictions.directions[8], atol=1e-5)  # batch of 1 vs 3
    # The trained network reads face areas, which a point file does not carry: one line says so
    with pytest.raises(InputError, match=r"duck.npy: the network reads point features \(face_"):
        predict(trained.checkpoint, tmp_path / "six" / "duck.npy")
    # A network of coordinates alone reads point files: (N, 6) and (N, 3) files of the same
    # points give the same prediction
    plain, _ = save_model(ViewpointNet(ModelConfig(), seed=3), tmp_path / "plain.safetensors")
    six = predict(plain, tmp_path / "six" / "duck.npy")
    three = predict(plain, tmp_path / "three" / "duck.npy")
    assert np.allclose(three.directions, six.directions, atol=1e-5)

    path = predictions.save_npz(tmp_path / "predictions.npz")
    with np.load(path, allow_pickle=False) as archive:
        assert sorted(archive.files) == ["directions", "measures", "names"]
        assert archive["names"].dtype.kind == "U" and archive["measures"].dtype.kind == "U"
        assert archive["directions"].dtype == np.float64
        assert archive["names"].tolist() == list(predictions.names)
    loaded = Predictions.load_npz(path)
    assert loaded.names == predictions.names
    assert np.array_equal(loaded.directions, predictions.directions)
    assert not any(p.name.endswith(".partial") for p in tmp_path.iterdir())


def test_mesh_predictor_matches_predict_on_the_file(trained):
    from vptoolkit.io import load_mesh
    from vptoolkit.learn.predict import MeshPredictor

    duck = sample_path("Duck")
    predictor = MeshPredictor(trained.checkpoint, seed=2)
    directions = predictor(load_mesh(duck))
    assert directions.shape == (4, 3) and predictor.measures == ("VE", "VR", "VKL", "VMI")
    expected = predict(trained.checkpoint, [duck], seed=2).directions[0]
    assert np.allclose(directions, expected, atol=1e-5)
    with pytest.raises(InputError, match="seed"):
        MeshPredictor(trained.checkpoint, seed=-1)


def test_predict_rejects_bad_inputs(trained, tmp_path):
    with pytest.raises(InputError, match="missing.obj: no such file"):
        predict(trained.checkpoint, [tmp_path / "missing.obj"])
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(InputError, match="notes.txt: not a model file"):
        predict(trained.checkpoint, [tmp_path / "notes.txt"])
    # point files, for a network of coordinates alone
    from vptoolkit.learn.model import ViewpointNet, save_model

    plain, _ = save_model(ViewpointNet(ModelConfig()), tmp_path / "plain.safetensors")
    np.save(tmp_path / "bad.npy", np.zeros((10, 4)))
    with pytest.raises(InputError, match=r"bad.npy: expected an \(N, 3\) or \(N, 6\)"):
        predict(plain, [tmp_path / "bad.npy"])
    np.save(tmp_path / "a.npy", np.random.default_rng(0).normal(size=(500, 3)))
    (tmp_path / "b").mkdir()
    np.save(tmp_path / "b" / "a.npy", np.random.default_rng(1).normal(size=(500, 3)))
    assert predict(plain, [tmp_path / "a.npy", tmp_path / "b" / "a.npy"]).names == ("a", "b__a")
    np.savetxt(tmp_path / "a.xyz", np.random.default_rng(2).normal(size=(500, 3)))
    with pytest.raises(InputError, match="two models are named 'a'"):
        predict(plain, [tmp_path / "a.npy", tmp_path / "a.xyz"])
    with pytest.raises(InputError, match=r"\.npz"):
        Predictions(("a",), np.zeros((1, 4, 3))).save_npz(tmp_path / "out.npy")


def test_train_model_checks_its_run_keywords(dataset_dir, tmp_path):
    with pytest.raises(InputError, match="options: expected TrainOptions, got dict"):
        T.train_model(dataset_dir, tmp_path / "x", {"epochs": 1})  # type: ignore[arg-type]
    with pytest.raises(InputError, match="save_every: must be at least 1"):
        T.train_model(dataset_dir, tmp_path / "x", tiny_options(), save_every=0)
    with pytest.raises(InputError, match="workers: must be at least 0"):
        T.train_model(dataset_dir, tmp_path / "x", tiny_options(), workers=-1)
    assert not (tmp_path / "x").exists()


def test_the_farthest_point_pool_keeps_a_few_subsets_per_model(dataset_dir):
    from vptoolkit.data.torch import ViewpointTorchDataset

    with open_dataset(dataset_dir) as dataset:
        pooled = ViewpointTorchDataset(dataset.split("train"), n_points=300, n_fps=100, fps_pool=3,
                                       rotate=False)
        again = ViewpointTorchDataset(dataset.split("train"), n_points=300, n_fps=100, fps_pool=3,
                                      rotate=False)
        subsets, items = set(), []
        for epoch in range(12):
            pooled.set_epoch(epoch)
            item = pooled[0]
            items.append(item["points"])
            subsets.add(item["points"][:100].numpy().tobytes())
        assert len(subsets) <= 3  # farthest-point parts come from the pool
        # random parts stay fresh
        assert len({points[100:].numpy().tobytes() for points in items}) == 12
        again.set_epoch(11)  # the same item whatever was drawn before
        assert torch.equal(again[0]["points"], items[-1])


def test_training_fewer_categories_keeps_the_others_in_the_index(tmp_path, monkeypatch):
    import contextlib

    trained = []

    def fake_train(dataset_path, output, options, **run):
        Path(output).mkdir(parents=True, exist_ok=True)
        trained.append(options.categories[0])
        return options.categories[0]

    monkeypatch.setattr(T, "train_model", fake_train)
    monkeypatch.setattr(T, "open_dataset", lambda path: contextlib.nullcontext(None))
    monkeypatch.setattr(T, "select_categories", lambda dataset, chosen: list(chosen))
    T.train_per_category("ds", tmp_path / "per", TrainOptions(categories=["a", "b"]))
    T.train_per_category("ds", tmp_path / "per", TrainOptions(categories=["a"]), resume=True)
    index = json.loads((tmp_path / "per" / "categories.json").read_text())
    assert index["categories"] == {"a": "a", "b": "b"} and trained == ["a", "b", "a"]
    (tmp_path / "per" / "categories.json").write_text('{"format": "other"}')
    with pytest.raises(InputError, match="categories.json: not a vptoolkit per-category index"):
        T.train_per_category("ds", tmp_path / "per", TrainOptions(categories=["a"]), resume=True)
    assert trained == ["a", "b", "a"]


@pytest.mark.parametrize("category", ["../../escaped", "/tmp/escaped", ".."])
def test_a_category_that_is_not_a_folder_name_trains_nothing(tmp_path, monkeypatch, category):
    import contextlib

    trained = []
    monkeypatch.setattr(T, "train_model", lambda *args, **run: trained.append(args))
    monkeypatch.setattr(T, "open_dataset", lambda path: contextlib.nullcontext(None))
    monkeypatch.setattr(T, "select_categories", lambda dataset, chosen: ["a", category])
    (tmp_path / "deep" / "er").mkdir(parents=True)
    with pytest.raises(InputError) as caught:
        T.train_per_category("ds.zarr", tmp_path / "deep" / "er" / "per",
                             TrainOptions(categories=["a"]))
    assert str(caught.value).startswith(f"ds.zarr: category {category!r} cannot name a file")
    assert trained == [] and list((tmp_path / "deep" / "er").iterdir()) == []


def test_one_network_per_category_and_routing(dataset_dir, tmp_path):
    with open_dataset(dataset_dir) as dataset:
        train = dataset.split("train")
        categories = dict(zip(train.names, train.categories))
    options = TrainOptions(labels="ml", epochs=1, batch_size=2, architecture=TINY_CONFIG, **FAST)
    results = T.train_per_category(dataset_dir, tmp_path / "per", options, device="cpu")
    assert sorted(results) == sorted(set(categories.values()))
    index = json.loads((tmp_path / "per" / "categories.json").read_text())
    assert index["format"] == CATEGORY_MODELS_FORMAT
    assert sorted(index["categories"]) == sorted(results)
    for name, result in results.items():
        config = json.loads(result.config_path.read_text())
        assert config["categories"] == [name]
        assert result.n_train == list(categories.values()).count(name)
    predictions = predict(tmp_path / "per", dataset_dir, split="train")
    for name, directions in zip(predictions.names, predictions.directions):
        alone = predict(tmp_path / "per" / categories[name], dataset_dir, split="train")
        assert np.allclose(directions, alone.directions[alone.names.index(name)], atol=1e-6)
    with pytest.raises(InputError, match="one network per category"):
        predict(tmp_path / "per", [sample_path("Duck")])
    chosen = sorted(results)[0]
    chosen_predictions = predict(tmp_path / "per", [sample_path("Duck")], category=chosen)
    assert chosen_predictions.directions.shape == (1, 4, 3)
    with pytest.raises(InputError, match="categories:"):
        T.train_model(dataset_dir, tmp_path / "x",
                      dataclasses.replace(options, categories=["no-such-category"]))


@pytest.mark.parametrize("epoch", [10**12, -1, 1])
def test_a_resumed_state_with_an_impossible_epoch_is_refused(dataset_dir, tmp_path, epoch):
    tiny_run(dataset_dir, tmp_path / "run", tiny_options(epochs=2))
    state_path = tmp_path / "run" / "model.last.json"
    state = json.loads(state_path.read_text())
    state["epoch"] = epoch  # the history holds two epochs
    state_path.write_text(json.dumps(state))
    config_before = (tmp_path / "run" / "model.json").read_bytes()
    with pytest.raises(InputError, match=r"^model\.last\.json: epoch"):
        tiny_run(dataset_dir, tmp_path / "run", tiny_options(epochs=3), resume=True)
    assert (tmp_path / "run" / "model.json").read_bytes() == config_before


def test_resuming_with_fewer_epochs_than_done_is_refused(dataset_dir, tmp_path):
    tiny_run(dataset_dir, tmp_path / "run", tiny_options(epochs=2))
    with pytest.raises(InputError, match="at epoch 2, past the 1 epochs asked for"):
        tiny_run(dataset_dir, tmp_path / "run", tiny_options(epochs=1), resume=True)
