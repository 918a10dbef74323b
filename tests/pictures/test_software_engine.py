"""The software picture engine: the measures' rasteriser plus numpy shading."""

from __future__ import annotations

import numpy as np
import pytest

from fixtures.meshes import box_mesh
from fixtures.pictures import model_mask, started_renderer
from vptoolkit.camera import Camera
from vptoolkit.errors import InputError
from vptoolkit.mesh import Mesh
from vptoolkit.pictures.engine import open_renderer
from vptoolkit.pictures.shading import RenderStyle
from vptoolkit.pictures.software_engine import SoftwareRenderer
from vptoolkit.pictures.views import render_view
from vptoolkit.settings import MeasureSettings
from vptoolkit.visibility import face_id_images, face_pixel_counts

SIZE = 96
MEASURES_ROLL = RenderStyle(up=Camera().up)


def test_face_id_images_are_what_the_measures_count(bunny):
    directions = np.array([[0.3, 0.2, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    images = face_id_images(bunny, MeasureSettings(resolution=80), view_directions=directions)
    counts = face_pixel_counts(bunny, MeasureSettings(resolution=80), view_directions=directions)
    assert images.shape == (3, 80, 80) and images.dtype == np.int32 and images.min() == -1
    for view in range(3):
        seen = np.bincount(images[view][images[view] >= 0], minlength=bunny.n_faces)
        np.testing.assert_array_equal(seen, counts[view])


def test_silhouette_is_the_triangle_id_image(bunny):
    direction = [0.4, -0.3, 1.0]
    with SoftwareRenderer(size=SIZE, style=MEASURES_ROLL, supersampling=1) as renderer:
        image = renderer.render(bunny, direction)[0]
    background = (image == 255).all(axis=2)
    ids = face_id_images(bunny, MeasureSettings(resolution=SIZE), view_directions=[direction])[0]
    np.testing.assert_array_equal(~background, ids >= 0)


def test_cube_corner_view_shows_three_differently_lit_faces():
    cube = box_mesh()
    direction = np.array([1.0, 1.0, 1.0])
    with SoftwareRenderer(size=SIZE, style=MEASURES_ROLL) as renderer:
        image = renderer.render(cube, direction)[0]
    poses = Camera().poses(direction, centre=np.zeros(3), diagonal=np.sqrt(3), resolution=SIZE)
    brightness = []
    for axis in range(3):
        centre = np.zeros(3)
        centre[axis] = 0.5
        x, y, _ = poses.project(0, centre[None, :])[0]
        patch = image[int(y) - 3:int(y) + 4, int(x) - 3:int(x) + 4].reshape(-1, 3)
        assert patch.std(axis=0).max() < 2.0  # flat faces keep their own normal
        brightness.append(float(patch.mean()))
    assert max(brightness) < 240.0 and np.diff(sorted(brightness)).min() > 12.0, brightness


def test_pictures_are_upright_and_antialiased():
    raised = box_mesh()
    both = Mesh(np.vstack([raised.vertices, raised.vertices * 0.5 + [0.0, 1.5, 0.0]]),
                np.vstack([raised.faces, raised.faces + len(raised.vertices)]), "tower")
    with open_renderer(size=SIZE) as engine:  # the default engine and roll
        image = render_view(both, [0.2, 0.1, 1.0], engine=engine)
    rows = np.nonzero(model_mask(image))[0]
    top_half = model_mask(image)[: SIZE // 2].sum()
    assert rows.min() < SIZE * 0.25 and top_half < model_mask(image)[SIZE // 2:].sum()
    grey = image.min(axis=2)
    assert ((grey > 60) & (grey < 250)).any()  # blended edge pixels, not just two levels


def test_style_changes_the_shading():
    cube = box_mesh()
    darker = RenderStyle(light_intensity=0.0, ambient_intensity=10000.0, color=(1.0, 0.0, 0.0))
    with SoftwareRenderer(size=32, style=darker) as renderer:
        image = renderer.render(cube, [1.0, 1.0, 1.0])[0]
    centre = image[16, 16]
    assert centre[0] > 50 and centre[1] == centre[2] == 0  # red, ambient only


def test_open_renderer_checks_the_engine():
    assert isinstance(open_renderer("software", size=32), SoftwareRenderer)
    with pytest.raises(InputError, match="engine: expected one of software, open3d"):
        open_renderer("opengl")
    with pytest.raises(InputError, match="supersampling"):
        SoftwareRenderer(supersampling=8)


@pytest.fixture(scope="module")
def open3d_renderer():
    yield from started_renderer(SIZE, frame_timeout=30.0)


@pytest.mark.renderer
def test_both_engines_draw_the_same_silhouette(open3d_renderer, cube):
    direction = [1.0, 0.6, 0.3]
    with SoftwareRenderer(size=SIZE) as software:
        ours = model_mask(software.render(cube, direction)[0])
    theirs = model_mask(open3d_renderer.render(cube, direction)[0])
    assert (ours & theirs).sum() / (ours | theirs).sum() > 0.95
