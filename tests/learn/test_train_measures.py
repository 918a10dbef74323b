"""Networks of any recorded measures: training on a store of VE, NVT and SL, predicting,
checkpoints that name their heads, and the prior of a search for some measures."""

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
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.settings import MeasureSettings

require_package("torch")
require_package("safetensors")
require_package("zarr")

import torch  # noqa: E402

from vptoolkit.cli import main  # noqa: E402
from vptoolkit.data import open_dataset  # noqa: E402
from vptoolkit.data.torch import ViewpointTorchDataset  # noqa: E402
from vptoolkit.errors import InputError  # noqa: E402
from vptoolkit.learn import train as T  # noqa: E402
from vptoolkit.learn.labels import head_for_method  # noqa: E402
from vptoolkit.learn.model import ViewpointNet, load_model, save_model  # noqa: E402
from vptoolkit.learn.options import TrainOptions  # noqa: E402
from vptoolkit.learn.predict import CATEGORY_MODELS_FORMAT, MeshPredictor, predict  # noqa: E402
from vptoolkit.learn.prior import NetworkPrior  # noqa: E402
from vptoolkit.samples import sample_path  # noqa: E402

MEASURED = ("VE", "NVT", "SL")
"""The store's measures: one of the paper's, one area count and one silhouette measure."""

SHAPES = ("bottle", "mug", "table", "teapot")
FAST = {"n_points": 512, "n_fps": 128, "rotate": False, "val_split": "train", "val_rotations": 0,
        "batch_size": 2}

pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.fixture(scope="module")
def three(tmp_path_factory: pytest.TempPathFactory, one_thread: None) -> Path:
    """Four sample meshes measured with VE, NVT and SL from 60 views at 64 px, 1100 points each
    (enough for ``vptool train``'s check): a build folder."""
    options = BuildOptions(MeasureSettings(views=60, resolution=64), n_points=1100, clean=False,
                           measures=MEASURED)
    out = build_samples(tmp_path_factory.mktemp("three"), SHAPES, category="shapes",
                        options=options)
    torch.set_num_threads(1)  # numba.set_num_threads in the build sets torch's OpenMP threads too
    return out


def tiny_options(**changes: Any) -> TrainOptions:
    """Two epochs of the tiny network on 512 unrotated points, validated on the train split in
    the stored orientation."""
    values = {"labels": "ml+gl", "epochs": 2, **FAST, **changes}
    values.setdefault("architecture",
                      dataclasses.replace(TINY_CONFIG, head=head_for_method(values["labels"])))
    return TrainOptions(**values)


def nearest_view_scores(dataset_dir: Path, checkpoint: Path, seed: int) -> dict[str, float]:
    """Mean normalised quality of the stored view nearest to the network's answer, per measure
    of the network, over the train split, scored with the dataset's own columns by name; one
    input per model, as the validation draws it."""
    predictions = predict(checkpoint, dataset_dir, split="train", seed=seed, device="cpu",
                          n_inputs=1)
    with open_dataset(dataset_dir) as dataset:
        scores = {name: [] for name in predictions.measures}
        for name, directions in zip(predictions.names, predictions.directions):
            quality = dataset.quality_of(name, directions)  # (M, every stored measure)
            for row, measure in enumerate(predictions.measures):
                scores[measure].append(quality[row, dataset.measures.index(measure)])
    return {name: float(np.mean(values)) for name, values in scores.items()}


@pytest.mark.parametrize(("labels", "measures"), [
    ("sl", None), ("ml+gl", None), ("sr", "SL,VE"), ("dldl", ("NVT",)),
])
def test_a_network_learns_the_recorded_measures_and_names_them(three, tmp_path, labels, measures):
    result = T.train_model(three, tmp_path / "net", tiny_options(labels=labels, measures=measures),
                           device="cpu")
    names = MEASURED if measures is None else tuple(
        measures.split(",") if isinstance(measures, str) else measures)
    assert list(result.best_scores) == list(names)
    assert all(list(entry["val_scores"]) == list(names) for entry in result.history)
    assert all(np.isfinite(entry["loss"]) for entry in result.history)
    assert result.best_score == pytest.approx(np.mean(list(result.best_scores.values())))

    config = json.loads(result.config_path.read_text())
    assert config["measures"] == list(names) == config["architecture"]["measures"]
    assert "n_measures" not in config["architecture"]
    training = config["training"]
    assert training["dataset_attrs"]["measures"] == list(MEASURED)
    assert training["arguments"]["measures"] == (None if measures is None else list(names))
    assert set(training["best_scores"]) == set(names)

    model, _ = load_model(result.checkpoint)
    assert model.measures == names and len(model.heads) == len(names)
    predictions = predict(result.checkpoint, three, split=None, device="cpu")
    with open_dataset(three) as dataset:
        assert predictions.names == tuple(dataset.names)
    assert predictions.measures == names
    assert predictions.directions.shape == (len(SHAPES), len(names), 3)
    assert np.allclose(np.linalg.norm(predictions.directions, axis=-1), 1.0)
    # The validation scored each head against its own column: the same inputs scored by name
    # with the dataset's arrays give the best epoch's scores.
    rescored = nearest_view_scores(three, result.checkpoint, seed=tiny_options().seed)
    assert rescored == pytest.approx(result.best_scores, abs=1e-5)


