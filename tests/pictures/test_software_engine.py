"""The software picture engine: the measures' rasteriser plus numpy shading."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.meshes import box_mesh
from fixtures.pictures import model_mask, started_renderer
from vptoolkit.camera import Camera
from vptoolkit.errors import InputError
from vptoolkit.mesh import Mesh
from vptoolkit.pictures.engine import open_renderer
from vptoolkit.pictures.shading import RenderStyle
from vptoolkit.pictures.software_engine import SoftwareRenderer
from vptoolkit.pictures.views import render_view
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.visibility import face_id_images, face_pixel_counts

SIZE = 96
MEASURES_FRAME = RenderStyle(up=Camera().up, margin=None)


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
    with SoftwareRenderer(size=SIZE, style=MEASURES_FRAME, supersampling=1) as renderer:
        image = renderer.render(bunny, direction)[0]
    background = (image == 255).all(axis=2)
    ids = face_id_images(bunny, MeasureSettings(resolution=SIZE), view_directions=[direction])[0]
    np.testing.assert_array_equal(~background, ids >= 0)


def test_cube_corner_view_shows_three_differently_lit_faces():
    cube = box_mesh()
    direction = np.array([1.0, 1.0, 1.0])
    with SoftwareRenderer(size=SIZE, style=MEASURES_FRAME) as renderer:
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


# ------------------------------------------------------------------ the model's own appearance

REAL = Path(__file__).resolve().parents[1] / "assets" / "real"


def drawn_pixels(image: np.ndarray) -> np.ndarray:
    """``(n, 3)`` float colours of the pixels that differ from the white background."""
    return image[(image < 250).any(axis=2)].astype(np.float64)


def test_duck_is_drawn_yellow_from_its_texture():
    require_package("PIL")
    from vptoolkit.io import load_with_appearance

    duck, appearance = load_with_appearance(sample_path("Duck.glb"))
    assert appearance.texture is not None and appearance.corner_uv is not None
    with SoftwareRenderer(size=128) as renderer:
        painted = drawn_pixels(renderer.render(duck, [0.3, 0.4, 1.0], appearance=appearance)[0])
        plain = drawn_pixels(renderer.render(duck, [0.3, 0.4, 1.0])[0])
    red, green, blue = painted.mean(axis=0)
    assert red > 150 and green > 120 and blue < 60, (red, green, blue)  # yellow
    assert plain.mean(axis=0)[2] > plain.mean(axis=0)[0]  # the default blue-grey
    assert len(painted) == len(plain)  # the same pixels, only their colour differs


def test_milk_truck_shows_its_texture_and_face_colours():
    require_package("PIL")
    from vptoolkit.io import load_with_appearance

    truck, appearance = load_with_appearance(REAL / "CesiumMilkTruck.glb")
    textured = np.isfinite(appearance.corner_uv[:, 0, 0])
    assert appearance.face_colors is not None and 0 < textured.sum() < truck.n_faces
    with SoftwareRenderer(size=128) as renderer:
        image = renderer.render(truck, [1.0, 0.5, 0.6], appearance=appearance)[0]
    pixels = drawn_pixels(image)
    # the white body with its green and blue logo, dark tyres and windows
    assert (pixels.min(axis=1) > 200).mean() > 0.1
    assert ((pixels[:, 1] > pixels[:, 0] + 40) | (pixels[:, 2] > pixels[:, 0] + 40)).sum() > 20
    assert (pixels.max(axis=1) < 60).sum() > 20


def test_obj_material_colours_are_drawn(tmp_path: Path):
    from vptoolkit.io import load_with_appearance

    (tmp_path / "two.mtl").write_text("newmtl red\nKd 0.9 0.05 0.05\n"
                                      "newmtl blue\nKd 0.05 0.1 0.9\n")
    vertices = "\n".join(f"v {x} {y} {z}" for x, y, z in box_mesh().vertices)
    faces = box_mesh().faces + 1
    half = len(faces) // 2
    lines = ["mtllib two.mtl", vertices, "usemtl red",
             *(f"f {a} {b} {c}" for a, b, c in faces[:half]), "usemtl blue",
             *(f"f {a} {b} {c}" for a, b, c in faces[half:])]
    (tmp_path / "two.obj").write_text("\n".join(lines) + "\n")
    box, appearance = load_with_appearance(tmp_path / "two.obj")
    assert appearance.face_colors is not None
    with SoftwareRenderer(size=64) as renderer:
        pixels = np.concatenate([drawn_pixels(renderer.render(box, direction,
                                                              appearance=appearance)[0])
                                 for direction in ([1, 1, 1], [-1, -1, -1])])
    reddish = (pixels[:, 0] > 2 * pixels[:, 2]).mean()
    bluish = (pixels[:, 2] > 2 * pixels[:, 0]).mean()
    assert reddish > 0.2 and bluish > 0.2 and reddish + bluish > 0.9, (reddish, bluish)


def test_ply_vertex_colours_are_interpolated(tmp_path: Path):
    from vptoolkit.io import load_mesh, load_with_appearance

    bunny = load_mesh(sample_path("bunny.ply"))
    height = bunny.vertices[:, 1]
    level = (height - height.min()) / np.ptp(height)
    colours = np.stack([255 * level, np.zeros_like(level), 255 * (1 - level)], axis=1)
    header = ["ply", "format ascii 1.0", f"element vertex {bunny.n_vertices}",
              "property float x", "property float y", "property float z",
              "property uchar red", "property uchar green", "property uchar blue",
              f"element face {bunny.n_faces}", "property list uchar int vertex_indices",
              "end_header"]
    rows = [f"{x} {y} {z} {r:.0f} {g:.0f} {b:.0f}"
            for (x, y, z), (r, g, b) in zip(bunny.vertices, colours)]
    rows += [f"3 {a} {b} {c}" for a, b, c in bunny.faces]
    (tmp_path / "painted.ply").write_text("\n".join(header + rows) + "\n")
    painted, appearance = load_with_appearance(tmp_path / "painted.ply")
    assert appearance.vertex_colors is not None
    with SoftwareRenderer(size=96) as renderer:  # image up is +y: red on top, blue below
        image = renderer.render(painted, [0.0, 0.0, 1.0], appearance=appearance)[0]
    rows_drawn = np.nonzero((image < 250).any(axis=2))[0]
    top = drawn_pixels(image[: (rows_drawn.min() + rows_drawn.max()) // 2 - 8])
    bottom = drawn_pixels(image[(rows_drawn.min() + rows_drawn.max()) // 2 + 8:])
    assert top[:, 0].mean() > top[:, 2].mean() + 30
    assert bottom[:, 2].mean() > bottom[:, 0].mean() + 30
    middle = drawn_pixels(image[(rows_drawn.min() + rows_drawn.max()) // 2 - 2:
                                (rows_drawn.min() + rows_drawn.max()) // 2 + 2])
    assert (np.abs(middle[:, 0] - middle[:, 2]) < 80).mean() > 0.5  # blended, not two levels


def test_an_appearance_of_another_mesh_is_refused():
    from vptoolkit.appearance import Appearance

    colours = np.full((3, 4), 200, dtype=np.uint8)
    with SoftwareRenderer(size=32) as renderer, pytest.raises(InputError, match="vertex colours"):
        renderer.render(box_mesh(), [1, 1, 1], appearance=Appearance(vertex_colors=colours))


# ------------------------------------------------------------------ framing


def drawn_box(image: np.ndarray) -> tuple[int, int, int, int]:
    """``(left, top, right, bottom)`` inclusive pixel bounds of the non-white pixels."""
    rows, columns = np.nonzero((image < 255).any(axis=2))
    return int(columns.min()), int(rows.min()), int(columns.max()), int(rows.max())


@pytest.mark.parametrize("extents", [(6.0, 0.2, 0.2), (3.0, 2.0, 0.05)], ids=["thin", "flat"])
@pytest.mark.parametrize("direction", [[0.2, 0.3, 1.0], [1.0, 0.1, 0.1], [0.5, 1.0, 0.4]])
def test_framing_touches_the_margin_and_never_crosses_it(extents, direction):
    size, margin = 200, 0.05
    border = round(margin * size)  # 10 pixels free on every side
    with SoftwareRenderer(size=size, style=RenderStyle(margin=margin)) as renderer:
        image = renderer.render(box_mesh(extents), direction)[0]
    left, top, right, bottom = drawn_box(image)
    gaps = [left - border, top - border, size - 1 - border - right, size - 1 - border - bottom]
    assert min(gaps) >= 0 and min(gaps) <= 2, gaps


def test_framing_magnifies_about_the_centre():
    plate = box_mesh((2.0, 2.0, 0.05))  # seen face on, it fills little of the inscribed circle
    with SoftwareRenderer(size=SIZE, style=MEASURES_FRAME) as measures, \
            SoftwareRenderer(size=SIZE, style=RenderStyle(up=Camera().up)) as framed:
        before = drawn_box(measures.render(plate, [0.0, 0.0, 1.0])[0])
        after = drawn_box(framed.render(plate, [0.0, 0.0, 1.0])[0])
    assert after[2] - after[0] > 1.2 * (before[2] - before[0])  # larger
    centre = (SIZE - 1) / 2
    assert abs((after[0] + after[2]) / 2 - centre) <= 1.5  # about the same centre
    with pytest.raises(InputError, match="margin"):
        RenderStyle(margin=0.5)


# ----------------------------------------------------------- the bits of numpy's plain paths
def plain_texture_lookup(texture: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Bilinear texture lookup by np.mod wrapping and [row, column] indexing."""
    height, width = texture.shape[:2]
    x = np.mod(uv[:, 0], 1.0) * width - 0.5
    y = (1.0 - np.mod(uv[:, 1], 1.0)) * height - 0.5
    left, top = np.floor(x), np.floor(y)
    dx, dy = (x - left)[:, None], (y - top)[:, None]
    c0 = np.mod(left.astype(np.int64), width)
    c1 = np.mod(c0 + 1, width)
    r0 = np.mod(top.astype(np.int64), height)
    r1 = np.mod(r0 + 1, height)
    return ((1 - dy) * ((1 - dx) * texture[r0, c0] + dx * texture[r0, c1])
            + dy * ((1 - dx) * texture[r1, c0] + dx * texture[r1, c1]))


