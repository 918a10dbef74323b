"""Other libraries' meshes in (trimesh, Open3D, (vertices, faces)); cameras out to renderers."""

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from fixtures.environment import require_package
from vptoolkit.best_view.prior import UnoccludedPrior
from vptoolkit.best_view.search import SearchSettings, search_best_views
from vptoolkit.errors import InputError
from vptoolkit.geometry import bounding_frame, face_areas
from vptoolkit.io import load_mesh, save_mesh
from vptoolkit.measures.quality import compute_view_quality
from vptoolkit.mesh import Mesh, as_mesh
from vptoolkit.points import sample_surface
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.view_sets.search import best_view_set
from vptoolkit.visibility import face_id_images

KINDS = ["trimesh", "open3d", "tuple"]


@pytest.fixture(scope="module")
def mug() -> Mesh:
    return load_mesh(sample_path("mug.obj"))


def other_mesh(kind: str, mesh: Mesh):
    """``mesh`` as another library holds it (both libraries refuse read-only arrays)."""
    vertices, faces = mesh.vertices.copy(), mesh.faces.copy()
    if kind == "trimesh":
        require_package("trimesh")
        import trimesh

        return trimesh.Trimesh(vertices, faces, process=False)
    if kind == "open3d":
        require_package("open3d")
        import open3d as o3d

        return o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(vertices),
                                         o3d.utility.Vector3iVector(faces.astype(np.int32)))
    return vertices, faces


@pytest.mark.parametrize("kind", KINDS)
def test_as_mesh_keeps_the_arrays_as_float64_and_int64_copies(mug, kind):
    source = other_mesh(kind, mug)
    converted = as_mesh(source, name="mug")
    assert type(converted) is Mesh and converted.name == "mug"
    assert converted.vertices.dtype == np.float64 and converted.faces.dtype == np.int64
    np.testing.assert_array_equal(converted.vertices, mug.vertices)
    np.testing.assert_array_equal(converted.faces, mug.faces)
    assert as_mesh(source).name == "mesh"
    assert as_mesh(mug) is mug and as_mesh(mug, name="other") is mug


@pytest.mark.parametrize("kind", KINDS)
def test_every_input_gives_exactly_the_search_of_the_mesh(mug, kind):
    expected = search_best_views(mug, SearchSettings(budget=16, resolution=64))
    found = search_best_views(other_mesh(kind, mug), SearchSettings(budget=16, resolution=64))
    assert found.directions.tobytes() == expected.directions.tobytes()
    assert found.raw.tobytes() == expected.raw.tobytes()
    assert found.stages == expected.stages
    for convention in ("opencv", "opengl"):
        assert found.camera_pose("VMI", convention=convention).tobytes() == \
            expected.camera_pose("VMI", convention=convention).tobytes()


@pytest.mark.parametrize("kind", KINDS)
def test_the_other_entry_points_take_every_input(mug, kind, tmp_path):
    source = other_mesh(kind, mug)
    settings = MeasureSettings(views=20, resolution=32)
    assert compute_view_quality(source, settings).raw.tobytes() == \
        compute_view_quality(mug, settings).raw.tobytes()
    assert sample_surface(source, 100, seed=3).points.tobytes() == \
        sample_surface(mug, 100, seed=3).points.tobytes()
    assert face_areas(source).tobytes() == face_areas(mug).tobytes()
    (centre, diagonal), (mug_centre, mug_diagonal) = bounding_frame(source), bounding_frame(mug)
    assert centre.tobytes() == mug_centre.tobytes() and diagonal == mug_diagonal
    np.testing.assert_array_equal(UnoccludedPrior()(source), UnoccludedPrior()(mug))
    np.testing.assert_array_equal(best_view_set(source, 2, settings=settings).indices,
                                  best_view_set(mug, 2, settings=settings).indices)
    np.testing.assert_array_equal(face_id_images(source, settings, view_directions=[[0, 0, 1]]),
                                  face_id_images(mug, settings, view_directions=[[0, 0, 1]]))
    written = load_mesh(save_mesh(source, tmp_path / "mug.ply"))
    np.testing.assert_array_equal(written.faces, mug.faces)


@pytest.mark.parametrize("value, message", [
    ("mug.obj", "model: expected a Mesh, a PointCloud, a trimesh or Open3D mesh, point cloud or "
                "scene, an (N, 3) array or (vertices, faces), got str"),
    ([np.eye(3), [[0, 1, 2]]], "points: expected an (N, 3) or (N, 6) point array, got a list "
                               "that is not one"),
    ((np.eye(3), [[0, 1, 2]], None), "model: expected a Mesh, a PointCloud, a trimesh or Open3D "
                                     "mesh, point cloud or scene, an (N, 3) array or (vertices, "
                                     "faces), got tuple"),
], ids=["path", "list", "triple"])
def test_anything_else_is_refused_in_one_line(value, message):
    with pytest.raises(InputError) as caught:
        search_best_views(value, SearchSettings(budget=8, resolution=32))
    assert str(caught.value) == message


