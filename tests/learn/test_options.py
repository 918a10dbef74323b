"""TrainOptions: a training run's definition, checked when made and compared on resume."""

from __future__ import annotations

import dataclasses
import json

import pytest

from fixtures.environment import require_package
from fixtures.networks import TINY_CONFIG

require_package("torch")
require_package("safetensors")
require_package("zarr")

from vptoolkit.errors import InputError  # noqa: E402
from vptoolkit.learn.config import ModelConfig  # noqa: E402
from vptoolkit.learn.options import TrainOptions  # noqa: E402
from vptoolkit.learn.schedule import (  # noqa: E402
    PAPER_BATCH_SIZE,
    PAPER_EPOCHS,
    scaled_lr_step,
)

pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.mark.parametrize(("changes", "message"), [
    ({"labels": "best"}, "labels: unknown label method"),
    ({"batch_size": 1}, "batch_size: must be at least 2"),
    ({"epochs": 0}, "epochs: must be at least 1"),
    ({"lr": float("nan")}, "lr: expected a positive finite number"),
    ({"lr_decay": 0}, "lr_decay: expected a positive finite number"),
    ({"lr_step": 0}, "lr_step: must be at least 1"),
    ({"seed": -1}, "seed: must be at least 0"),
    ({"val_split": "holdout"}, "val_split: unknown split 'holdout'"),
    ({"max_models": 0}, "max_models: must be at least 1"),
    ({"categories": []}, "categories: none given"),
    ({"categories": [1]}, "categories: expected category names"),
    ({"n_fps": 5000}, "n_fps: 5000 exceeds n_points=4096"),
    ({"rotate": "yes"}, "rotate: expected True or False"),
    ({"fps_pool": -1}, "fps_pool: must be at least 0"),
    ({"val_rotations": 1.5}, "val_rotations: expected an integer"),
    ({"labels": "sr", "architecture": TINY_CONFIG},
     "architecture: head 'direction' does not fit labels 'sr'"),
    ({"architecture": "big"}, "architecture: expected a ModelConfig or a mapping"),
])
def test_training_options_are_checked_when_made(changes, message):
    with pytest.raises(InputError, match=message):
        TrainOptions(**changes)


def test_training_options_keep_their_checked_values_and_read_back():
    options = TrainOptions(labels="SR", epochs=300, val_split="val",
                           categories=("mug", "cup", "mug"), architecture={"head_channels": [32]})
    assert options.labels == "sr" and options.val_split == "validation"
    assert options.categories == ("cup", "mug")
    assert options.lr_step == options.decay_step == scaled_lr_step(300) == 20
    assert options.architecture == ModelConfig(head="sr", head_channels=(32,),
                                               point_features=("face_area",))
    recorded = json.loads(json.dumps(options.to_dict()))
    assert TrainOptions.from_dict(recorded) == options
    assert TrainOptions() == TrainOptions(labels="ml+gl", epochs=PAPER_EPOCHS,
                                          batch_size=PAPER_BATCH_SIZE)
    with pytest.raises(InputError, match=r"^training options: unknown device$"):
        TrainOptions.from_dict({**recorded, "device": "cpu"})
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.seed = 1  # type: ignore[misc]


def test_resuming_may_only_grow_the_epochs():
    options = TrainOptions(epochs=100, lr_step=10)
    assert options.resume_conflicts(dataclasses.replace(options, epochs=50)) == {}
    assert options.resume_conflicts(dataclasses.replace(options, seed=3, rotate=False)) == {
        "seed": (3, 0), "rotate": (False, True)}
    # the paper's step for 3000 epochs
    longer = dataclasses.replace(options, epochs=3000, lr_step=None)
    assert longer.resume_conflicts(options) == {"lr_step": (10, 200)}
    wider = dataclasses.replace(options, architecture={"head_channels": [32]})
    assert wider.resume_conflicts(options) == {
        "architecture.head_channels": ([256, 64], [32])}


def test_a_default_step_may_grow_with_the_epochs_of_a_resumed_run():
    short, long = TrainOptions(epochs=30), TrainOptions(epochs=60)
    assert (short.lr_step, long.lr_step) == (scaled_lr_step(30), scaled_lr_step(60)) == (2, 4)
    assert long.resume_conflicts(short) == {}
    assert TrainOptions(epochs=60, lr_step=3).resume_conflicts(short) == {"lr_step": (2, 3)}
    assert long.resume_conflicts(TrainOptions(epochs=30, lr_step=3)) == {"lr_step": (3, 4)}
