"""Open3D's render child: its checks, upright pictures, the measures' camera and recovery.

Tests marked ``renderer`` start Open3D's offscreen renderer in a child
process; they skip where none can start (no Vulkan driver), or fail with
``VPTOOLKIT_REQUIRE_ALL=1``. The silhouette test checks the camera against
the measures' own: every rendered pixel must be a pixel the measures' rays
hit (ray casting through ``ViewPoses.pixel_rays``).
"""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.meshes import box_mesh
from fixtures.pictures import model_mask, started_renderer
from vptoolkit.camera import Camera
from vptoolkit.errors import InputError, MeasurementError, MissingDependencyError
from vptoolkit.geometry import bounding_frame
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.mesh import Mesh
from vptoolkit.pictures.engine import open_renderer
from vptoolkit.pictures.open3d_engine import Renderer
from vptoolkit.pictures.shading import RenderStyle
from vptoolkit.pictures.views import (
    RenderedView,
    render_best,
    render_predicted,
    render_view,
    render_views,
)
from vptoolkit.settings import MeasureSettings

SIZE = 128


def pair_mesh() -> Mesh:
    """A box and a ball, apart and off-centre: an asymmetric pair of closed meshes."""
    import trimesh

    box = trimesh.creation.box(extents=(1.0, 0.6, 0.4))
    box.apply_translation((-0.6, 0.3, 0.1))
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.35)
    ball.apply_translation((0.5, -0.2, -0.3))
    both = trimesh.util.concatenate([box, ball])
    return Mesh(both.vertices, both.faces, "pair")


def test_renderer_checks_its_arguments():
    with pytest.raises(InputError, match="size"):
        Renderer(size=8)
    with pytest.raises(InputError, match="frame_timeout"):
        Renderer(frame_timeout=0)
    with pytest.raises(InputError, match="mesh: expected a vptoolkit Mesh"):
        Renderer().render("cube.off", [0, 0, 1])  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def renderer():
    """One render child for the module, with the measures' own roll (image up -y), so that
    picture pixels are triangle-ID pixels; start-up is paid once."""
    yield from started_renderer(SIZE, frame_timeout=30.0,
                                style=RenderStyle(up=Camera().up, margin=None))


@pytest.fixture(scope="module")
def upright_renderer():
    """A render child with the default image up (+y), framed as the measures frame."""
    yield from started_renderer(SIZE, style=RenderStyle(margin=None))


@pytest.fixture()
def default_renderer():
    """A render child with the default style: image up +y, framed to the default margin
    (one per test, closed after it, so that no more children run at once than before)."""
    yield from started_renderer(SIZE, frame_timeout=30.0)


@pytest.mark.renderer
def test_vertex_colours_are_drawn(default_renderer):
    from vptoolkit.appearance import Appearance

    box = box_mesh((2.0, 1.0, 1.0))
    colours = np.where(box.vertices[:, :1] > 0, [[230, 20, 20, 255]], [[20, 20, 230, 255]])
    appearance = Appearance(vertex_colors=colours.astype(np.uint8))
    image = default_renderer.render(box, [0.0, 0.3, 1.0], appearance=appearance)[0]
    pixels = image[model_mask(image)].astype(float)
    reddish = (pixels[:, 0] > pixels[:, 2] + 40).mean()
    bluish = (pixels[:, 2] > pixels[:, 0] + 40).mean()
    assert reddish > 0.25 and bluish > 0.25, (reddish, bluish)
    plain = default_renderer.render(box, [0.0, 0.3, 1.0])[0]
    grey = plain[model_mask(plain)].astype(float)
    assert (grey[:, 2] >= grey[:, 0]).all()  # the style's blue-grey


@pytest.mark.renderer
def test_duck_texture_is_sampled_at_the_corners(default_renderer):
    require_package("PIL")
    from vptoolkit.io import load_with_appearance
    from vptoolkit.samples import sample_path

    duck, appearance = load_with_appearance(sample_path("Duck.glb"))
    image = default_renderer.render(duck, [0.3, 0.4, 1.0], appearance=appearance)[0]
    red, green, blue = image[(image < 250).any(axis=2)].astype(float).mean(axis=0)
    assert red > 150 and green > 120 and blue < 80, (red, green, blue)


