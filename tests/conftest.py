"""The test suite's plugins and its one option.

The shared builders live in ``tests/fixtures/``, one module per kind of input, loaded
here as plugins so every test takes their fixtures by name; tests import the helper
functions from those modules, never from another test module.

Tests marked ``slow`` (more than a few seconds each) or ``renderer`` (Open3D's Filament
child drawing on software Vulkan: seconds a frame) run only with ``--run-slow``, when
``-m`` picks markers explicitly or when a test is named by its id (``file.py::test``):
``python -m pytest`` is the quick run while developing, ``python -m pytest --run-slow``
(what CI runs) the whole suite.
"""

from __future__ import annotations

import pytest

pytest.register_assert_rewrite("fixtures")  # their asserts explain failures, as in tests

SLOW_MARKERS = ("slow", "renderer")
"""Markers of the tests that a run without ``--run-slow`` leaves out."""

pytest_plugins = [
    "fixtures.browser",
    "fixtures.builds",
    "fixtures.commands",
    "fixtures.environment",
    "fixtures.meshes",
    "fixtures.networks",
    "fixtures.pictures",
    "fixtures.releases",
    "fixtures.scripts",
    "fixtures.stores",
]


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--run-slow", action="store_true",
                     help="also run the tests marked slow or renderer (the whole suite, as in CI)")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Deselect the slow tests unless ``--run-slow``, ``-m`` or a test id asks for them."""
    if (config.getoption("--run-slow") or config.getoption("markexpr")
            or any("::" in argument for argument in config.args)):
        return
    quick, slow = [], []
    for item in items:
        is_slow = any(item.get_closest_marker(name) for name in SLOW_MARKERS)
        (slow if is_slow else quick).append(item)
    if slow:
        config.hook.pytest_deselected(items=slow)
        items[:] = quick
