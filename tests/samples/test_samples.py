"""The bundled sample meshes: their names, documented face counts, paths and licence table."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.samples import sample_names, sample_path

# faces after loading, as listed in vptoolkit/samples/README.md
SAMPLE_FACES = {
    "Duck.glb": 4212,
    "angle_block.STL": 704,
    "ballA.off": 3796,
    "bottle.obj": 132,
    "bunny.ply": 16301,
    "featuretype.STL": 3476,
    "lego.obj": 2463,
    "mug.obj": 864,
    "suzanne.ply": 968,
    "table.obj": 12,
    "teapot.stl": 894,
    "torus.STL": 8700,
}


def test_sample_names_lists_the_shipped_meshes() -> None:
    assert sample_names() == sorted(SAMPLE_FACES)


@pytest.mark.parametrize("name", sorted(SAMPLE_FACES))
def test_sample_loads_with_documented_face_count(name: str) -> None:
    mesh = load_mesh(sample_path(name))
    assert mesh.name == Path(name).stem
    assert mesh.n_faces == SAMPLE_FACES[name]
    assert mesh.vertices.dtype == np.float64 and mesh.vertices.shape == (mesh.n_vertices, 3)
    assert mesh.faces.dtype == np.int64 and mesh.faces.shape == (mesh.n_faces, 3)
    assert np.isfinite(mesh.vertices).all()
    assert 0 <= mesh.faces.min() and mesh.faces.max() < mesh.n_vertices
    assert np.ptp(mesh.vertices, axis=0).min() > 0  # a 3D object, not a flat one


def test_sample_path_accepts_stem_and_rejects_unknown_names() -> None:
    assert sample_path("bunny") == sample_path("bunny.ply")
    assert sample_path("bunny.ply").is_file()
    message = r"^dragon\.ply: no such sample mesh; available: .*bunny\.ply"
    with pytest.raises(InputError, match=message):
        sample_path("dragon.ply")
    with pytest.raises(InputError):
        sample_path("../io.py")


def test_the_sample_licence_table_covers_every_sample_mesh() -> None:
    from vptoolkit.dataset.release.licenses import read_licenses
    from vptoolkit.samples import sample_names, sample_path

    table = read_licenses(sample_path("bunny.ply").parent / "LICENSES.csv")
    assert sorted(table) == sorted(Path(name).stem for name in sample_names())
    assert {row["license"] for row in table.values()} == {"mit", "zlib"}
