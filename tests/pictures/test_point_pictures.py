"""Pictures of point clouds: the measures' splats, the points' colours, their normals' light;
the commands that draw them (render, thumbnails, sphere-map) and their --json records."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.pictures import decode_png, model_mask
from vptoolkit.camera import Camera
from vptoolkit.cli import main
from vptoolkit.errors import InputError
from vptoolkit.io import load_with_appearance, save_mesh
from vptoolkit.pictures.shading import RenderStyle
from vptoolkit.pictures.software_engine import SoftwareRenderer
from vptoolkit.point_cloud import PointCloud
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.visibility.splats import PointScene, iter_point_histograms

SIZE = 96
FRONT = np.array([0.0, 0.2, 1.0])
RED = (0.9, 0.1, 0.1)


def write_bunny_cloud(path: Path, *, normals: bool = True,
                      colors: Callable[[np.ndarray], np.ndarray] | tuple[float, float, float]
                      | None = RED) -> Path:
    """6000 points sampled (seeded) on the bundled bunny, written by Open3D as a PLY cloud,
    with their faces' normals and a colour (one for all, or ``colors(points)`` ``(n, 3)``
    in 0..1) where asked."""
    require_package("open3d")
    import open3d as o3d

    o3d.utility.random.seed(0)
    mesh = o3d.io.read_triangle_mesh(str(sample_path("bunny.ply")))
    mesh.compute_triangle_normals()
    cloud = mesh.sample_points_uniformly(6000, use_triangle_normal=True)
    if not normals:
        cloud.normals = o3d.utility.Vector3dVector(np.zeros((0, 3)))
    if isinstance(colors, tuple):
        cloud.paint_uniform_color(colors)
    elif colors is not None:
        cloud.colors = o3d.utility.Vector3dVector(colors(np.asarray(cloud.points)))
    assert o3d.io.write_point_cloud(str(path), cloud)
    return path


def strict_json(text: str):
    """JSON that has no NaN or infinity (``json.loads`` would take them)."""
    def refuse(constant: str):
        raise AssertionError(f"not strict JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


@pytest.fixture(scope="module")
def red_bunny(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_bunny_cloud(tmp_path_factory.mktemp("clouds") / "bunny.ply")


def test_a_coloured_cloud_is_drawn_in_its_colour_on_the_background(red_bunny: Path):
    cloud, appearance = load_with_appearance(red_bunny)
    assert isinstance(cloud, PointCloud) and appearance.vertex_colors is not None
    with SoftwareRenderer(size=SIZE) as renderer:
        image = renderer.render(cloud, FRONT, appearance=appearance)[0].astype(int)
    mask = model_mask(image)
    assert 0.15 < mask.mean() < 0.8  # the bunny, framed, with background around it
    assert (image[0, :] == 255).all() and (image[:, 0] == 255).all()  # no splat: background
    red, green, blue = (image[..., channel][mask] for channel in range(3))
    assert np.median(red) > 150 and np.median(green) < 90 and np.median(blue) < 90


def test_per_point_colours_are_drawn_where_their_points_are(tmp_path: Path):
    def two_colours(points: np.ndarray) -> np.ndarray:  # blue above, green below
        top = points[:, 1] > np.median(points[:, 1])
        return np.where(top[:, None], [0.1, 0.1, 0.9], [0.1, 0.8, 0.1])

    cloud, appearance = load_with_appearance(write_bunny_cloud(tmp_path / "two.ply",
                                                               colors=two_colours))
    with SoftwareRenderer(size=SIZE) as renderer:
        image = renderer.render(cloud, FRONT, appearance=appearance)[0].astype(int)
    rows = np.flatnonzero(model_mask(image).any(axis=1))
    upper, lower = image[rows[2]:rows[len(rows) // 4]], image[rows[-len(rows) // 4]:rows[-2]]
    upper_mask, lower_mask = model_mask(upper), model_mask(lower)
    assert (upper[..., 2] > upper[..., 1])[upper_mask].mean() > 0.9  # the +y half is on top
    assert (lower[..., 1] > lower[..., 2])[lower_mask].mean() > 0.9


def test_normals_shade_a_cloud_and_a_cloud_without_them_is_flat(tmp_path: Path):
    style = RenderStyle(color=(0.7, 0.7, 0.7))
    shaded, _ = load_with_appearance(write_bunny_cloud(tmp_path / "lit.ply", colors=None))
    flat, _ = load_with_appearance(write_bunny_cloud(tmp_path / "flat.ply", colors=None,
                                                     normals=False))
    assert isinstance(shaded, PointCloud) and shaded.normals is not None
    assert isinstance(flat, PointCloud) and flat.normals is None
    with SoftwareRenderer(size=SIZE, style=style, supersampling=1) as renderer:
        lit_image, flat_image = (renderer.render(cloud, FRONT)[0].astype(int)
                                 for cloud in (shaded, flat))
    lit = lit_image[model_mask(lit_image)].mean(axis=1)
    even = flat_image[model_mask(flat_image)].mean(axis=1)
    assert lit.std() > 10.0 and np.ptp(lit) > 60  # light and shade along the normals
    assert np.ptp(even) <= 1  # one colour: a surface facing the camera everywhere


def test_the_picture_shows_the_points_the_measures_count(red_bunny: Path):
    cloud, _ = load_with_appearance(red_bunny)
    assert isinstance(cloud, PointCloud)
    directions = np.array([[0.3, 0.2, 1.0], [1.0, 0.0, 0.0]])
    scene = PointScene(cloud.points, cloud.normals)
    images = scene.id_images(directions, 80)
    assert images.shape == (2, 80, 80) and images.dtype == np.int32 and images.min() == -1
    batches = iter_point_histograms(cloud.points, MeasureSettings(resolution=80),
                                    normals=cloud.normals, view_directions=directions)
    for batch in batches:
        for local in range(batch.n_views):
            view = batch.first_view + local
            span = slice(batch.offsets[local], batch.offsets[local + 1])
            counted = np.zeros(cloud.n_points, dtype=np.int64)
            counted[batch.face_ids[span]] = batch.pixel_counts[span]
            seen = np.bincount(images[view][images[view] >= 0], minlength=cloud.n_points)
            np.testing.assert_array_equal(seen, counted)
    with SoftwareRenderer(size=80, style=RenderStyle(up=Camera().up, margin=None),
                          supersampling=1) as renderer:
        image = renderer.render(cloud, directions[0])[0]
    np.testing.assert_array_equal(~(image == 255).all(axis=2), images[0] >= 0)


def test_the_open3d_engine_refuses_a_cloud_naming_the_software_engine(red_bunny: Path):
    from vptoolkit.pictures.open3d_engine import Renderer

    cloud, _ = load_with_appearance(red_bunny)
    with pytest.raises(InputError, match=r"^bunny: a point cloud; the open3d engine draws "
                                         r"surfaces only, the software engine"):
        Renderer(size=SIZE).render(cloud, FRONT)  # refused before any child starts


def test_render_json_of_a_cloud_is_strict_json_of_the_picture(runner, red_bunny: Path,
                                                               tmp_path: Path):
    output = tmp_path / "bunny.png"
    result = runner.invoke(main, ["render", str(red_bunny), "--view", "0,0.2,1", "--size",
                                  str(SIZE), "--json", "-o", str(output)])
    assert result.exit_code == 0, result.output
    record = strict_json(result.stdout)
    assert record["file"] == str(red_bunny) and record["name"] == "bunny"
    assert record["output"] == str(output) and record["size"] == SIZE
    (view,) = record["views"]
    assert view["label"] == "--view"
    np.testing.assert_allclose(view["direction"], FRONT / np.linalg.norm(FRONT), atol=1e-6)
    pose = np.array(view["pose"])
    cloud, _ = load_with_appearance(red_bunny)
    expected = Camera().look_at(cloud, FRONT, resolution=SIZE).camera_to_world("opencv")[0]
    np.testing.assert_allclose(pose, expected, atol=1e-9)
    intrinsics = np.array(view["intrinsics"])
    assert intrinsics[0, 2] == intrinsics[1, 2] == SIZE / 2
    assert intrinsics[0, 0] > Camera().look_at(cloud, FRONT, resolution=SIZE).focal_px
    image = decode_png(output.read_bytes())  # magnified by the framing: the focal length grew
    assert image.shape == (SIZE, SIZE, 3) and model_mask(image).any()


def test_render_best_view_of_a_cloud(runner, red_bunny: Path, tmp_path: Path):
    output = tmp_path / "best.png"
    result = runner.invoke(main, ["render", str(red_bunny), "--best", "VE", "--views", "24",
                                  "--resolution", "64", "--size", "64", "--up", "auto",
                                  "-o", str(output)])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith(f"wrote {output} (best VE (view ")
    assert model_mask(decode_png(output.read_bytes())).any()


def test_sphere_map_json_of_a_cloud_is_strict_json(runner, red_bunny: Path, tmp_path: Path):
    require_package("matplotlib")
    output = tmp_path / "maps.png"
    result = runner.invoke(main, ["sphere-map", str(red_bunny), "--measure", "VE", "--views",
                                  "24", "--resolution", "48", "--json", "-o", str(output)])
    assert result.exit_code == 0, result.output
    record = strict_json(result.stdout)
    assert record["name"] == "bunny" and record["views"] == 24 and record["resolution"] == 48
    assert list(record["best"]) == ["VE"] and output.is_file()
    best = record["best"]["VE"]
    cloud, _ = load_with_appearance(red_bunny)
    pose = Camera().look_at(cloud, best["direction"], resolution=48).camera_to_world("opencv")
    np.testing.assert_allclose(best["pose"], pose[0], atol=1e-5)
    assert np.array(record["intrinsics"]).shape == (3, 3)


def test_thumbnails_of_a_folder_of_a_mesh_and_a_cloud_draw_both(runner, red_bunny: Path,
                                                                tmp_path: Path):
    from fixtures.meshes import box_mesh

    source = tmp_path / "mixed"
    source.mkdir()
    save_mesh(box_mesh(name="cube"), source / "cube.off")
    (source / "bunny.ply").write_bytes(red_bunny.read_bytes())
    out = tmp_path / "thumbs"
    result = runner.invoke(main, ["thumbnails", str(source), str(out), "--views", "8",
                                  "--resolution", "48", "--size", "48", "--up", "auto"])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("wrote 2 thumbnails")
    for name in ("cube.off.png", "bunny.ply.png"):
        assert model_mask(decode_png((out / name).read_bytes())).any()
    bunny = decode_png((out / "bunny.ply.png").read_bytes()).astype(int)
    mask = model_mask(bunny)
    assert np.median(bunny[..., 0][mask]) > 150 > np.median(bunny[..., 1][mask])  # its red


def test_a_cloud_of_the_duck_in_its_texture_colours_looks_like_the_duck(tmp_path: Path):
    require_package("open3d")
    require_package("PIL")
    import open3d as o3d

    from vptoolkit.geometry import face_normals
    from vptoolkit.pictures.shading import linear_to_srgb, srgb8_to_linear, texture_lookup

    duck, appearance = load_with_appearance(sample_path("Duck.glb"))
    assert appearance.texture is not None and appearance.corner_uv is not None
    texture = srgb8_to_linear(appearance.texture[..., :3])
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(
        duck.vertices[duck.faces].mean(axis=1)))  # a point per face, in the texture's colour
    cloud.normals = o3d.utility.Vector3dVector(face_normals(duck))
    cloud.colors = o3d.utility.Vector3dVector(
        linear_to_srgb(texture_lookup(texture, appearance.corner_uv.mean(axis=1))) / 255.0)
    path = tmp_path / "duck_points.ply"
    assert o3d.io.write_point_cloud(str(path), cloud)
    points, colours = load_with_appearance(path)
    direction = [1.0, 0.7, 1.3]
    with SoftwareRenderer(size=SIZE) as renderer:
        surface = renderer.render(duck, direction, appearance=appearance)[0].astype(int)
        splats = renderer.render(points, direction, appearance=colours)[0].astype(int)
    surface_colour = np.median(surface[model_mask(surface)], axis=0)
    splat_colour = np.median(splats[model_mask(splats)], axis=0)
    assert surface_colour[0] > 150 and surface_colour[2] < 100  # the duck is yellow
    np.testing.assert_allclose(splat_colour, surface_colour, atol=20)
