"""The measuring session: its passes, and the values frozen before it existed, bit for bit.

``tests/assets/measured_values.npz`` holds the raw values of two sample meshes
(``suzanne.ply``, ``mug.obj``; 60 Fibonacci views at 64 px) for the paper's
four, VE alone and every registered measure, and the answers of best-view
searches (24 views at 64 px, with and without a prior, the paper's four and a
mix of the paper's and other measures). Any change of a value fails; the file
is rewritten, by running this module (``tests`` on the path), only for a
deliberate change of what a measure computes.
"""

import numpy as np
import pytest

from fixtures.paths import ASSETS
from vptoolkit.best_view.search import SearchSettings, search_best_views
from vptoolkit.errors import InputError, MeasurementError
from vptoolkit.io import load_mesh
from vptoolkit.measures.curvature import CACHE_KEY
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.measures.session import MeasuringSession
from vptoolkit.mesh import Mesh
from vptoolkit.point_cloud import PointCloud
from vptoolkit.points import sample_surface
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere

FROZEN_VALUES = ASSETS / "measured_values.npz"
FROZEN_MESHES = ("suzanne.ply", "mug.obj")
QUALITY_SPECS = ("paper", "VE", "all")
SEARCH_SPECS = {"paper": None, "mixed": "VKL,NVT,SL,I2,SS,VE"}
PRIOR = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def _quality_case(name: str, spec: str) -> dict[str, np.ndarray]:
    mesh = load_mesh(sample_path(name))
    quality = compute_view_quality(mesh, MeasureSettings(views=60, resolution=64), measures=spec)
    return {f"{name.split('.')[0]}/quality/{spec}": quality.raw}


def _search_case(name: str, spec: str, with_prior: bool) -> dict[str, np.ndarray]:
    mesh = load_mesh(sample_path(name))
    found = search_best_views(mesh, SearchSettings(budget=24, resolution=64),
                              prior=PRIOR if with_prior else None, measures=SEARCH_SPECS[spec])
    key = f"{name.split('.')[0]}/search/{spec}/{'prior' if with_prior else 'sphere'}"
    return {f"{key}/directions": found.directions, f"{key}/raw": found.raw}


@pytest.fixture(scope="module")
def frozen():
    with np.load(FROZEN_VALUES, allow_pickle=False) as archive:
        return dict(archive)


@pytest.mark.parametrize("spec", QUALITY_SPECS)
@pytest.mark.parametrize("name", FROZEN_MESHES)
def test_compute_view_quality_keeps_the_frozen_values(frozen, name, spec):
    for key, value in _quality_case(name, spec).items():
        assert np.array_equal(value, frozen[key], equal_nan=True), key


@pytest.mark.parametrize("with_prior", [False, True])
@pytest.mark.parametrize("spec", list(SEARCH_SPECS))
@pytest.mark.parametrize("name", FROZEN_MESHES)
def test_search_best_views_keeps_the_frozen_answers(frozen, name, spec, with_prior):
    for key, value in _search_case(name, spec, with_prior).items():
        assert np.array_equal(value, frozen[key], equal_nan=True), key


@pytest.fixture(scope="module")
def mug():
    return load_mesh(sample_path("mug.obj"))


def test_any_subset_of_the_paper_s_four_streams_in_one_pass(mug):
    views = fibonacci_sphere(30)
    paper = MeasuringSession(mug, "paper", MeasureSettings(resolution=64))
    four = paper.measure(views)
    for spec, columns in (("VE", [0]), ("vkl,VR", [2, 1]), ("VE,VR,VKL", [0, 1, 2])):
        session = MeasuringSession(mug, spec, MeasureSettings(resolution=64))
        assert session.streams and not session.view_columns
        once = iter(list(paper.draw(views, 64)))  # runs that can be read only once
        raw = session.measure(views, histograms=once)  # type: ignore[arg-type]
        assert np.array_equal(raw, four[:, columns], equal_nan=True), spec


def test_other_measures_read_the_kept_counts_and_the_four_keep_their_values(mug):
    views = fibonacci_sphere(30)
    session = MeasuringSession(mug, "NVT,VMI,CE,SL", MeasureSettings(resolution=64))
    assert not session.streams and session.sum_columns == [1]
    assert session.view_columns == [0, 2, 3] and session.features
    raw = session.measure(views)
    paper = MeasuringSession(mug, "paper", MeasureSettings(resolution=64)).measure(views)
    assert np.array_equal(raw[:, 1], paper[:, 3], equal_nan=True)
    assert np.isfinite(raw).all()
    curvature = session.mesh_cache[CACHE_KEY]
    only = session.measure(views[:5], columns=[2])
    assert session.mesh_cache[CACHE_KEY] is curvature  # computed once per session
    assert np.isnan(only[:, [0, 1, 3]]).all() and np.isfinite(only[:, 2]).all()


