"""The paper's optimisation settings and its learning-rate schedule.

Schelling et al. 2021, section 4.3: Adam, batch size 8, learning rate 0.001
multiplied by 0.75 every 200 of 3000 epochs. A run of another length keeps
the 15 decays: :func:`scaled_lr_step` scales the step with the run.
"""

from __future__ import annotations

from typing import Final

__all__ = [
    "PAPER_EPOCHS",
    "PAPER_BATCH_SIZE",
    "PAPER_LR",
    "PAPER_LR_DECAY",
    "PAPER_LR_STEP",
    "learning_rate",
    "scaled_lr_step",
]

PAPER_EPOCHS: Final = 3000
"""Epochs of the paper's runs (ML+GL switches at 1500)."""

PAPER_BATCH_SIZE: Final = 8
"""The paper's batch size."""

PAPER_LR: Final = 1e-3
"""The paper's initial learning rate (Adam)."""

PAPER_LR_DECAY: Final = 0.75
"""The paper's learning-rate factor per step."""

PAPER_LR_STEP: Final = 200
"""The paper's step: the learning rate decays every 200 epochs."""


def learning_rate(epoch: int, *, lr: float = PAPER_LR, lr_decay: float = PAPER_LR_DECAY,
                  lr_step: int = PAPER_LR_STEP) -> float:
    """Step decay: ``lr * lr_decay ** (epoch // lr_step)`` for a zero-based epoch."""
    return lr * lr_decay ** (epoch // lr_step)


def scaled_lr_step(epochs: int) -> int:
    """The paper's decay step (200 of 3000 epochs) scaled to a run of ``epochs``: at least 1."""
    return max(1, round(epochs * PAPER_LR_STEP / PAPER_EPOCHS))