def test_bad_arrays_are_named_by_the_mesh_check():
    with pytest.raises(InputError, match="^chair: face index 5 out of range for 3 vertices$"):
        as_mesh((np.eye(3), [[0, 1, 5]]), name="chair")
    require_package("trimesh")
    import trimesh

    with pytest.raises(InputError, match="^mesh: mesh has no faces$"):
        search_best_views(trimesh.Trimesh(), SearchSettings(budget=8, resolution=32))


def test_trimesh_scene_camera_with_the_opengl_pose_casts_through_our_pixels(mug):
    """trimesh's own camera, given the OpenGL pose and the field of view, has our K, and its ray
    for every pixel lands on that pixel's centre under K and the OpenCV pose."""
    require_package("trimesh")
    import trimesh

    found = search_best_views(mug, SearchSettings(budget=16, resolution=64))
    scene = trimesh.Scene(other_mesh("trimesh", mug))
    scene.camera.resolution = (48, 48)
    scene.camera.fov = (45.0, 45.0)
    scene.camera_transform = found.camera_pose("VE", convention="opengl")
    np.testing.assert_allclose(scene.camera.K, found.intrinsics(48), rtol=1e-12)
    origins, vectors, pixels = scene.camera_rays()
    extrinsic = np.linalg.inv(found.camera_pose("VE"))
    camera_points = (origins + vectors) @ extrinsic[:3, :3].T + extrinsic[:3, 3]
    projected = camera_points @ found.intrinsics(48).T
    projected = projected[:, :2] / projected[:, 2:]
    # trimesh counts its pixel rows from the bottom of the picture, vptoolkit from the top
    expected = np.column_stack([pixels[:, 0], 47 - pixels[:, 1]]) + 0.5
    np.testing.assert_allclose(projected, expected, atol=1e-9)


OPEN3D_GUIDE = """
import sys
import numpy as np
import open3d as o3d
from vptoolkit.io import load_mesh
from vptoolkit.samples import sample_path
from vptoolkit.best_view.search import SearchSettings, search_best_views

mug = load_mesh(sample_path("mug.obj"))
found = search_best_views(mug, SearchSettings(budget=16, resolution=64))
mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(mug.vertices.copy()),
                                 o3d.utility.Vector3iVector(mug.faces.astype(np.int32)))
mesh.compute_vertex_normals()
renderer = o3d.visualization.rendering.OffscreenRenderer(256, 256)
renderer.scene.set_background([0.0, 0.0, 0.0, 1.0])
material = o3d.visualization.rendering.MaterialRecord()
material.shader = "unlitSolidColor"
material.base_color = [1.0, 1.0, 1.0, 1.0]
renderer.scene.add_geometry("mug", mesh, material)
renderer.setup_camera(o3d.camera.PinholeCameraIntrinsic(256, 256, found.intrinsics(256)),
                      np.linalg.inv(found.camera_pose("VE")))
np.save(sys.argv[1], np.asarray(renderer.render_to_image()))
"""


@pytest.mark.renderer
def test_open3d_draws_the_found_view_where_the_rasteriser_does(mug, tmp_path):
    """Open3D's renderer, given K and the inverse OpenCV pose, draws the silhouette the
    triangle-ID image of the same view has, turned half a turn (in a child process, as
    Filament wants)."""
    require_package("open3d")
    script = tmp_path / "draw.py"
    script.write_text(textwrap.dedent(OPEN3D_GUIDE))
    subprocess.run([sys.executable, str(script), str(tmp_path / "picture.npy")], check=True,
                   capture_output=True, timeout=300, cwd=tmp_path)
    drawn = np.load(tmp_path / "picture.npy", allow_pickle=False)[:, :, :3].max(axis=2) > 127
    found = search_best_views(mug, SearchSettings(budget=16, resolution=64))
    # the exported pose puts +y up, the measures -y: half a turn about the optical axis
    seen = np.rot90(face_id_images(mug, MeasureSettings(views=1, resolution=256),
                                   view_directions=found.directions[:1])[0] >= 0, 2)
    assert (drawn & seen).sum() / (drawn | seen).sum() > 0.97
    rows, columns = np.nonzero(drawn)
    seen_rows, seen_columns = np.nonzero(seen)
    assert abs(rows.mean() - seen_rows.mean()) < 0.25  # a flipped axis or a half-pixel
    assert abs(columns.mean() - seen_columns.mean()) < 0.25  # shift would show here
