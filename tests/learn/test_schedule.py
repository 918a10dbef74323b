"""The paper's learning-rate schedule, scaled to a run."""

from __future__ import annotations

import pytest

from fixtures.environment import require_package

require_package("torch")
require_package("safetensors")
require_package("zarr")

from vptoolkit.learn.schedule import (  # noqa: E402
    PAPER_BATCH_SIZE,
    PAPER_EPOCHS,
    learning_rate,
    scaled_lr_step,
)

pytestmark = pytest.mark.usefixtures("one_thread")


def test_learning_rate_follows_the_papers_step_decay():
    assert learning_rate(0) == 1e-3 and learning_rate(199) == 1e-3
    assert learning_rate(200) == pytest.approx(7.5e-4)
    assert learning_rate(2999) == pytest.approx(1e-3 * 0.75**14)
    assert (PAPER_EPOCHS, PAPER_BATCH_SIZE) == (3000, 8)


def test_paper_schedule_scales_to_the_run_length():
    assert scaled_lr_step(3000) == 200 and scaled_lr_step(100) == 7 and scaled_lr_step(5) == 1
    run = learning_rate(99, lr_step=scaled_lr_step(100))
    assert run == pytest.approx(1e-3 * 0.75**14)  # 15 steps, as in the paper's 3000 epochs
