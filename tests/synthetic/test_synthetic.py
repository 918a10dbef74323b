"""Procedural category shapes: closed outward meshes, deterministic, symmetric, category-like."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.mesh import Mesh
from vptoolkit.synthetic import (
    CATEGORIES,
    MAX_FACES,
    MIRROR_SYMMETRIC,
    make_shape,
    write_collection,
)

SEEDS = (0, 1, 2, 3)
PAPER_CATEGORIES = ("airplane", "bench", "bottle", "car", "chair", "sofa", "table", "toilet")


def extents(mesh: Mesh) -> np.ndarray:
    """(3,) float64: bounding-box size along x (front), y (left-right) and z (up)."""
    return np.ptp(mesh.vertices, axis=0)


def max_distance_to_set(points: np.ndarray, targets: np.ndarray) -> float:
    """Largest distance from a point of ``points`` (n, 3) to its nearest of ``targets`` (m, 3)."""
    nearest = [np.min(np.linalg.norm(targets[None] - chunk[:, None], axis=2), axis=1)
               for chunk in np.array_split(points, max(1, len(points) // 256))]
    return float(np.max(np.concatenate(nearest)))


def test_categories_are_the_papers_sorted():
    assert CATEGORIES == PAPER_CATEGORIES == tuple(sorted(CATEGORIES))


@pytest.mark.parametrize("seed", SEEDS, ids=[f"seed{s}" for s in SEEDS])
@pytest.mark.parametrize("category", CATEGORIES)
def test_shape_is_a_valid_closed_outward_mesh(category, seed):
    mesh = make_shape(category, seed=seed)
    assert isinstance(mesh, Mesh)
    assert mesh.name == f"{category}_{seed:04d}"
    assert mesh.vertices.dtype == np.float64 and mesh.vertices.shape[1] == 3
    assert mesh.faces.dtype == np.int64 and mesh.faces.shape[1] == 3
    assert 12 <= mesh.n_faces <= MAX_FACES
    assert np.isfinite(mesh.vertices).all()
    assert np.array_equal(np.unique(mesh.faces), np.arange(mesh.n_vertices)), "unused vertices"
    low, high = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    diagonal = float(np.linalg.norm(high - low))
    np.testing.assert_allclose((low + high) / 2, 0.0, atol=1e-12 * diagonal)  # centred

    corners = mesh.vertices[mesh.faces]
    areas = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                          corners[:, 2] - corners[:, 0]), axis=1)
    assert areas.min() > 1e-9 * diagonal**2, "degenerate face"

    whole = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    parts = whole.split(only_watertight=False)
    assert len(parts) >= 1
    for part in parts:
        assert part.is_watertight and part.is_winding_consistent
        assert part.volume > 0, "a part has inward faces"


@pytest.mark.parametrize("category", CATEGORIES)
def test_same_seed_gives_identical_arrays_and_other_seeds_other_proportions(category):
    first, again = make_shape(category, seed=11), make_shape(category, seed=11)
    np.testing.assert_array_equal(first.vertices, again.vertices)
    np.testing.assert_array_equal(first.faces, again.faces)
    others = [extents(make_shape(category, seed=seed)) for seed in (12, 13)]
    for other in others:
        assert not np.allclose(extents(first), other, rtol=1e-3)


def test_seed_is_mixed_with_the_category_and_the_name_can_be_set():
    chair = make_shape("chair", seed=5, name="my_chair")
    assert chair.name == "my_chair"
    np.testing.assert_array_equal(chair.vertices, make_shape("chair", seed=5).vertices)
    assert make_shape("chair", seed=np.int64(5)).name == "chair_0005"
    assert make_shape("table", seed=-3).n_faces > 0  # any int seeds, negative too


@pytest.mark.parametrize("seed", range(6), ids=[f"seed{s}" for s in range(6)])
@pytest.mark.parametrize("category", MIRROR_SYMMETRIC)
def test_mirror_symmetric_categories_map_onto_themselves_across_y0(category, seed):
    mesh = make_shape(category, seed=seed)
    mirrored = mesh.vertices * np.array([1.0, -1.0, 1.0])
    diagonal = float(np.linalg.norm(extents(mesh)))
    assert max_distance_to_set(mirrored, mesh.vertices) < 1e-9 * diagonal


@pytest.mark.parametrize("seed", range(4), ids=[f"seed{s}" for s in range(4)])
def test_bottle_body_is_rotationally_symmetric_about_z(seed):
    bottle = make_shape("bottle", seed=seed)
    parts = trimesh.Trimesh(bottle.vertices, bottle.faces,
                            process=False).split(only_watertight=False)
    body = max(parts, key=lambda part: len(part.faces)).vertices
    axis = (body.min(axis=0) + body.max(axis=0)) / 2
    quarter_turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    turned = (body - axis) @ quarter_turn.T + axis
    assert max_distance_to_set(turned, body) < 1e-9 * float(np.linalg.norm(np.ptp(body, axis=0)))


# Bounding-box proportions (x front, y left-right, z up) that tell the categories apart.
SILHOUETTES = {
    "airplane": lambda x, y, z: y > 2.0 * z and x > 2.0 * z and 0.7 * x < y < 1.5 * x,  # wide, flat
    "bench": lambda x, y, z: y > 1.3 * z and y > 2.0 * x,  # long and low
    "bottle": lambda x, y, z: z > 1.5 * max(x, y),  # tall and narrow
    "car": lambda x, y, z: x > 2.0 * z and x > 1.5 * y,  # long and low, along x
    "chair": lambda x, y, z: z > max(x, y),  # taller than wide
    "sofa": lambda x, y, z: y > 1.2 * z and y > 0.7 * x,  # wide
    "table": lambda x, y, z: x >= y and max(x, y) > 0.75 * z,  # top longest along x
    "toilet": lambda x, y, z: x > y and z > 0.6 * max(x, y),  # deeper than wide
}


@pytest.mark.parametrize("category", CATEGORIES)
def test_category_silhouettes_differ(category):
    for seed in range(8):
        x, y, z = extents(make_shape(category, seed=seed))
        assert SILHOUETTES[category](x, y, z), (
            f"{category}_{seed:04d} extents {x:.3f} {y:.3f} {z:.3f}")


def test_categories_are_recognised_from_bounding_box_proportions_alone():
    """Nearest-centroid on log aspect ratios, fitted on other seeds, mostly finds the category."""

    def aspects(mesh: Mesh) -> np.ndarray:
        x, y, z = extents(mesh)
        return np.log([x / z, y / z, y / x])

    centroids = np.array([np.mean([aspects(make_shape(category, seed=seed)) for seed in range(20)],
                                  axis=0) for category in CATEGORIES])
    n_correct = 0
    for index, category in enumerate(CATEGORIES):
        for seed in range(100, 115):
            distances = np.linalg.norm(centroids - aspects(make_shape(category, seed=seed)), axis=1)
            n_correct += int(np.argmin(distances) == index)
    assert n_correct / (15 * len(CATEGORIES)) > 0.75


def test_bottles_and_benches_are_told_apart_by_their_silhouettes():
    bottles = [extents(make_shape("bottle", seed=seed)) for seed in range(4)]
    benches = [extents(make_shape("bench", seed=seed)) for seed in range(4)]
    assert not any(SILHOUETTES["bench"](*e) for e in bottles)
    assert not any(SILHOUETTES["bottle"](*e) for e in benches)


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"category": "lamp", "seed": 0}, "category: unknown category 'lamp'"),
        ({"category": "chair", "seed": 1.5}, "seed: expected an int"),
        ({"category": "chair", "seed": True}, "seed: expected an int"),
    ],
    ids=["unknown-category", "float-seed", "bool-seed"],
)
def test_make_shape_rejects_bad_arguments(arguments, message):
    with pytest.raises(InputError, match=message):
        make_shape(arguments.pop("category"), **arguments)


def test_write_collection_writes_a_modelnet_tree(tmp_path):
    paths = write_collection(tmp_path, n_per_category=5, categories=["chair", "bottle"], seed=3)
    relative = [path.relative_to(tmp_path).as_posix() for path in paths]
    expected_splits = ["train"] * 4 + ["test"]
    assert relative == [f"{category}/{split}/{category}_{number:04d}.off"
                        for category in ("chair", "bottle")
                        for number, split in zip(range(1, 6), expected_splits)]
    assert (sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*.off"))
            == sorted(relative))
    mesh = load_mesh(paths[0])
    assert mesh.name == "chair_0001" and mesh.n_faces <= MAX_FACES


def test_write_collection_is_deterministic_and_stable_when_grown(tmp_path):
    first = write_collection(tmp_path / "a", n_per_category=3, categories=["car", "sofa"], seed=7)
    again = write_collection(tmp_path / "b", n_per_category=3, categories=["car", "sofa"], seed=7)
    assert [p.read_bytes() for p in first] == [p.read_bytes() for p in again]
    grown = write_collection(tmp_path / "c", n_per_category=10, categories=["car", "sofa"], seed=7,
                             test_fraction=0.0)
    grown_bytes = {p.name: p.read_bytes() for p in grown}
    assert all(grown_bytes[p.name] == p.read_bytes() for p in first)
    other = write_collection(tmp_path / "d", n_per_category=3, categories=["car", "sofa"], seed=8)
    assert [p.read_bytes() for p in other] != [p.read_bytes() for p in first]
    # Different models of one collection differ.
    assert len({p.read_bytes() for p in first}) == len(first)


def test_write_collection_flat_layout_and_other_formats(tmp_path):
    paths = write_collection(tmp_path, n_per_category=2, categories=["table"], layout="flat",
                             file_format=".ply")
    assert ([p.relative_to(tmp_path).as_posix() for p in paths]
            == ["table/table_0001.ply", "table/table_0002.ply"])
    assert load_mesh(paths[1]).name == "table_0002"


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"n_per_category": 0}, "n_per_category"),
        ({"n_per_category": 2, "categories": ["chair", "lamp"]}, "categories: unknown"),
        ({"n_per_category": 2, "categories": "chair"}, "categories: expected a sequence"),
        ({"n_per_category": 2, "categories": []}, "categories: expected distinct"),
        ({"n_per_category": 2, "categories": ["car", "car"]}, "categories: expected distinct"),
        ({"n_per_category": 2, "layout": "shapenet"}, "layout"),
        ({"n_per_category": 2, "test_fraction": 1.0}, "test_fraction"),
        ({"n_per_category": 2, "file_format": ".glb"}, "file_format"),
        ({"n_per_category": 2, "seed": "0"}, "seed"),
    ],
    ids=["zero-models", "unknown-category", "string-categories", "no-categories", "duplicate",
         "layout", "test-fraction", "format", "seed"],
)
def test_write_collection_rejects_bad_arguments(tmp_path, arguments, message):
    with pytest.raises(InputError, match=message):
        write_collection(tmp_path, **arguments)
    assert list(tmp_path.iterdir()) == []
