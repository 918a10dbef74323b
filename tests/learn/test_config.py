"""ModelConfig: the architecture as data, its round trip and checks."""

from __future__ import annotations

import json

import pytest

from fixtures.environment import require_package
from fixtures.networks import TINY_CONFIG

require_package("torch")
require_package("safetensors")

import torch  # noqa: E402

from vptoolkit.errors import InputError  # noqa: E402
from vptoolkit.learn import model as M  # noqa: E402
from vptoolkit.learn.config import LevelConfig, ModelConfig  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_thread")


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
