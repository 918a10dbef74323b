"""vptool render, sphere-map, report and thumbnails: thin commands over the picture modules;
sphere-map of other measures than the paper's four."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fixtures.commands import SMALL_DRAW
from fixtures.environment import require_package
from fixtures.meshes import box_mesh
from fixtures.pictures import decode_png, model_mask, read_png, started_renderer
from vptoolkit.cli import main
from vptoolkit.io import save_mesh
from vptoolkit.measures.registry import all_measures
from vptoolkit.samples import sample_path


@pytest.fixture(scope="module")
def renderer_available():
    """Skip (or fail in CI) where no renderer can start; the commands start their own."""
    yield from started_renderer(16)


@pytest.fixture()
def cube_file(tmp_path: Path) -> Path:
    path = tmp_path / "cube.off"
    save_mesh(box_mesh(name="cube"), path)
    return path


def one_error_line(result) -> str:
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("vptool: error: ")
    return lines[0]


@pytest.mark.renderer
@pytest.mark.parametrize("how", [["--view", "1,1,1"], ["--best", "vr", "--views", "40",
                                                        "--resolution", "64"]],
                         ids=["view", "best"])
def test_render_writes_a_picture_of_the_mesh(renderer_available, runner, cube_file, tmp_path, how):
    output = tmp_path / "cube.png"
    result = runner.invoke(main, ["render", str(cube_file), *how, "--size", "64",
                                  "-o", str(output)])
    assert result.exit_code == 0, result.output
    image = decode_png(output.read_bytes())
    assert image.shape == (64, 64, 3) and model_mask(image).any() and not model_mask(image).all()
    assert result.stdout.startswith(f"wrote {output} (")


@pytest.mark.renderer
def test_render_from_the_bundled_network(renderer_available, runner, tmp_path):
    require_package("torch")
    output = tmp_path / "teapot.png"
    result = runner.invoke(main, ["render", str(sample_path("teapot.stl")), "--model", "default",
                                  "--measure", "VKL", "--size", "48", "-o", str(output)])
    assert result.exit_code == 0, result.output
    assert "predicted VKL" in result.stdout
    assert model_mask(decode_png(output.read_bytes())).any()


@pytest.mark.parametrize("margin", [0.0, 0.15])
def test_render_draws_the_duck_in_its_texture_framed_to_the_margin(runner, tmp_path, margin):
    require_package("PIL")
    output = tmp_path / "duck.png"
    result = runner.invoke(main, ["render", str(sample_path("Duck.glb")), "--view", "1,0.7,1.3",
                                  "--size", "80", "--margin", str(margin), "-o", str(output)])
    assert result.exit_code == 0, result.output
    image = decode_png(output.read_bytes())
    rows, columns = np.nonzero((image < 255).any(axis=2))
    border = round(margin * 80)
    gaps = [columns.min() - border, rows.min() - border, 79 - border - columns.max(),
            79 - border - rows.max()]
    assert 0 <= min(gaps) <= 2, gaps
    red, green, blue = image[(image < 250).any(axis=2)].astype(float).mean(axis=0)
    assert red > 150 and green > 120 and blue < 80


@pytest.mark.parametrize("arguments, message", [
    ([], "exactly one of --view, --best, --model or --view-set"),
    (["--view", "1,0,0", "--margin", "0.6"], "--margin"),
    (["--view", "1,0,0", "--best", "VE"], "exactly one of"),
    (["--view", "1,2"], "--view: expected three numbers x,y,z"),
    (["--view", "0,0,0"], "--view"),
], ids=["none", "two", "wide-margin", "short-view", "zero-view"])
def test_render_rejects_bad_choices_in_one_line(runner, cube_file, tmp_path, arguments, message):
    result = runner.invoke(main, ["render", str(cube_file), *arguments,
                                  "-o", str(tmp_path / "x.png")])
    assert result.exit_code == 2
    assert message in one_error_line(result)
    assert not (tmp_path / "x.png").exists()


def test_render_without_a_vulkan_driver_exits_2(runner, cube_file, tmp_path, monkeypatch):
    require_package("open3d")
    for variable in ("VK_ICD_FILENAMES", "VK_DRIVER_FILES"):
        monkeypatch.setenv(variable, "/nonexistent/vptoolkit-test-icd.json")
    result = runner.invoke(main, ["render", str(cube_file), "--view", "0,0,1", "--size", "32",
                                  "--engine", "open3d", "-o", str(tmp_path / "x.png")])
    assert result.exit_code == 2
    assert "could not start" in one_error_line(result)
    assert not (tmp_path / "x.png").exists()


def test_sphere_map_marks_the_best_view(runner, cube_file, tmp_path):
    require_package("matplotlib")
    quality = tmp_path / "cube.npz"
    measured = runner.invoke(main, ["measures", str(cube_file), "--views", "60", "--resolution",
                                    "48", "-o", str(quality)])
    assert measured.exit_code == 0, measured.output
    output = tmp_path / "map.png"
    result = runner.invoke(main, ["sphere-map", str(quality), "--measure", "vmi",
                                  "--predicted", "0,0,1", "-o", str(output)])
    assert result.exit_code == 0, result.output
    import matplotlib.image

    pixels = matplotlib.image.imread(output)
    assert pixels.std() > 0.05
    red = (pixels[..., 0] > 0.8) & (pixels[..., 1] < 0.25) & (pixels[..., 2] < 0.25)
    assert red.any()  # the best-view star


def test_sphere_map_of_a_wrong_file_exits_2(runner, tmp_path):
    bad = tmp_path / "bad.npz"
    np.savez(bad, something=np.zeros(3))
    result = runner.invoke(main, ["sphere-map", str(bad), "-o", str(tmp_path / "map.png")])
    assert result.exit_code == 2
    assert "bad.npz: lacks views, normalized" in one_error_line(result)


def test_report_without_pictures(runner, tiny_dataset, tmp_path):
    require_package("matplotlib")
    result = runner.invoke(main, ["report", str(tiny_dataset), "--no-pictures", "-o",
                                  str(tmp_path / "report")])
    assert result.exit_code == 0, result.output
    page = (tmp_path / "report" / "index.html").read_text()
    assert page.count('class="card"') == 4
    assert len(list((tmp_path / "report" / "maps").glob("*.png"))) == 4


def test_report_of_an_unknown_split_exits_2(runner, tiny_dataset, tmp_path):
    result = runner.invoke(main, ["report", str(tiny_dataset), "--split", "everything",
                                  "-o", str(tmp_path / "report")])
    assert result.exit_code == 2


@pytest.mark.renderer
def test_thumbnails_skip_bad_files_and_exit_1(renderer_available, runner, cube_file, tmp_path):
    (cube_file.parent / "broken.off").write_text("OFF\n3 1 0\n0 0 0\n")
    out = tmp_path / "thumbs"
    result = runner.invoke(main, ["thumbnails", str(cube_file.parent), str(out), "--size", "48",
                                  "--views", "40", "--resolution", "48", "--workers", "1"])
    assert result.exit_code == 1, result.output
    assert "wrote 1 thumbnails" in result.stdout
    assert "skipped broken.off: broken.off: " in result.stderr
    assert model_mask(decode_png((out / "cube.off.png").read_bytes())).any()
    index = json.loads((out / "thumbnails.json").read_text())
    assert [failure["source"] for failure in index["failures"]] == ["broken.off"]


def test_render_view_set_draws_a_contact_sheet(runner, tmp_path):
    from fixtures.pictures import read_png

    output = tmp_path / "sheet.png"
    result = runner.invoke(main, ["render", str(sample_path("teapot.stl")), "--view-set", "3",
                                  *SMALL_DRAW, "--size", "64", "-o", str(output)])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith(f"wrote {output} (3 views, views [")
    sheet = read_png(output)
    assert sheet.shape[1] == 3 * 64 + 4 * 6  # three tiles and four gaps in a row
    assert sheet.shape[0] > 64 and (sheet[..., :3] < 200).any()


def test_thumbnails_view_set_writes_a_sheet_per_mesh(runner, tmp_path):
    import shutil

    from fixtures.pictures import read_png

    source = tmp_path / "models"
    source.mkdir()
    shutil.copy(sample_path("mug.obj"), source / "mug.obj")
    (source / "broken.off").write_text("OFF\n3 1 0\n0 0 0\n")
    out = tmp_path / "sheets"
    result = runner.invoke(main, ["thumbnails", str(source), str(out), "--view-set", "2",
                                  "--size", "48", *SMALL_DRAW, "--workers", "1"])
    assert result.exit_code == 1, result.output  # the broken file is skipped
    assert read_png(out / "mug.obj.png").shape[1] == 2 * 48 + 3 * 6
    record = json.loads((out / "thumbnails.json").read_text())["thumbnails"][0]
    assert len(record["direction"]) == 2 and record["label"].startswith("view set of 2")


# --- sphere-map of other measures ---------------------------------------------------------


MUG = str(sample_path("mug.obj"))
SMALL = ["--views", "60", "--resolution", "32"]


@pytest.fixture(scope="module")
def three(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``vptool measures mug.obj --measures NVT,SL,MD -o mug.npz``."""
    from click.testing import CliRunner

    out = tmp_path_factory.mktemp("three") / "mug.npz"
    result = CliRunner().invoke(main, ["measures", MUG, "--measures", "NVT,SL,MD", *SMALL,
                                       "-o", str(out)])
    assert result.exit_code == 0, result.output
    return out


