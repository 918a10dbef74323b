"""Tests of vptoolkit.clean: repair, hidden-face removal, decimation and the report."""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import pytest
import trimesh

from vptoolkit.errors import InputError, MeasurementError, VptoolkitError
from vptoolkit.geometry import face_areas
from vptoolkit.mesh import Mesh

pytest.importorskip("pymeshlab")

from vptoolkit.clean import CleaningReport, clean_mesh  # noqa: E402  (after the skip)
from vptoolkit.clean.hidden import (  # noqa: E402
    hidden_faces,
    remove_hidden_faces,
    two_sided_pixel_totals,
)
from vptoolkit.clean.repair import count_self_intersections, repair_mesh  # noqa: E402
from vptoolkit.clean.simplify import simplify_mesh  # noqa: E402
from vptoolkit.settings import MeasureSettings

# Few views keep the visibility passes fast; 200 Fibonacci views at 128 px
# still see every face of the convex test shapes.
FAST = {"settings": MeasureSettings(views=200, resolution=128)}


# ---------------------------------------------------------------- meshes


def _mesh(parts: list[trimesh.Trimesh], name: str) -> Mesh:
    vertices = np.vstack([part.vertices for part in parts])
    offsets = np.cumsum([0] + [len(part.vertices) for part in parts[:-1]])
    faces = np.vstack([part.faces + offset for part, offset in zip(parts, offsets)])
    return Mesh(vertices, faces, name=name)


def _edge_face_counts(faces: np.ndarray) -> np.ndarray:
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    return np.unique(edges, axis=0, return_counts=True)[1]


def _is_closed_and_oriented(faces: np.ndarray) -> bool:
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    forward = {tuple(edge) for edge in directed.tolist()}
    return len(forward) == len(directed) and all((b, a) in forward for a, b in forward)


def _signed_volume(mesh: Mesh) -> float:
    corners = mesh.vertices[mesh.faces]
    return float(np.einsum("ij,ij->", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])) / 6.0)


@dataclass(frozen=True)
class Planted:
    """A mesh with planted defects and where each defect sits."""

    mesh: Mesh
    big_centre: np.ndarray
    big_radius: float
    small_centre: np.ndarray
    small_radius: float
    inner_centre: np.ndarray
    inner_radius: float
    fin_tip: np.ndarray


@pytest.fixture(scope="module")
def planted() -> Planted:
    """Two overlapping spheres, a sphere hidden inside, a fin, as an unmerged triangle soup.

    The fin is a triangle on an edge of the big sphere (that edge then has
    three faces) sticking out by 0.3, so it is larger than the sphere's
    faces: the repair must still drop the fin, not a face of the sphere.
    """
    big = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    small = trimesh.creation.icosphere(subdivisions=3, radius=0.7)
    small.apply_translation([1.2, 0.0, 0.0])
    inner = trimesh.creation.icosphere(subdivisions=2, radius=0.3)
    inner.apply_translation([-0.4, 0.0, 0.0])
    edge = big.faces[0][:2]
    middle = big.vertices[edge].mean(axis=0)
    tip = middle + 0.3 * middle / np.linalg.norm(middle)
    fin = trimesh.Trimesh(
        np.vstack([big.vertices[edge], tip]), np.array([[0, 1, 2]]), process=False
    )
    welded = _mesh([big, small, inner, fin], "planted")
    soup_vertices = welded.vertices[welded.faces.ravel()]  # every corner its own vertex
    soup = Mesh(soup_vertices, np.arange(len(soup_vertices)).reshape(-1, 3), name="planted")
    return Planted(
        mesh=soup,
        big_centre=np.zeros(3),
        big_radius=1.0,
        small_centre=np.array([1.2, 0.0, 0.0]),
        small_radius=0.7,
        inner_centre=np.array([-0.4, 0.0, 0.0]),
        inner_radius=0.3,
        fin_tip=tip,
    )


@pytest.fixture(scope="module")
def cleaned_planted(planted: Planted) -> dict[str, tuple[Mesh, CleaningReport]]:
    return {
        method: clean_mesh(planted.mesh, max_faces=100_000, self_intersections=method, **FAST)
        for method in ("auto", "remove")
    }


