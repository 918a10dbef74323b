"""Shared fixtures: small closed-form meshes and the bundled samples."""

from __future__ import annotations

import os

import numpy as np
import pytest

from vptoolkit.mesh import Mesh

REQUIRE_ALL = os.environ.get("VPTOOLKIT_REQUIRE_ALL") == "1"


def require_package(module: str) -> None:
    """Skip the calling test when ``module`` is missing, or fail when CI requires everything."""
    from vptoolkit.optional import is_available

    if is_available(module):
        return
    if REQUIRE_ALL:
        pytest.fail(f"{module} is required (VPTOOLKIT_REQUIRE_ALL=1) but not installed")
    pytest.skip(f"{module} not installed")


def box_mesh(extents: tuple[float, float, float] = (1.0, 1.0, 1.0), name: str = "box") -> Mesh:
    """An axis-aligned box centred at the origin, outward counter-clockwise faces."""
    import trimesh

    box = trimesh.creation.box(extents=extents)
    return Mesh(box.vertices, box.faces, name)


@pytest.fixture(scope="session")
def cube() -> Mesh:
    return box_mesh()


@pytest.fixture(scope="session")
def triangle() -> Mesh:
    """One triangle in the z = 0 plane, its front facing +z."""
    return Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]), "triangle")


@pytest.fixture(scope="session")
def bunny() -> Mesh:
    from vptoolkit.io import load_mesh
    from vptoolkit.samples import sample_path

    return load_mesh(sample_path("bunny.ply"))