def test_texture_lookup_has_the_bits_of_the_plain_lookup():
    from vptoolkit.pictures.shading import texture_lookup

    rng = np.random.default_rng(3)
    texture = rng.random((5, 7, 3)).astype(np.float32)
    edges = np.array([0.0, 1.0, -1e-20, 1.0 - 1e-17, -3.0, 2.5, 1 / 14, 0.5 / 5])
    uv = np.concatenate([rng.uniform(-3.0, 3.0, (5000, 2)),
                         np.stack(np.meshgrid(edges, edges), axis=-1).reshape(-1, 2)])
    assert np.array_equal(texture_lookup(texture, uv), plain_texture_lookup(texture, uv))


def test_block_means_and_cross_products_have_numpys_bits():
    from vptoolkit.pictures.software_engine import _cross, _downsample

    rng = np.random.default_rng(4)
    for factor in (1, 2, 3, 4):
        linear = rng.random(((37 * factor) ** 2, 3)) ** 3
        assert np.array_equal(_downsample(linear, 37, factor),
                              linear.reshape(37, factor, 37, factor, 3).mean(axis=(1, 3)))
    a, b = rng.normal(size=(2, 4000, 3)) * 10.0 ** rng.integers(-5, 5, (2, 4000, 1))
    assert np.array_equal(_cross(a, b), np.cross(a, b))