@pytest.fixture(scope="module")
def shell_in_box() -> tuple[Mesh, int]:
    """A closed box with a closed sphere floating inside; the mesh and the box's face count."""
    box = trimesh.creation.box(extents=[2.0, 1.5, 1.0])
    inner = trimesh.creation.icosphere(subdivisions=2, radius=0.3)
    return _mesh([box, inner], "shell_in_box"), len(box.faces)


@pytest.fixture(scope="module")
def fine_sphere() -> Mesh:
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=1.0)  # 20480 faces
    return Mesh(sphere.vertices, sphere.faces, name="fine_sphere")


# ---------------------------------------------------------------- step 1 and planted defects


@pytest.mark.parametrize("method", ["auto", "remove"])
def test_planted_defects_are_gone(
    planted: Planted, cleaned_planted: dict[str, tuple[Mesh, CleaningReport]], method: str
) -> None:
    cleaned, report = cleaned_planted[method]
    vertices = cleaned.vertices
    # Duplicated vertices: merged, no two vertices share a position.
    assert len(np.unique(vertices, axis=0)) == cleaned.n_vertices
    assert cleaned.n_vertices < planted.mesh.n_vertices / 4
    # Non-manifold fin: no edge has more than two faces and the fin tip is gone.
    assert _edge_face_counts(cleaned.faces).max() <= 2
    assert np.linalg.norm(vertices - planted.fin_tip, axis=1).min() > 0.1
    # Hidden inner part: nothing left near the inner sphere.
    to_inner = np.linalg.norm(vertices - planted.inner_centre, axis=1)
    assert to_inner.min() > planted.inner_radius + 0.05
    # Overlapping parts: no self-intersection, and nothing of one sphere left
    # inside the other. (With "remove", a hole-filling cap may remain inside
    # the other sphere where the seam between them lets it be seen.)
    assert report.self_intersections_before > 0
    assert report.self_intersections_after_repair == 0
    assert count_self_intersections(cleaned) == 0
    centroids = vertices[cleaned.faces].mean(axis=1)
    is_buried = (
        np.linalg.norm(centroids - planted.big_centre, axis=1) < planted.big_radius - 0.02
    ) | (np.linalg.norm(centroids - planted.small_centre, axis=1) < planted.small_radius - 0.02)
    areas = face_areas(cleaned)
    if method == "auto":
        assert not is_buried.any()
    else:
        assert areas[is_buried].sum() < 0.02 * areas.sum()
    assert report.hidden_area_removed > 0.0


def test_auto_repair_gives_the_exact_closed_union(
    planted: Planted, cleaned_planted: dict[str, tuple[Mesh, CleaningReport]]
) -> None:
    cleaned, report = cleaned_planted["auto"]
    assert report.self_intersection_method == "union"
    assert _is_closed_and_oriented(cleaned.faces)
    assert _signed_volume(cleaned) > 0
    # Every vertex lies on one of the two spheres (icosphere vertices or cuts
    # of their faces, so within the flat-facet sagitta of the surface).
    on_big = np.abs(np.linalg.norm(cleaned.vertices - planted.big_centre, axis=1) - 1.0) < 0.02
    on_small = np.abs(np.linalg.norm(cleaned.vertices - planted.small_centre, axis=1) - 0.7) < 0.02
    assert (on_big | on_small).all()
    assert on_big.sum() > 100 and on_small.sum() > 50


def test_repair_merges_a_triangle_soup() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=2)
    corners = sphere.vertices[sphere.faces.ravel()]
    soup = Mesh(corners, np.arange(len(corners)).reshape(-1, 3), name="soup")
    repaired = repair_mesh(soup)
    assert repaired.n_vertices == len(sphere.vertices)
    assert repaired.n_faces == len(sphere.faces)
    assert _is_closed_and_oriented(repaired.faces)