def test_an_npz_of_three_measures_draws_them_all_or_one(runner, three, tmp_path):
    require_package("matplotlib")
    grid = tmp_path / "grid.png"
    result = runner.invoke(main, ["sphere-map", str(three), "--measures", "all", "-o", str(grid)])
    assert result.exit_code == 0, result.output
    assert read_png(grid).shape[:2] == (340, 1200)
    single = tmp_path / "sl.png"
    result = runner.invoke(main, ["sphere-map", str(three), "--measure", "sl", "--dpi", "50",
                                  "-o", str(single)])
    assert result.exit_code == 0, result.output
    assert read_png(single).shape[:2] == (270, 320)
    first = runner.invoke(main, ["sphere-map", str(three), "-o", str(tmp_path / "first.png")])
    assert first.exit_code == 0, first.output


def test_all_measures_of_a_mesh_on_one_figure(runner, tmp_path):
    require_package("matplotlib")
    out = tmp_path / "all.png"
    result = runner.invoke(main, ["sphere-map", MUG, "--measures", "all", *SMALL, "--dpi", "40",
                                  "-o", str(out)])
    assert result.exit_code == 0, result.output
    names = list(all_measures())
    assert result.stdout.strip() == f"wrote {out} ({', '.join(names)})"
    rows = -(-len(names) // 4)
    assert read_png(out).shape[:2] == (round(40 * 3.4 * rows), 480)
    one = tmp_path / "ins.png"
    result = runner.invoke(main, ["sphere-map", MUG, "--measure", "ins", *SMALL, "-o", str(one)])
    assert result.exit_code == 0, result.output
    assert read_png(one).shape[:2] == (540, 640) and "(INS)" in result.stdout


@pytest.mark.parametrize(("arguments", "message"), [
    (["--measures", "VE,XX"], "--measures: unknown measure 'XX'"),
    (["--measure", "XX"], "--measure: unknown measure 'XX'"),
    (["--measure", "VE", "--measures", "all"], "give --measure or --measures, not both"),
    (["--measures", "VE"], "mug.npz: measure: no column for measure 'VE'; the quality has "
                           "NVT, SL, MD"),
    (["--measure", "vkl"], "mug.npz: measure: no column for measure 'VKL'"),
], ids=["unknown-list", "unknown-one", "both", "unrecorded-list", "unrecorded-one"])
def test_bad_measures_are_one_line(runner, three, tmp_path, arguments, message):
    out = tmp_path / "map.png"
    result = runner.invoke(main, ["sphere-map", str(three), *arguments, "-o", str(out)])
    assert result.exit_code == 2
    assert message in one_error_line(result)
    assert not out.exists()


def test_thumbnails_of_a_list_resume_and_size_themselves(runner, tmp_path):
    import shutil

    source = tmp_path / "models"
    (source / "a").mkdir(parents=True)
    (source / "b").mkdir()
    shutil.copy(sample_path("mug.obj"), source / "a" / "cup.obj")
    shutil.copy(sample_path("teapot.stl"), source / "b" / "cup.obj.stl")
    listing = source / "models.txt"
    listing.write_text("a/cup.obj\nb/cup.obj.stl\n")
    out = tmp_path / "thumbs"
    small = ["--size", "32", "--views", "12", "--resolution", "32"]
    plan = runner.invoke(main, ["thumbnails", f"@{listing}", str(out), *small, "--dry-run"])
    assert plan.exit_code == 0, plan.output
    assert plan.stdout.startswith("2 files (") and not out.exists()
    first = runner.invoke(main, ["thumbnails", f"@{listing}", str(out), *small, "--workers", "2"])
    assert first.exit_code == 0, first.output
    assert first.stdout.startswith(f"wrote 2 thumbnails to {out} (2 in all), 0 skipped")
    assert (out / "a" / "cup.obj.png").is_file() and (out / "b" / "cup.obj.stl.png").is_file()
    again = runner.invoke(main, ["thumbnails", f"@{listing}", str(out), *small])
    assert again.stdout.startswith(f"wrote 0 thumbnails to {out} (2 in all), 0 skipped")


def test_sphere_map_of_a_point_cloud(runner, tmp_path):
    from vptoolkit.io import load_mesh
    from vptoolkit.points import sample_surface

    sample = sample_surface(load_mesh(sample_path("torus.STL")), 3000, seed=0)
    np.savetxt(tmp_path / "torus.xyz", sample.points)
    out = tmp_path / "maps.png"
    result = runner.invoke(main, ["sphere-map", str(tmp_path / "torus.xyz"), "--measures",
                                  "paper", "--views", "60", "--resolution", "64", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert result.stdout.strip() == f"wrote {out} (VE, VR, VKL, VMI)"
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