@pytest.mark.parametrize("supersampling", [2, 3])
def test_pictures_have_the_bytes_of_the_plain_numpy_paths(monkeypatch, supersampling):
    """The textured duck and a cloud drawn as by np.cross, reshape-mean and the plain
    texture lookup: the same pixels."""
    from vptoolkit.io import load_with_appearance
    from vptoolkit.pictures import software_engine
    from vptoolkit.point_cloud import PointCloud

    duck, appearance = load_with_appearance(sample_path("Duck.glb"))
    cloud = PointCloud(duck.vertices)
    directions = [[0.3, 0.4, 1.0], [-1.0, 0.2, -0.5]]

    def pictures() -> list[np.ndarray]:
        with SoftwareRenderer(size=48, supersampling=supersampling) as renderer:
            return [renderer.render(duck, directions, appearance=appearance),
                    renderer.render(cloud, directions)]

    fast = pictures()
    monkeypatch.setattr(software_engine, "_cross", np.cross)
    monkeypatch.setattr(software_engine, "texture_lookup", plain_texture_lookup)
    monkeypatch.setattr(software_engine, "_downsample", lambda linear, size, factor:
                        linear.reshape(size, factor, size, factor, 3).mean(axis=(1, 3)))
    for mine, plain in zip(fast, pictures()):
        assert np.array_equal(mine, plain)