def test_repair_drops_the_fin_not_the_body() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=2)
    edge = sphere.faces[5][:2]
    middle = sphere.vertices[edge].mean(axis=0)
    tip = middle + 0.5 * middle  # a fin much larger than any face of the sphere
    vertices = np.vstack([sphere.vertices, tip])
    faces = np.vstack([sphere.faces, [edge[1], edge[0], len(sphere.vertices)]])
    repaired = repair_mesh(Mesh(vertices, faces, name="fin"))
    assert repaired.n_faces == len(sphere.faces)
    assert _is_closed_and_oriented(repaired.faces)


def test_repair_removes_null_and_duplicate_faces() -> None:
    box = trimesh.creation.box()
    faces = np.vstack([box.faces, box.faces[:3], [[0, 0, 1], [2, 2, 2]]])
    repaired = repair_mesh(Mesh(box.vertices, faces, name="dups"))
    assert repaired.n_faces == len(box.faces)
    assert len(np.unique(np.sort(repaired.faces, axis=1), axis=0)) == repaired.n_faces


def test_repair_leaves_a_clean_mesh_alone() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=2)
    repaired = repair_mesh(Mesh(sphere.vertices, sphere.faces, name="clean"))
    assert repaired.n_faces == len(sphere.faces)
    assert repaired.n_vertices == len(sphere.vertices)
    assert count_self_intersections(repaired) == 0


def test_count_self_intersections(planted: Planted) -> None:
    one = trimesh.creation.icosphere(subdivisions=2)
    two = trimesh.creation.icosphere(subdivisions=2)
    two.apply_translation([1.0, 0.0, 0.0])
    assert count_self_intersections(_mesh([one], "one")) == 0
    assert count_self_intersections(_mesh([one, two], "two")) > 0


# ---------------------------------------------------------------- step 2


def test_faces_near_holds_every_face_whose_box_meets_a_target() -> None:
    from vptoolkit.clean.topology import faces_near

    rng = np.random.default_rng(0)
    # Mostly small triangles, some long ones (they span many grid cells).
    size = rng.choice([0.02, 0.5], size=(3000, 1, 1), p=[0.97, 0.03])
    corners = rng.random((3000, 1, 3)) + size * rng.random((3000, 3, 3))
    vertices = corners.reshape(-1, 3)
    faces = np.arange(len(vertices)).reshape(-1, 3)
    is_target = rng.random(len(faces)) < 0.02
    low, high = corners.min(axis=1) - 0.001, corners.max(axis=1) + 0.001
    expected = is_target.copy()
    for target in np.flatnonzero(is_target):
        expected |= np.all((low <= high[target]) & (high >= low[target]), axis=1)
    near = faces_near(vertices, faces, is_target, 0.001)
    assert near is not None and np.array_equal(near, expected)
    assert 0 < expected.sum() - is_target.sum() < len(faces) // 4


def test_retesting_near_changed_faces_gives_the_whole_test() -> None:
    """Moving a few vertices of two crossing spheres: the local retest equals a full test."""
    from vptoolkit.clean._meshlab import intersecting_faces_of
    from vptoolkit.clean.repair import _face_keys, _retest

    big = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    small = trimesh.creation.icosphere(subdivisions=3, radius=0.7)
    small.apply_translation([1.2, 0.0, 0.0])
    mesh = _mesh([big, small], "two")
    before = intersecting_faces_of(mesh.vertices, mesh.faces)
    assert 0 < before.sum() < mesh.n_faces
    cleared = _face_keys(mesh.vertices, mesh.faces[~before])
    assert cleared is not None
    top = int(np.argmax(big.vertices[:, 2]))  # pulled through the bottom: its fan crosses it
    rng = np.random.default_rng(1)
    for moved, shift, crossing in (([5, 17, 300], 0.2, False), ([top], -2.3, True), ([], 0, False)):
        vertices = mesh.vertices.copy()
        if shift < 0:
            vertices[moved, 2] += shift
        else:
            vertices[moved] += shift * rng.standard_normal((len(moved), 3))
        kept = ~before  # the faces the first test flagged are gone
        faces = mesh.faces[kept]
        used = np.unique(faces)
        remap = np.zeros(len(vertices), dtype=np.int64)
        remap[used] = np.arange(len(used))
        vertices, faces = vertices[used], remap[faces]
        retested = _retest(vertices, faces, cleared)
        assert retested is not None
        assert np.array_equal(retested, intersecting_faces_of(vertices, faces))
        if crossing:
            assert retested.any()
        if not moved:
            assert not retested.any()


