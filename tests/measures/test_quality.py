import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.meshes import box_mesh
from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.geometry import face_areas
from vptoolkit.measures.quality import compute_view_quality, normalize_quality, ranked_views
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.measures.sums import quality_from_histograms
from vptoolkit.mesh import Mesh
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import angle_between_deg, fibonacci_sphere
from vptoolkit.visibility import face_pixel_counts, iter_view_histograms

CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) / np.sqrt(3)


def dense_measures(counts: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """The paper's equations 1-4 written out on a dense (views, faces) matrix."""
    a_t = counts.sum(axis=1, keepdims=True)
    p = counts / a_t
    q = areas / areas.sum()
    p_z = counts.sum(axis=0) / counts.sum()
    with np.errstate(divide="ignore", invalid="ignore"):
        plogp = np.where(counts > 0, p * np.log2(p), 0.0)
        ve = -plogp.sum(axis=1)
        vr = ((counts > 0) * q).sum(axis=1)
        vkl = np.where(counts > 0, p * np.log2(p / q), 0.0).sum(axis=1)
        vmi = np.where(counts > 0, p * np.log2(p / p_z), 0.0).sum(axis=1)
    return np.stack([ve, vr, vkl, vmi], axis=1)


def test_streaming_measures_equal_the_dense_formulas(bunny):
    views = fibonacci_sphere(40)
    counts = face_pixel_counts(bunny, MeasureSettings(resolution=128), view_directions=views)
    expected = dense_measures(counts, face_areas(bunny))
    quality = compute_view_quality(bunny, MeasureSettings(resolution=128), view_directions=views)
    np.testing.assert_allclose(quality.raw, expected, rtol=1e-10, atol=1e-12)


def test_vmi_second_pass_gives_the_same_result_when_histograms_do_not_fit(bunny):
    views = fibonacci_sphere(30)

    def runs():
        return iter_view_histograms(bunny, MeasureSettings(resolution=96), view_directions=views)

    areas = face_areas(bunny)
    kept = quality_from_histograms(runs(), areas, n_views=30)
    recomputed = quality_from_histograms(runs(), areas, n_views=30, recompute=runs(), store_bytes=0)
    np.testing.assert_array_equal(kept, recomputed)


def test_cube_visibility_ratio_spans_one_sixth_to_one_half(cube):
    quality = compute_view_quality(cube, MeasureSettings(views=1000, resolution=128))
    vr = quality.raw[:, PAPER_MEASURES.index("VR")]
    assert vr.min() == pytest.approx(1 / 6) and vr.max() == pytest.approx(1 / 2)
    on_axis = compute_view_quality(cube, MeasureSettings(resolution=64),
                                   view_directions=[[0, 0, 1], [0, -1, 0]])
    np.testing.assert_allclose(on_axis.raw[:, 1], 1 / 6)


@pytest.mark.parametrize("measure", ["VE", "VKL"])
def test_cube_entropy_and_kl_are_best_at_a_corner(cube, measure):
    quality = compute_view_quality(cube, MeasureSettings(views=1000, resolution=256))
    best = quality.best_views[PAPER_MEASURES.index(measure)]
    assert angle_between_deg(np.tile(best, (8, 1)), CORNERS).min() < 4.0
    worst = quality.views[quality.worst_index[PAPER_MEASURES.index(measure)]]
    assert np.abs(worst).max() > np.cos(np.radians(20))  # worst looks nearly straight at a side


def fan_box(extents: tuple[float, float, float]) -> Mesh:
    """A box whose every side is four triangles around its centre, so the
    triangulation is as mirror-symmetric as the solid."""
    half = np.asarray(extents) / 2
    vertices, faces = [], []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for sign in (-1.0, 1.0):
            centre = np.zeros(3)
            centre[axis] = sign * half[axis]
            corners = []
            for du, dv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                corner = centre.copy()
                corner[u], corner[v] = du * half[u], dv * half[v]
                corners.append(corner)
            base = len(vertices)
            vertices += [centre, *corners]
            for k in range(4):
                a, b = base + 1 + k, base + 1 + (k + 1) % 4
                # counter-clockwise seen from outside
                faces.append((base, a, b) if sign > 0 else (base, b, a))
    return Mesh(np.array(vertices), np.array(faces), "fan-box")


def test_fan_box_is_closed_and_outward():
    box = fan_box((1.0, 2.0, 3.0))
    corners = box.vertices[box.faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    assert (np.einsum("ij,ij->i", normals, corners.mean(axis=1)) > 0).all()
    assert face_areas(box).sum() == pytest.approx(2 * (2 + 3 + 6))


def test_symmetric_box_gives_mirror_symmetric_quality():
    box = fan_box((1.0, 1.6, 2.3))
    views = fibonacci_sphere(300)
    mirrored = views * [-1.0, 1.0, 1.0]
    a = compute_view_quality(box, MeasureSettings(resolution=256), view_directions=views).raw
    b = compute_view_quality(box, MeasureSettings(resolution=256), view_directions=mirrored).raw
    np.testing.assert_allclose(a, b, rtol=1e-3)
    np.testing.assert_array_equal(np.argmax(a, axis=0), np.argmax(b, axis=0))


def subdivide_faces(mesh: Mesh, selected: np.ndarray, levels: int) -> Mesh:
    """Split the selected triangles into 4 ** levels pieces each (midpoints)."""
    vertices = [tuple(v) for v in mesh.vertices]
    faces = [tuple(f) for f in mesh.faces[~selected]]
    pending = [tuple(f) for f in mesh.faces[selected]]
    for _ in range(levels):
        next_pending = []
        for a, b, c in pending:
            mids = []
            for i, j in ((a, b), (b, c), (c, a)):
                vertices.append(tuple((np.array(vertices[i]) + vertices[j]) / 2))
                mids.append(len(vertices) - 1)
            ab, bc, ca = mids
            next_pending += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
        pending = next_pending
    return Mesh(np.array(vertices), np.array(faces + pending), f"{mesh.name}-subdivided")


def test_subdividing_part_of_a_mesh_moves_ve_but_not_vr_or_vmi():
    # The paper's table 1: VE is sensitive to the discretisation, VR and VMI are not.
    box = box_mesh((1.0, 1.3, 1.7))
    centroids = box.vertices[box.faces].mean(axis=1)
    finer = subdivide_faces(box, centroids[:, 0] > 0.49, levels=4)
    before = compute_view_quality(box, MeasureSettings(views=500, resolution=256)).normalized
    after = compute_view_quality(finer, MeasureSettings(views=500, resolution=256)).normalized
    change = np.abs(after - before).mean(axis=0)
    assert change[PAPER_MEASURES.index("VR")] < 0.01
    assert change[PAPER_MEASURES.index("VMI")] < 0.03
    assert change[PAPER_MEASURES.index("VE")] > 0.1
    views = fibonacci_sphere(500)
    ve_best_after = views[np.argmax(after[:, 0])]
    assert ve_best_after[0] > 0.5  # VE now prefers the finely meshed +x side


def test_empty_views_and_constant_measures_are_handled(triangle):
    quality = compute_view_quality(triangle, MeasureSettings(resolution=64),
                                   view_directions=[[0, 0, 1], [0.3, 0.2, 1], [0, 0, -1]])
    front, back = quality.raw[:2], quality.raw[2]
    np.testing.assert_allclose(front[:, 1], 1.0)  # VR: the whole area is visible
    np.testing.assert_allclose(front[:, 0], 0.0)  # VE: one face, no uncertainty
    assert back[1] == 0.0 and np.isnan(back[[0, 2, 3]]).all()
    np.testing.assert_array_equal(quality.normalized[:2], 1.0)  # constant: every view is best
    np.testing.assert_array_equal(quality.normalized[2], 0.0)  # sees nothing: worst


def test_a_model_no_view_sees_is_a_measurement_error(triangle):
    with pytest.raises(MeasurementError, match="^triangle: no face is visible"):
        compute_view_quality(triangle, MeasureSettings(resolution=32), view_directions=[[0, 0, -1]])


def test_normalisation_direction_per_measure():
    raw = np.array([[1.0, 0.2, 5.0, 3.0], [3.0, 0.6, 1.0, 1.0], [2.0, 0.4, 3.0, np.nan]])
    normalized = normalize_quality(raw)
    np.testing.assert_allclose(normalized[:, 0], [0, 1, 0.5])  # higher is better
    np.testing.assert_allclose(normalized[:, 2], [0, 1, 0.5])  # lower is better
    np.testing.assert_allclose(normalized[:, 3], [0, 1, 0])  # NaN is worst


def test_real_mesh_result_is_complete_and_saves_without_pickle(bunny, tmp_path):
    quality = compute_view_quality(bunny, MeasureSettings(views=200, resolution=128))
    assert quality.raw.shape == quality.normalized.shape == (200, 4)
    assert np.isfinite(quality.raw).all()
    assert ((quality.normalized >= 0) & (quality.normalized <= 1)).all()
    np.testing.assert_array_equal(quality.normalized[quality.best_index, range(4)], 1.0)
    assert quality.best_views.shape == (4, 3)
    path = quality.save_npz(tmp_path / "bunny.npz")
    with np.load(path, allow_pickle=False) as stored:
        assert tuple(stored["measures"]) == PAPER_MEASURES
        np.testing.assert_array_equal(stored["raw"], quality.raw)
        assert "fov_deg" in str(stored["camera"]) and int(stored["resolution"]) == 128


# --- measures chosen by name --------------------------------------------------------------


def test_the_four_are_unchanged_through_the_general_path(bunny):
    settings = MeasureSettings(resolution=96)
    views = fibonacci_sphere(60)
    paper = compute_view_quality(bunny, settings, view_directions=views)
    more = compute_view_quality(bunny, settings, view_directions=views,
                                measures="VE,VR,VKL,VMI,NVT")
    assert more.measures == ("VE", "VR", "VKL", "VMI", "NVT")
    assert more.raw.shape == more.normalized.shape == (60, 5)
    np.testing.assert_array_equal(more.raw[:, :4], paper.raw)
    np.testing.assert_array_equal(more.normalized[:, :4], paper.normalized)
    np.testing.assert_array_equal(more.best_index[:4], paper.best_index)
    reordered = compute_view_quality(bunny, settings, view_directions=views, measures="VMI,VE")
    np.testing.assert_array_equal(reordered.raw, paper.raw[:, [3, 0]])


def test_only_the_requested_columns_and_directions_follow_the_names(cube):
    quality = compute_view_quality(cube, MeasureSettings(views=50, resolution=64),
                                   measures="I2,NVT")
    assert quality.measures == ("I2", "NVT")
    assert quality.higher_is_better == (False, True)
    assert quality.best_index.shape == quality.worst_index.shape == (2,)
    assert quality.best_views.shape == (2, 3)
    i2, nvt = quality.raw.T
    assert i2[quality.best_index[0]] == np.nanmin(i2)
    assert nvt[quality.best_index[1]] == nvt.max()
    assert list(quality.summary()["best"]) == ["I2", "NVT"]
    assert quality.summary()["best"]["I2"]["higher_is_better"] is False


def test_normalisation_and_ranking_take_any_directions():
    raw = np.array([[1.0, 5.0, 2.0], [3.0, 1.0, np.nan], [2.0, 3.0, 4.0]])
    normalized = normalize_quality(raw, [True, False, False])
    np.testing.assert_allclose(normalized, [[0, 0, 1], [1, 1, 0], [0.5, 0.5, 0]])
    np.testing.assert_array_equal(ranked_views(raw, 1, [True, False, True]), [1, 2, 0])
    np.testing.assert_array_equal(ranked_views(raw, 2, [True, True, True]), [2, 0, 1])
    with pytest.raises(InputError, match=r"expected shape \(n_views, 4\)"):
        normalize_quality(raw)  # the paper's four by default
    four = np.array([[1.0, 0.2, 5.0, 3.0], [3.0, 0.6, 1.0, 1.0]])
    np.testing.assert_array_equal(ranked_views(four, 2), [1, 0])  # VKL: lower is better


def test_npz_stores_the_names_and_directions(tmp_path, cube):
    quality = compute_view_quality(cube, MeasureSettings(views=40, resolution=64),
                                   measures="PA,VMI,I3")
    path = quality.save_npz(tmp_path / "cube.npz")
    with np.load(path, allow_pickle=False) as stored:
        assert tuple(stored["measures"]) == ("PA", "VMI", "I3")
        np.testing.assert_array_equal(stored["higher_is_better"], [True, False, True])
        np.testing.assert_array_equal(stored["raw"], quality.raw)
        np.testing.assert_array_equal(stored["best_index"], quality.best_index)


@pytest.mark.parametrize("backend", ["raster", "raycast"])
def test_a_view_of_one_face_has_exactly_zero_entropy_and_divergence(backend):
    if backend == "raycast":
        require_package("open3d")
    triangle = Mesh(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
                    np.array([[0, 1, 2]]), name="triangle")
    quality = compute_view_quality(triangle, MeasureSettings(views=30, resolution=32,
                                                             backend=backend),
                                   measures="VE,I2,VKL,VMI")
    seen = np.isfinite(quality.raw[:, 0])
    assert seen.any()
    values = quality.raw[seen]
    assert (values == 0.0).all() and not np.signbit(values).any(), values