def test_the_labels_are_the_named_columns_in_the_networks_order(three):
    with open_dataset(three) as dataset:
        options, columns = T._measure_columns(dataset, tiny_options(measures="SL,VE"))
        assert options.measures == ("SL", "VE") == options.model_config.measures
        assert columns == (2, 0)
        plain = ViewpointTorchDataset(dataset, n_points=64, n_fps=16, seed=3)
        taken = ViewpointTorchDataset(dataset, n_points=64, n_fps=16, seed=3,
                                      transform=T._TakeMeasures(columns))
        item, chosen = plain[1], taken[1]
    assert torch.equal(chosen["points"], item["points"])
    assert torch.equal(chosen["quality"], item["quality"][:, [2, 0]])
    assert torch.equal(chosen["best_index"], item["best_index"][[2, 0]])
    assert torch.equal(chosen["best_views"], item["views"][item["best_index"][[2, 0]]])
    assert chosen["quality"][chosen["best_index"], [0, 1]].tolist() == [1.0, 1.0]


def test_a_measure_the_dataset_does_not_record_is_refused(three, tmp_path):
    with pytest.raises(InputError, match=r"^measures: .* does not record VMI \(it records VE, "
                                         r"NVT, SL\)$"):
        T.train_model(three, tmp_path / "net", tiny_options(measures="VE,VMI"), device="cpu")
    assert not (tmp_path / "net").exists()


@pytest.mark.parametrize(("names", "message"), [
    ("VE,VMI", "does not record VMI (it records VE, NVT, SL)"),
    ("VE,XYZ", "unknown measure 'XYZ'"),
    ("SL,SL", "SL named twice"),
])
def test_train_refuses_bad_measures_in_one_line(runner, three, tmp_path, names, message):
    result = runner.invoke(main, ["train", str(three), "-o", str(tmp_path / "net"), "--epochs",
                                  "1", "--threads", "1", "--measures", names])
    assert result.exit_code == 2, result.output
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.output
    assert result.stderr.startswith("vptool: error: --measures: ") and message in result.stderr
    assert not (tmp_path / "net").exists()


def test_resuming_with_other_measures_is_refused(three, tmp_path):
    T.train_model(three, tmp_path / "net", tiny_options(epochs=1, measures="VE,NVT"),
                  device="cpu")
    with pytest.raises(InputError, match=r"cannot resume with other options \(measures: "
                                         r"\['VE', 'NVT'\] -> \['VE'\]\)"):
        T.train_model(three, tmp_path / "net", tiny_options(epochs=2, measures="VE"),
                      resume=True, device="cpu")
    with pytest.raises(InputError, match=r"measures: \['VE', 'NVT'\] -> \['VE', 'NVT', 'SL'\]"):
        T.train_model(three, tmp_path / "net", tiny_options(epochs=2), resume=True, device="cpu")
    resumed = T.train_model(three, tmp_path / "net", tiny_options(epochs=2, measures="VE,NVT"),
                            resume=True, device="cpu")
    assert resumed.epochs == 2 and list(resumed.best_scores) == ["VE", "NVT"]


def test_options_without_measures_stand_for_their_architectures():
    named = TrainOptions(measures=("VE", "VR", "VKL", "VMI"))
    assert named.resume_conflicts(TrainOptions()) == {}  # a run recorded before measures
    assert TrainOptions(measures="SL").model_config.measures == ("SL",)
    assert set(TrainOptions(measures="SL").resume_conflicts(TrainOptions())) == {"measures"}
    assert TrainOptions.from_dict(named.to_dict()) == named


# ---------------------------------------------------------------- checkpoints