def test_hidden_inner_shell_is_removed_exactly(shell_in_box: tuple[Mesh, int]) -> None:
    mesh, n_box_faces = shell_in_box
    is_hidden = hidden_faces(mesh, MeasureSettings(views=200, resolution=128))
    assert is_hidden.shape == (mesh.n_faces,) and is_hidden.dtype == np.bool_
    np.testing.assert_array_equal(is_hidden, np.arange(mesh.n_faces) >= n_box_faces)
    visible = remove_hidden_faces(mesh, MeasureSettings(views=200, resolution=128))
    np.testing.assert_array_equal(visible.vertices, mesh.vertices[:8])
    np.testing.assert_array_equal(visible.faces, mesh.faces[:n_box_faces])


def test_clean_mesh_loses_exactly_the_inner_shell(shell_in_box: tuple[Mesh, int]) -> None:
    mesh, n_box_faces = shell_in_box
    cleaned, report = clean_mesh(mesh, **FAST)
    assert cleaned.n_faces == n_box_faces
    np.testing.assert_allclose(
        np.sort(cleaned.vertices, axis=0), np.sort(mesh.vertices[:8], axis=0)
    )
    areas = face_areas(mesh)
    inner_area = float(areas[n_box_faces:].sum())
    assert report.hidden_area_removed == pytest.approx(inner_area)
    assert report.hidden_area_fraction == pytest.approx(inner_area / areas.sum())
    assert report.self_intersection_method == "none"
    assert report.faces_flipped == 0


def test_faces_seen_from_behind_are_turned_around() -> None:
    box = trimesh.creation.box()
    faces = box.faces.copy()
    faces[:5] = faces[:5, ::-1]  # five faces point inwards
    mesh = Mesh(box.vertices, faces, name="half_inverted")
    pixels = two_sided_pixel_totals(mesh, MeasureSettings(views=200, resolution=64))
    assert pixels.shape == (12, 2) and pixels.dtype == np.int64
    # Grazing rays along the box edges can catch a pixel or two of the wrong side.
    assert (pixels[:5, 1] > 10 * pixels[:5, 0]).all()
    assert (pixels[5:, 0] > 10 * pixels[5:, 1]).all()
    oriented = remove_hidden_faces(mesh, MeasureSettings(views=200, resolution=64))
    assert _is_closed_and_oriented(oriented.faces)
    assert _signed_volume(oriented) == pytest.approx(1.0)
    kept = remove_hidden_faces(mesh, MeasureSettings(views=200, resolution=64), orient=False)
    np.testing.assert_array_equal(kept.faces, faces)


def test_an_inside_out_mesh_is_turned_outward() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=2)
    inverted = Mesh(sphere.vertices, sphere.faces[:, ::-1], name="inside_out")
    cleaned, report = clean_mesh(inverted, **FAST)
    assert report.faces_flipped == len(sphere.faces)
    assert _signed_volume(cleaned) > 0


# ---------------------------------------------------------------- step 3


@pytest.mark.parametrize("max_faces", [200, 1000, 5000])
def test_decimation_respects_max_faces_and_the_shape(fine_sphere: Mesh, max_faces: int) -> None:
    simplified = simplify_mesh(fine_sphere, max_faces=max_faces)
    assert max_faces * 0.8 <= simplified.n_faces <= max_faces
    # A unit sphere in n flat faces deviates by about the sagitta 3.6 / n.
    radii = np.linalg.norm(simplified.vertices, axis=1)
    np.testing.assert_allclose(radii, 1.0, atol=8.0 / max_faces + 0.002)
    assert _is_closed_and_oriented(simplified.faces)


