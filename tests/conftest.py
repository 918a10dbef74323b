"""Shared fixtures and helpers: small closed-form meshes, the bundled samples, pictures."""

from __future__ import annotations

import os
import socket
import struct
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from vptoolkit.mesh import Mesh

REQUIRE_ALL = os.environ.get("VPTOOLKIT_REQUIRE_ALL") == "1"

DASK_DASHBOARD = "127.0.0.1:0"
"""``dashboard_address`` of every test's LocalCluster: any free port, since ``None`` still
binds distributed's HTTP server to 8787 and fails when another cluster holds it."""


@pytest.fixture()
def taken_dashboard_port() -> Iterator[None]:
    """Hold port 8787, Dask's default dashboard port, during the test, as another cluster would."""
    with socket.socket() as holder:
        try:
            holder.bind(("127.0.0.1", 8787))
            holder.listen()
        except OSError:  # someone else holds it already, which serves as well
            pass
        yield


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


def primitive_mesh(kind: str, options: dict[str, Any], name: str) -> Mesh:
    import trimesh

    made = getattr(trimesh.creation, kind)(**options)
    return Mesh(made.vertices, made.faces, name)


# Pixels darker than this in their darkest channel are model, not (white)
# background; the anti-aliased rim is lighter.
MODEL_LEVEL = 215


def decode_png(data: bytes) -> np.ndarray:
    """A minimal PNG reader for 8-bit images with filter 0 rows (what png_bytes writes)."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    offset, chunks = 8, {}
    while offset < len(data):
        (length,) = struct.unpack(">I", data[offset:offset + 4])
        tag = data[offset + 4:offset + 8]
        body = data[offset + 8:offset + 8 + length]
        (crc,) = struct.unpack(">I", data[offset + 8 + length:offset + 12 + length])
        assert crc == zlib.crc32(tag + body) & 0xFFFFFFFF
        chunks[tag] = chunks.get(tag, b"") + body
        offset += 12 + length
    width, height, depth, color_type = struct.unpack(">IIBB", chunks[b"IHDR"][:10])
    channels = {0: 1, 2: 3, 6: 4}[color_type]
    assert depth == 8
    rows = np.frombuffer(zlib.decompress(chunks[b"IDAT"]), np.uint8).reshape(height, -1)
    assert (rows[:, 0] == 0).all()
    return rows[:, 1:].reshape(height, width, channels)


def model_mask(image: np.ndarray) -> np.ndarray:
    return image.min(axis=2) < MODEL_LEVEL


def started_renderer(size: int, **options: Any) -> Iterator[Any]:
    """Body of a renderer fixture: a started Renderer, skipped (or failed in CI) without one."""
    require_package("open3d")
    from vptoolkit.errors import MissingDependencyError
    from vptoolkit.pictures.open3d_engine import Renderer

    shared = Renderer(size=size, **options)
    try:
        shared.start()
    except MissingDependencyError as err:
        if REQUIRE_ALL:
            pytest.fail(f"renderer required (VPTOOLKIT_REQUIRE_ALL=1): {err}")
        pytest.skip(str(err))
    yield shared
    shared.close()


def read_png(path: Path | str) -> np.ndarray:
    """Pixels of any PNG (matplotlib's, Chromium's) through Pillow, which matplotlib requires."""
    require_package("PIL")
    from PIL import Image

    with Image.open(path) as image:
        return np.asarray(image)


def one_torch_thread() -> Iterator[None]:
    """Body of a fixture running torch on one thread (on a busy 2-core machine two threads
    wait on each other), restoring the count afterwards."""
    import torch

    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)