def test_histograms_without_the_statistics_a_measure_reads_are_refused(mug):
    views = fibonacci_sphere(4)
    plain = MeasuringSession(mug, "VE", MeasureSettings(resolution=32))
    session = MeasuringSession(mug, "SL", MeasureSettings(resolution=32))
    with pytest.raises(InputError, match=r"^histograms: .* \(needed by SL\)$"):
        session.measure(views, histograms=list(plain.draw(views)))


def test_views_that_see_nothing_raise_or_are_nan():
    triangle = Mesh(np.eye(3), np.array([[0, 1, 2]]), name="triangle")
    behind = -np.ones((1, 3)) / np.sqrt(3.0)  # sees the culled back face only
    session = MeasuringSession(triangle, "VE,NVT", MeasureSettings(resolution=16))
    with pytest.raises(MeasurementError, match="no face is visible"):
        session.measure(behind)
    assert np.isnan(session.measure(behind, require_seen=False)).all()


def _cloud(name, n_points=20000):

    mesh = load_mesh(sample_path(name))
    sample = sample_surface(mesh, n_points, seed=0)
    return mesh, PointCloud(sample.points, sample.normals, name=mesh.name)


@pytest.mark.parametrize("name", ["bunny.ply", "torus.STL"])
def test_a_point_cloud_ranks_the_views_as_its_mesh_does(name):
    # 20,000 points splatted against the mesh's faces, 200 views at 128 px:
    # the measures of the pixel counts rank the views alike (INS, from pairs
    # of neighbouring views, a little less: 0.85 on the torus).
    from scipy.stats import spearmanr

    mesh, cloud = _cloud(name)
    views = fibonacci_sphere(200)
    bounds = {"VR": 0.9, "VKL": 0.9, "VMI": 0.9, "NVT": 0.9, "EVMI": 0.9, "INS": 0.8}
    settings = MeasureSettings(resolution=128)
    on_mesh = MeasuringSession(mesh, tuple(bounds), settings).measure(views)
    on_points = MeasuringSession(cloud, tuple(bounds), settings).measure(views)
    for column, (measure, bound) in enumerate(bounds.items()):
        assert spearmanr(on_mesh[:, column], on_points[:, column])[0] >= bound, measure


def test_a_cloud_is_the_same_however_it_is_given():
    import trimesh

    _, cloud = _cloud("torus.STL", 3000)
    views = fibonacci_sphere(12)
    settings = MeasureSettings(resolution=64)
    expected = MeasuringSession(cloud, ("VE", "VR", "VKL", "VMI", "SAL"), settings)
    raw = expected.measure(views)
    assert expected.n_elements == 3000 and expected.areas.shape == (3000,)
    table = np.concatenate([cloud.points, cloud.normals], axis=1)
    np.testing.assert_array_equal(MeasuringSession(table, ("VE", "VR", "VKL", "VMI", "SAL"),
                                                   settings).measure(views), raw)
    plain = MeasuringSession(cloud.points, "paper", settings).measure(views)
    as_trimesh = MeasuringSession(trimesh.PointCloud(cloud.points), "paper", settings)
    np.testing.assert_array_equal(as_trimesh.measure(views), plain)
    quality = compute_view_quality(cloud, MeasureSettings(views=12, resolution=64))
    assert quality.n_faces == 3000 and quality.name == "torus"


def test_a_cloud_refuses_the_measures_not_defined_on_points_in_one_line():
    _, cloud = _cloud("torus.STL", 3000)
    with pytest.raises(InputError, match=r"^torus: SL, MD, CE are not defined on a point cloud "
                                         r"\(reading silhouettes, depth or a face curvature\); "
                                         r"on points: NVT, "):
        MeasuringSession(cloud, "VE,SL,MD,CE")
    with pytest.raises(InputError, match=r"^few: points: 3 points, need more than k = 8"):
        MeasuringSession(PointCloud(np.eye(3), name="few"), "VE")


if __name__ == "__main__":  # rewrite the frozen values from the current code
    arrays: dict[str, np.ndarray] = {}
    for name in FROZEN_MESHES:
        for spec in QUALITY_SPECS:
            arrays.update(_quality_case(name, spec))
        for spec in SEARCH_SPECS:
            for with_prior in (False, True):
                arrays.update(_search_case(name, spec, with_prior))
    np.savez_compressed(FROZEN_VALUES, **arrays)