def saved(tmp_path: Path, measures: tuple[str, ...], name: str = "net", **changes: Any) -> Path:
    """An untrained tiny network with heads for ``measures``, saved under ``tmp_path/name``."""
    config = dataclasses.replace(TINY_CONFIG, measures=measures, **changes)
    save_model(ViewpointNet(config, seed=1), tmp_path / name)
    return tmp_path / name


def rewrite(folder: Path, change: Any) -> None:
    path = folder / "model.json"
    config = json.loads(path.read_text())
    change(config)
    path.write_text(json.dumps(config))


def test_a_checkpoint_naming_an_unknown_measure_is_one_line(tmp_path, runner):
    folder = saved(tmp_path, MEASURED)

    def name_xyz(config: dict[str, Any]) -> None:
        config["architecture"]["measures"][1] = config["measures"][1] = "XYZ"

    rewrite(folder, name_xyz)
    with pytest.raises(InputError, match=r"^model\.json: measures: unknown measure 'XYZ'; "
                                         r"known: NVT, ") as raised:
        load_model(folder)
    assert "\n" not in str(raised.value)
    result = runner.invoke(main, ["predict", "-m", str(folder), str(sample_path("table"))])
    assert result.exit_code == 2 and result.stderr.count("\n") == 1
    assert "unknown measure 'XYZ'" in result.stderr


def test_a_checkpoint_whose_names_are_not_its_heads_is_refused(tmp_path):
    folder = saved(tmp_path, MEASURED)
    rewrite(folder, lambda config: config.update(measures=["VE", "SL", "NVT"]))
    with pytest.raises(InputError, match=r"^model\.json: measures: the measure order VE, SL, "
                                         r"NVT is not that of the architecture's heads "
                                         r"\(VE, NVT, SL\)$"):
        load_model(folder)


def test_an_architecture_that_counts_its_heads_is_refused_in_one_line(tmp_path):
    # the heads are named (architecture.measures); a bare count is no key of ModelConfig
    folder = saved(tmp_path, PAPER_MEASURES)

    def counted(config: dict[str, Any]) -> None:
        del config["architecture"]["measures"]
        config["architecture"]["n_measures"] = 4

    rewrite(folder, counted)
    with pytest.raises(InputError, match=r"n_measures") as raised:
        load_model(folder)
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize("bundled", ["default", "points"])
def test_the_bundled_networks_keep_the_papers_four(bundled):
    model, config = load_model(bundled)
    assert model.measures == PAPER_MEASURES == MeshPredictor(bundled).measures
    predictions = predict(bundled, [sample_path("table")], device="cpu")
    assert predictions.measures == PAPER_MEASURES and predictions.directions.shape == (1, 4, 3)
    assert config["architecture"]["measures"] == list(PAPER_MEASURES)


def test_per_category_networks_must_predict_the_same_measures(tmp_path):
    saved(tmp_path, MEASURED, name="bottle")
    saved(tmp_path, ("VE", "SL"), name="mug")
    (tmp_path / "categories.json").write_text(json.dumps(
        {"format": CATEGORY_MODELS_FORMAT, "categories": {"bottle": "bottle", "mug": "mug"}}))
    with pytest.raises(InputError, match=r"categories\.json: its networks predict different "
                                         r"measures \(bottle: VE, NVT, SL; mug: VE, SL\)$"):
        predict(tmp_path, [sample_path("table")], category="mug", device="cpu")


# ---------------------------------------------------------------- the prior of a search


def test_a_prior_proposes_only_for_the_measures_searched(tmp_path):
    from vptoolkit.best_view.search import SearchSettings, search_best_views
    from vptoolkit.io import load_mesh

    folder = saved(tmp_path, MEASURED)
    mesh = load_mesh(sample_path("mug"))
    every = NetworkPrior(folder, min_angle_deg=0.0)(mesh)  # (frames x measures, 3), frame-major
    silhouette = NetworkPrior(folder, min_angle_deg=0.0, measures=("SL", "VMI"))
    assert silhouette.heads == ("SL",)
    assert np.array_equal(silhouette(mesh), every.reshape(-1, len(MEASURED), 3)[:, 2])

    none = NetworkPrior(folder, measures="VMI,VKL")
    assert none.heads == () and none(mesh).shape == (0, 3)
    found = search_best_views(mesh, SearchSettings(budget=16, resolution=32), prior=none(mesh))
    assert "prior" not in [stage.name for stage in found.stages]
    with pytest.raises(InputError, match="unknown measure 'XYZ'"):
        NetworkPrior(folder, measures=("XYZ",))