@pytest.mark.renderer
def test_pictures_are_framed_to_the_margin(default_renderer):
    border = round(0.05 * SIZE)
    image = default_renderer.render(box_mesh((3.0, 2.0, 0.05)), [0.2, 0.3, 1.0])[0]
    rows, columns = np.nonzero((image < 255).any(axis=2))
    gaps = [columns.min() - border, rows.min() - border, SIZE - 1 - border - columns.max(),
            SIZE - 1 - border - rows.max()]
    assert min(gaps) >= -1 and min(gaps) <= 2, gaps


@pytest.mark.renderer
@pytest.mark.parametrize("direction", [[1.0, 0.2, 0.6], [0.0, 0.0, 1.0]])
def test_default_pictures_are_upright_rolls_of_the_measures_view(renderer, upright_renderer,
                                                                 direction):
    """Default up (+y) turns the measures' picture (up -y) by 180 degrees, nothing else."""
    mesh = pair_mesh()
    measures_roll = model_mask(renderer.render(mesh, direction)[0])
    upright = model_mask(upright_renderer.render(mesh, direction)[0])
    turned = measures_roll[::-1, ::-1]
    assert (upright & turned).sum() / (upright | turned).sum() > 0.97
    cube_on_y = Mesh(box_mesh().vertices + [0.0, 1.0, 0.0], box_mesh().faces, "raised")
    both = Mesh(np.vstack([pair_mesh().vertices, cube_on_y.vertices]),
                np.vstack([pair_mesh().faces, cube_on_y.faces + len(pair_mesh().vertices)]), "both")
    rows = np.nonzero(model_mask(upright_renderer.render(both, [0.0, 0.0, 1.0])[0]))[0]
    assert rows.min() < SIZE * 0.2  # the part at +y is at the top of an upright picture


@pytest.mark.renderer
def test_cube_corner_view_shows_three_differently_lit_faces(renderer):
    cube = box_mesh()
    direction = np.array([1.0, 1.0, 1.0])
    image = renderer.render(cube, direction)[0]
    poses = Camera().poses(direction, centre=np.zeros(3), diagonal=np.sqrt(3), resolution=SIZE)
    colours = []
    for axis in range(3):  # the +x, +y and +z faces face the camera
        centre = np.zeros(3)
        centre[axis] = 0.5
        x, y, _ = poses.project(0, centre[None, :])[0]
        patch = image[int(y) - 3:int(y) + 4, int(x) - 3:int(x) + 4].reshape(-1, 3)
        assert patch.std(axis=0).max() < 6.0  # one flat colour over the face
        colours.append(patch.mean(axis=0))
    brightness = sorted(float(c.mean()) for c in colours)
    assert brightness[-1] < 240.0  # lit faces, not background
    assert np.diff(brightness).min() > 12.0, brightness


@pytest.mark.renderer
def test_picture_is_not_blank(renderer, bunny):
    image = renderer.render(bunny, [0.0, 0.0, 1.0])[0]
    assert image.shape == (SIZE, SIZE, 3) and image.dtype == np.uint8
    assert (image[0, 0] == 255).all()  # white background
    covered = model_mask(image)
    assert 0.1 < covered.mean() < 0.8
    assert image[covered].std() > 10.0  # shaded, not a flat silhouette


@pytest.mark.renderer
@pytest.mark.parametrize(
    "direction",
    [[0.0, 0.0, 1.0], [1.0, 0.3, 0.5], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [-1.0, -1.0, 0.2]],
    ids=["front", "oblique", "top-fallback-up", "bottom-fallback-up", "below-left"],
)
def test_silhouette_matches_the_measures_camera(renderer, direction):
    o3d = pytest.importorskip("open3d")
    mesh = pair_mesh()
    image = renderer.render(mesh, direction)[0]
    mask = model_mask(image)
    centre, diagonal = bounding_frame(mesh)
    poses = Camera().poses(direction, centre=centre, diagonal=diagonal, resolution=SIZE)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(mesh.vertices.astype(np.float32), mesh.faces.astype(np.uint32))
    hits = scene.cast_rays(o3d.core.Tensor(poses.pixel_rays(0)))["t_hit"].numpy()
    reference = np.isfinite(hits).reshape(SIZE, SIZE)
    iou = (mask & reference).sum() / (mask | reference).sum()
    assert iou > 0.95, iou
    projected = poses.project(0, mesh.vertices)
    rows, columns = np.nonzero(mask)
    np.testing.assert_allclose(
        [columns.min(), columns.max() + 1, rows.min(), rows.max() + 1],
        [projected[:, 0].min(), projected[:, 0].max(), projected[:, 1].min(),
         projected[:, 1].max()],
        atol=1.5,
    )