def test_decimation_keeps_the_outline_of_an_open_sheet() -> None:
    side = np.linspace(0.0, 1.0, 41)
    x, y = np.meshgrid(side, side)
    vertices = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    index = np.arange(x.size).reshape(41, 41)
    a, b, c, d = index[:-1, :-1], index[:-1, 1:], index[1:, 1:], index[1:, :-1]
    faces = np.concatenate(
        [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    )
    sheet = Mesh(vertices, faces, name="sheet")  # 3200 faces
    simplified = simplify_mesh(sheet, max_faces=300)
    assert simplified.n_faces <= 300
    np.testing.assert_allclose(simplified.vertices[:, 2], 0.0, atol=1e-12)
    np.testing.assert_allclose(simplified.vertices[:, :2].min(axis=0), [0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(simplified.vertices[:, :2].max(axis=0), [1.0, 1.0], atol=1e-9)
    assert face_areas(simplified).sum() == pytest.approx(1.0, abs=1e-6)


def _wound_triangles(mesh: Mesh) -> list[tuple[int, ...]]:
    """Each face as its vertex indices from the smallest on, in winding order, sorted."""
    starts = mesh.faces.argmin(axis=1)
    rows = np.arange(mesh.n_faces)
    rolled = np.stack([mesh.faces[rows, (starts + k) % 3] for k in range(3)], axis=1)
    return sorted(map(tuple, rolled.tolist()))


def test_simplify_keeps_the_faces_of_a_small_mesh() -> None:
    box = trimesh.creation.box()
    mesh = Mesh(box.vertices, box.faces, name="box")
    simplified = simplify_mesh(mesh, max_faces=100)
    np.testing.assert_array_equal(simplified.vertices, mesh.vertices)
    assert _wound_triangles(simplified) == _wound_triangles(mesh)
    assert simplified.intersections_after == 0


def test_remesh_keeps_the_budget(fine_sphere: Mesh) -> None:
    remeshed = simplify_mesh(fine_sphere, max_faces=2000, remesh=True)
    assert remeshed.n_faces <= 2000
    np.testing.assert_allclose(np.linalg.norm(remeshed.vertices, axis=1), 1.0, atol=0.02)
    corners = remeshed.vertices[remeshed.faces]
    lengths = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)
    assert lengths.std() / lengths.mean() < 0.3  # nearly equal edges


def test_clean_mesh_decimates_to_max_faces(fine_sphere: Mesh) -> None:
    cleaned, report = clean_mesh(fine_sphere, max_faces=500, **FAST)
    assert cleaned.n_faces <= 500
    assert report.step("simplify").faces_before == fine_sphere.n_faces
    assert report.step("simplify").faces_after == cleaned.n_faces


@pytest.mark.parametrize("method", ["auto", "remove"])
def test_the_three_steps_in_order_give_the_cleaned_mesh(planted: Planted, method: str) -> None:
    # "remove" opens seams, which the repaired mesh carries into step 2; 600
    # faces make step 3 decimate and remove the intersections that creates.
    cleaned, report = clean_mesh(planted.mesh, max_faces=600, self_intersections=method, **FAST)
    repaired = repair_mesh(planted.mesh, self_intersections=method)
    visible = remove_hidden_faces(repaired, FAST["settings"])
    simplified = simplify_mesh(visible, max_faces=600)
    np.testing.assert_array_equal(simplified.vertices, cleaned.vertices)
    np.testing.assert_array_equal(simplified.faces, cleaned.faces)
    assert repaired.method == report.self_intersection_method
    assert (visible.hidden_area, visible.faces_flipped) == (report.hidden_area_removed,
                                                            report.faces_flipped)
    assert simplified.intersections_after == report.self_intersections_after


# ---------------------------------------------------------------- the report


def test_report_records_every_step(cleaned_planted: dict[str, tuple[Mesh, CleaningReport]]) -> None:
    cleaned, report = cleaned_planted["auto"]
    record = report.to_dict()
    assert json.loads(json.dumps(record)) == record
    assert [step["name"] for step in record["steps"]] == ["repair", "remove_hidden", "simplify"]
    for before, after in zip(report.steps, report.steps[1:]):
        assert before.faces_after == after.faces_before
        assert before.vertices_after == after.vertices_before
    assert record["faces_before"] == 2 * 1280 + 320 + 1
    assert record["faces_after"] == cleaned.n_faces
    assert all(step["seconds"] >= 0.0 for step in record["steps"])
    assert record["seconds"] == pytest.approx(sum(step["seconds"] for step in record["steps"]))
    for key in (
        "self_intersections_before",
        "self_intersections_after_repair",
        "self_intersections_after",
        "hidden_area_removed",
        "hidden_area_fraction",
        "faces_flipped",
    ):
        assert key in record
    assert 0.0 < record["hidden_area_fraction"] < 1.0
    with pytest.raises(InputError, match="no cleaning step 'smooth'"):
        report.step("smooth")


def test_clean_mesh_is_quiet(
    shell_in_box: tuple[Mesh, int], capfd: pytest.CaptureFixture[str]
) -> None:
    clean_mesh(shell_in_box[0], **FAST)
    captured = capfd.readouterr()
    assert captured.out == ""
    assert captured.err == ""


# ---------------------------------------------------------------- errors


def test_a_mesh_of_null_faces_raises_with_its_name() -> None:
    flat = Mesh(
        np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], dtype=np.float64),
        np.array([[0, 1, 2], [1, 2, 3]]),
        name="chair_0001",
    )
    message = r"^chair_0001: cleaning step 'repair' left no faces"
    with pytest.raises(MeasurementError, match=message):
        clean_mesh(flat, **FAST)
    assert issubclass(MeasurementError, VptoolkitError)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"max_faces": 3}, "max_faces: must be at least 4"),
        ({"max_faces": 10.5}, "max_faces: expected an integer"),
        ({"self_intersections": "union"}, "self_intersections: expected 'auto' or 'remove'"),
        ({"max_rounds": -1}, "max_rounds: must be at least 0"),
        ({"settings": MeasureSettings(resolution=4)},
         "settings: resolution must be at least 8 for the hidden-face test, got 4"),
        ({"remesh": "yes"}, "remesh: expected True or False"),
    ],
    ids=[
        "few-faces", "float-faces", "bad-method", "negative-rounds", "tiny-resolution", "bad-remesh"
    ],
)
def test_clean_mesh_rejects_bad_options(
    shell_in_box: tuple[Mesh, int], kwargs: dict, message: str
) -> None:
    with pytest.raises(InputError, match=message):
        clean_mesh(shell_in_box[0], **kwargs)