@pytest.mark.renderer
def test_back_faces_are_culled_like_the_measures(renderer, triangle):
    front = renderer.render(triangle, [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    assert model_mask(front[0]).sum() > 100
    assert (front[1] == 255).all()  # seen from behind: nothing, as VR = 0 there
    with Renderer(size=32, camera=Camera(cull_back_faces=False)) as both_sides:
        assert model_mask(both_sides.render(triangle, [0.0, 0.0, -1.0])[0]).sum() > 20


@pytest.mark.renderer
def test_documented_return_shapes(renderer, cube):
    images = render_views(cube, np.eye(3), engine=renderer)
    assert images.shape == (3, SIZE, SIZE, 3) and images.dtype == np.uint8
    image = render_view(cube, [0.0, 0.0, 1.0], engine=renderer)
    assert image.shape == (SIZE, SIZE, 3)
    np.testing.assert_array_equal(image, images[2])  # same camera, same picture


@pytest.mark.renderer
def test_render_best_draws_the_best_view(renderer, cube):
    from vptoolkit.measures.quality import compute_view_quality

    quality = compute_view_quality(cube, MeasureSettings(views=60, resolution=48))
    for column, measure in enumerate(PAPER_MEASURES):
        view = render_best(cube, measure=measure, quality=quality, engine=renderer)
        assert isinstance(view, RenderedView)
        index = int(quality.best_index[column])
        np.testing.assert_array_equal(view.direction, quality.views[index])
        assert view.label == f"best {measure} (view {index} of 60)"
        assert model_mask(view.image).any()


@pytest.mark.renderer
def test_render_predicted_calls_the_hook(renderer, cube):
    seen = []

    def predict(mesh: Mesh) -> np.ndarray:
        seen.append(mesh.name)
        return np.tile([0.0, 0.0, 1.0], (4, 1))

    view = render_predicted(cube, predict, measure="VKL", engine=renderer)
    assert seen == ["box"] and view.label == "predicted VKL"
    np.testing.assert_array_equal(view.image, render_view(cube, [0, 0, 1], engine=renderer))


@pytest.mark.renderer
def test_a_killed_child_is_replaced(renderer, cube):
    before = renderer.render(cube, [1.0, 1.0, 1.0])[0]
    restarts = renderer.n_restarts
    os.kill(renderer._child.process.pid, signal.SIGKILL)
    after = renderer.render(cube, [1.0, 1.0, 1.0])[0]
    assert renderer.n_restarts == restarts + 1
    # Filament on a software Vulkan driver may round a pixel or two differently in a
    # new process; the picture is the same.
    difference = np.abs(after.astype(np.int64) - before.astype(np.int64))
    assert difference.max() <= 2 and np.count_nonzero(difference) <= 0.001 * difference.size


@pytest.mark.renderer
def test_a_hung_frame_is_a_measurement_error_and_the_renderer_recovers(renderer, cube):
    renderer.frame_timeout, renderer.attempts = 1e-4, 2
    try:
        with pytest.raises(MeasurementError,
                           match=r"^box: renderer: no answer within .* in 2 attempts$"):
            renderer.render(cube, [0.0, 1.0, 0.0])
    finally:
        renderer.frame_timeout, renderer.attempts = 30.0, 3
    assert model_mask(renderer.render(cube, [0.0, 1.0, 0.0])[0]).any()


def test_no_vulkan_driver_is_a_one_line_missing_dependency(monkeypatch, cube):
    require_package("open3d")
    for variable in ("VK_ICD_FILENAMES", "VK_DRIVER_FILES"):
        monkeypatch.setenv(variable, "/nonexistent/vptoolkit-test-icd.json")
    with pytest.raises(MissingDependencyError) as caught, \
            open_renderer("open3d", size=32) as engine:
        render_view(cube, [0.0, 0.0, 1.0], engine=engine)
    message = str(caught.value)
    assert message.startswith("renderer: Open3D's offscreen renderer could not start "
                              "(no Vulkan driver?): ")
    assert "\n" not in message
    assert "SIGABRT" in message  # the abort happened in the child, not here