def test_clean_mesh_rejects_a_non_mesh() -> None:
    with pytest.raises(InputError, match=r"^mesh: expected a vptoolkit Mesh, .*, got ndarray$"):
        clean_mesh(np.zeros((4, 3)))  # type: ignore[arg-type]


# ---------------------------------------------------------------- measures


@pytest.mark.slow
def test_measures_of_a_cleaned_real_mesh_stay_close() -> None:
    from vptoolkit.io import load_mesh
    from vptoolkit.measures.quality import compute_view_quality
    from vptoolkit.samples import sample_path

    bunny = load_mesh(sample_path("bunny"))
    cleaned, _ = clean_mesh(bunny, max_faces=5000)
    assert cleaned.n_faces <= 5000
    original = compute_view_quality(bunny, MeasureSettings(resolution=256))
    after = compute_view_quality(cleaned, MeasureSettings(resolution=256))
    best_before = original.views[original.best_index]
    best_after = after.views[after.best_index]
    angles = np.degrees(np.arccos(np.clip(np.sum(best_before * best_after, axis=1), -1.0, 1.0)))
    # VR and VMI (columns 1 and 3): within about one view spacing (6.5 degrees).
    assert angles[1] < 8.0 and angles[3] < 8.0
    # And the cleaned mesh's best views are near-best views of the original.
    quality_there = original.normalized[after.best_index, np.arange(4)]
    assert quality_there[1] > 0.95 and quality_there[3] > 0.95
