"""Bad input is one line on stderr and exit status 2: never a traceback, a hang or a bad file.

Each case here could give a traceback, a numpy warning storm, a 60 s hang, a segfault,
a 74 GiB allocation or an output full of inf if its check went missing.
"""

from __future__ import annotations

import io
import json
import logging
import os
import shutil
import subprocess
import sys
import textwrap
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fixtures.environment import require_package
from vptoolkit.cli import main
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings

TETRAHEDRON = "0 0 0\n{s} 0 0\n0 {s} 0\n0 0 {s}\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"


def _run(*args: str) -> tuple[int, str]:
    outcome = CliRunner().invoke(main, [str(arg) for arg in args])
    return outcome.exit_code, outcome.output


def _assert_one_line_bad_input(code: int, output: str, *needles: str) -> None:
    assert code == 2, output
    assert output.count("\n") == 1 and output.startswith("vptool: error: "), output
    assert "Traceback" not in output
    for needle in needles:
        assert needle in output, output


@pytest.fixture()
def huge_tetrahedron(tmp_path: Path) -> Path:
    path = tmp_path / "huge.off"
    path.write_text("OFF\n4 4 0\n" + TETRAHEDRON.format(s="1e300"))
    return path


@pytest.mark.parametrize("command", ["sample", "measures", "render"])
def test_overflowing_coordinates_are_bad_input(huge_tetrahedron: Path, tmp_path: Path,
                                               command: str) -> None:
    output = {"sample": ["-o", tmp_path / "p.npy"], "measures": ["--views", "10"],
              "render": ["--view", "0,0,1", "-o", tmp_path / "p.png"]}[command]
    code, text = _run(command, huge_tetrahedron, *output)
    _assert_one_line_bad_input(code, text, "huge.off", "1e+300", "rescale")
    assert not list(tmp_path.glob("p.*"))


@pytest.mark.parametrize("command", ["sample", "measures"])
def test_underflowing_coordinates_are_bad_input(tmp_path: Path, command: str) -> None:
    tiny = tmp_path / "tiny.off"
    tiny.write_text("OFF\n4 4 0\n" + TETRAHEDRON.format(s="1e-46"))
    output = {"sample": ["-o", tmp_path / "p.npy"], "measures": ["--views", "10"]}[command]
    code, text = _run(command, tiny, *output)
    _assert_one_line_bad_input(code, text, "tiny.off", "1e-46", "underflow", "rescale")
    assert not list(tmp_path.glob("p.*"))


def test_a_build_records_an_underflowing_mesh_as_a_failure(tmp_path: Path) -> None:
    from vptoolkit.dataset.builder.run import build_dataset

    src = tmp_path / "src"
    src.mkdir()
    (src / "tiny.off").write_text("OFF\n4 4 0\n" + TETRAHEDRON.format(s="1e-46"))
    (src / "tet.off").write_text("OFF\n4 4 0\n" + TETRAHEDRON.format(s="1"))
    options = BuildOptions(MeasureSettings(views=20, resolution=32), n_points=100, clean=False)
    result = build_dataset(src, tmp_path / "out", options)
    assert result.n_models == 1
    (failure,) = result.failures
    assert failure["source"] == "tiny.off" and "underflow" in failure["reason"]


@pytest.mark.parametrize("scale", [1e30, 1e-30])
def test_a_mesh_at_1e30_or_1e_minus_30_is_still_fine(scale: float) -> None:
    from vptoolkit.mesh import Mesh

    mesh = Mesh(np.eye(3) * scale, np.array([[0, 1, 2]]))
    assert mesh.vertices.max() == scale


@pytest.mark.parametrize("scale", ["1e-46", "1e300"])
def test_predict_refuses_a_point_file_beyond_float32(tmp_path: Path, scale: str) -> None:
    path = tmp_path / "cloud.npy"
    np.save(path, np.vstack([np.zeros(3), np.eye(3)]) * float(scale))
    code, text = _run("predict", path)
    _assert_one_line_bad_input(code, text, "cloud.npy: ", scale.replace("1e300", "1e+300"),
                               "rescale the point cloud")


def test_meshlab_ascii_ply_with_texture_lists_reads_its_indices_and_warns_once(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    from vptoolkit.io import load_mesh

    header = (
        "ply\nformat ascii 1.0\ncomment VCGLIB generated\nelement vertex 4\n"
        "property float x\nproperty float y\nproperty float z\nelement face 4\n"
        "property list uchar int vertex_indices\nproperty list uchar float texcoord\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n"
        "end_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
    )
    tail = " 6 0.06 0.74 0.1 0.2 0.3 0.4 9 1 1 1 1 1 1 1 1 1\n"  # more values than declared
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    path = tmp_path / "meshlab.ply"
    path.write_text(header + "".join("3 %d %d %d" % face + tail for face in faces))
    with caplog.at_level(logging.WARNING):
        mesh = load_mesh(path)
    assert mesh.faces.tolist() == [list(face) for face in faces]
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1 and warnings[0].startswith("meshlab.ply: ")
    assert "vertex_indices" in warnings[0]


@pytest.mark.parametrize("args, needle", [
    (["--points", "10000000000"], "--points"),
    (["--seed", "-1"], "--seed"),
], ids=["74-GiB-points", "negative-seed"])
def test_sample_options_out_of_range(tmp_path: Path, args: list[str], needle: str) -> None:
    code, text = _run("sample", sample_path("teapot"), "-o", tmp_path / "p.npy", *args)
    _assert_one_line_bad_input(code, text, needle)


def _absurd_npy() -> bytes:
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f8", "fortran_order": False, "shape": (400_000_000_000, 4, 3)}
    )
    return header.getvalue() + bytes(96)


def test_predictions_that_are_not_npy_or_claim_terabytes(small_build: Path, tmp_path: Path) -> None:
    not_npy = tmp_path / "p.npz"
    with zipfile.ZipFile(not_npy, "w") as archive:
        archive.writestr("names.txt", "chair")
        archive.writestr("directions.npy", b"not an array")
    code, text = _run("evaluate", not_npy, "--dataset", small_build)
    _assert_one_line_bad_input(code, text, "p.npz", "names.txt", "not a .npy array")

    absurd = tmp_path / "p.npy"
    absurd.write_bytes(_absurd_npy())
    code, text = _run("evaluate", absurd, "--dataset", small_build)
    _assert_one_line_bad_input(code, text, "p.npy", "(400000000000, 4, 3)")
    code, text = _run("predict", absurd)
    _assert_one_line_bad_input(code, text, "p.npy", "but the file holds 96")


@pytest.mark.parametrize("address", ["not a url", "http://127.0.0.1:8787"])
def test_a_scheduler_that_is_not_a_dask_address_is_refused_at_once(tmp_path: Path,
                                                                   address: str) -> None:
    src = tmp_path / "src"
    src.mkdir()
    (src / "teapot.stl").write_bytes(sample_path("teapot").read_bytes())
    code, text = _run("build-dataset", src, tmp_path / "out", "--no-clean", "--scheduler", address)
    _assert_one_line_bad_input(code, text, "scheduler", "tcp://host:port")
    assert not (tmp_path / "out").exists()


def test_train_threads_beyond_the_machine(small_build: Path, tmp_path: Path) -> None:
    code, text = _run("train", small_build, "-o", tmp_path / "m", "--threads", "100000")
    _assert_one_line_bad_input(code, text, "--threads")


def test_a_checkpoint_whose_json_disagrees_with_its_weights(tmp_path: Path) -> None:
    require_package("torch")
    from vptoolkit.learn import model as M
    from vptoolkit.learn.config import LevelConfig, ModelConfig

    small = ModelConfig(levels=(
        LevelConfig(grid_level=3, radius=1 / 8, max_neighbours=16, channels=8,
                    neighbourhood="cell"),
    ))
    M.save_model(M.ViewpointNet(small), tmp_path / "small.safetensors")
    M.save_model(M.ViewpointNet(), tmp_path / "big.safetensors")
    (tmp_path / "big.safetensors").replace(tmp_path / "small.safetensors")
    code, text = _run("predict", "-m", tmp_path / "small.safetensors", sample_path("teapot"))
    _assert_one_line_bad_input(code, text, "small.safetensors: weights do not match")


# Runs each checkpoint of a test in a child process limited to 3 GiB of address space, so a
# configuration that asks for terabytes fails there instead of exhausting the machine.
_LIMITED_PREDICT = textwrap.dedent("""
    import json, resource, sys
    resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))
    from click.testing import CliRunner
    from vptoolkit.cli import main
    cloud, *models = sys.argv[1:]
    for model in models:
        outcome = CliRunner().invoke(main, ["predict", cloud, "--model", model])
        print(json.dumps([outcome.exit_code, outcome.output]))
""")

_HUGE_CONFIGS = {
    "n-points": lambda config: config.update(input={"n_points": 10**9, "n_fps": 10**9}),
    "latent-channels": lambda config: config["architecture"].update(latent_channels=200_000_000),
    "levels-a-string": lambda config: config["architecture"].update(levels="abc"),
    "many-parameters": lambda config: config["architecture"].update(
        head_channels=[4096] * 16, kernel_size=256, global_kernel_size=256, kernel_hidden=256),
    "input-a-list": lambda config: config.update(input=[1, 2]),
    "format-version": lambda config: config.update(format_version=99),
}
_HUGE_NEEDLES = {
    "n-points": "input.n_points", "latent-channels": "latent_channels",
    "levels-a-string": "levels", "many-parameters": "parameters", "input-a-list": "input",
    "format-version": "format_version",
}


def test_checkpoint_configs_that_ask_for_too_much_are_one_line(tmp_path: Path) -> None:
    require_package("torch")
    from vptoolkit.learn.checkpoint import PRETRAINED

    cloud = tmp_path / "cloud.npy"
    np.save(cloud, np.random.default_rng(0).normal(size=(2000, 3)))
    models = []
    for case, change in _HUGE_CONFIGS.items():
        model = tmp_path / case
        shutil.copytree(PRETRAINED, model)
        config = json.loads((model / "model.json").read_text())
        change(config)
        (model / "model.json").write_text(json.dumps(config))
        models.append(model)
    done = subprocess.run([sys.executable, "-c", _LIMITED_PREDICT, cloud, *models],
                          capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert done.returncode == 0, done.stderr[-2000:]
    outcomes = [json.loads(line) for line in done.stdout.splitlines()]
    for case, (code, text) in zip(_HUGE_CONFIGS, outcomes):
        _assert_one_line_bad_input(code, text, "model.json: ", _HUGE_NEEDLES[case])
    assert len(outcomes) == len(_HUGE_CONFIGS)


_LAX_CONFIGS = {
    "no-fps-points": (lambda config: config["input"].update(n_fps=0), "input.n_fps"),
    "no-architecture": (lambda config: config.pop("architecture"), "architecture: missing"),
    "measure-order": (lambda config: config.update(measures=["VR", "VE", "VKL", "VMI"]),
                      "measure order"),
}


@pytest.mark.parametrize("case", list(_LAX_CONFIGS))
def test_checkpoint_configs_that_leave_out_or_reorder_are_bad_input(tmp_path: Path,
                                                                    case: str) -> None:
    require_package("torch")
    from vptoolkit.learn.checkpoint import PRETRAINED

    cloud = tmp_path / "cloud.npy"
    np.save(cloud, np.random.default_rng(0).normal(size=(2000, 3)))
    model = tmp_path / case
    shutil.copytree(PRETRAINED, model)
    config = json.loads((model / "model.json").read_text())
    change, needle = _LAX_CONFIGS[case]
    change(config)
    (model / "model.json").write_text(json.dumps(config))
    code, text = _run("predict", cloud, "--model", model)
    _assert_one_line_bad_input(code, text, "model.json: ", needle)


@pytest.mark.parametrize("weight", [float("nan"), float("inf"), 0.0], ids=["nan", "inf", "zero"])
def test_a_checkpoint_with_broken_weights_predicts_nothing(tmp_path: Path, weight: float) -> None:
    require_package("torch")
    import torch

    from vptoolkit.learn import model as M
    from vptoolkit.learn.config import LevelConfig, ModelConfig

    small = ModelConfig(latent_channels=16, head_channels=(8,), levels=(
        LevelConfig(grid_level=3, radius=1 / 8, max_neighbours=16, channels=8,
                    neighbourhood="cell"),
    ))
    network = M.ViewpointNet(small)
    with torch.no_grad():
        for parameter in network.parameters():
            parameter.fill_(weight)
    M.save_model(network, tmp_path / "broken")
    cloud = tmp_path / "cloud.npy"
    np.save(cloud, np.random.default_rng(0).normal(size=(2000, 3)))
    code, text = _run("predict", "-m", tmp_path / "broken", cloud, "-o", tmp_path / "p.npz")
    needle = "model.safetensors: weight " if weight != 0.0 else "broken: the network answers"
    assert "Traceback" not in text
    _assert_one_line_bad_input(code, text.split("\r")[-1].splitlines()[-1] + "\n", needle)
    assert not (tmp_path / "p.npz").exists()


@pytest.mark.parametrize("reader", ["model.json", "categories.json"])
def test_deeply_nested_checkpoint_json_is_one_line(tmp_path: Path, reader: str) -> None:
    require_package("torch")
    from vptoolkit.learn.checkpoint import PRETRAINED

    model = tmp_path / "m"
    if reader == "model.json":
        shutil.copytree(PRETRAINED, model)
    else:
        model.mkdir()
    (model / reader).write_text("[" * 200_000)
    cloud = tmp_path / "cloud.npy"
    np.save(cloud, np.random.default_rng(0).normal(size=(100, 3)))
    code, text = _run("predict", "-m", model, cloud)
    _assert_one_line_bad_input(code, text, f"{reader}: ", "nested too deeply")


def test_the_json_reader_turns_every_decoding_failure_into_one_line(tmp_path: Path) -> None:
    from vptoolkit.errors import InputError
    from vptoolkit.files import parse_json, read_json_file

    for bad in ("[" * 200_000, b"\xff{}", "{", "1" * 5000, ""):
        with pytest.raises(InputError, match=r"^x\.json: not UTF-8 JSON \(") as caught:
            parse_json(bad, "x.json")
        assert "\n" not in str(caught.value)
    state = tmp_path / "model.last.json"
    state.write_text('{"a": ' * 200_000)
    nested = r"^model\.last\.json: not UTF-8 JSON \(nested too deeply\)$"
    with pytest.raises(InputError, match=nested):
        read_json_file(state)
    with pytest.raises(InputError, match=r"^folder: not a regular file$"):
        read_json_file(tmp_path, "folder")


def test_a_deeply_nested_build_record_is_one_line(tmp_path: Path) -> None:
    from vptoolkit.dataset.builder.run import build_dataset
    from vptoolkit.dataset.builder.staging import STAGING_DIR
    from vptoolkit.errors import InputError

    src = tmp_path / "src"
    src.mkdir()
    (src / "tet.off").write_text("OFF\n4 4 0\n" + TETRAHEDRON.format(s="1"))
    staging = tmp_path / "out" / STAGING_DIR
    staging.mkdir(parents=True)
    (staging / "build.json").write_text("[" * 200_000)
    with pytest.raises(InputError, match="build.json: unreadable build record .*nested too deeply"):
        build_dataset(src, tmp_path / "out",
                      BuildOptions(MeasureSettings(views=20, resolution=32), clean=False))


def test_option_errors_are_one_line_like_every_other_error() -> None:
    code, text = _run("measures", sample_path("teapot"), "--views", "0")
    _assert_one_line_bad_input(code, text, "measures: ", "--views")
    code, text = _run("no-such-command")
    _assert_one_line_bad_input(code, text, "no-such-command")
    code, text = _run("--help")
    assert code == 0 and "Usage:" in text


def test_a_symlink_loop_is_named_as_such(tmp_path: Path) -> None:
    (tmp_path / "a.off").symlink_to(tmp_path / "b.off")
    (tmp_path / "b.off").symlink_to(tmp_path / "a.off")
    code, text = _run("sample", tmp_path / "a.off", "-o", tmp_path / "p.npy")
    _assert_one_line_bad_input(code, text, "symbolic link loop")
    assert "does not exist" not in text


def test_build_into_a_symlink_loop_is_one_line(tmp_path: Path) -> None:
    source = tmp_path / "src"
    source.mkdir()
    (source / "tet.off").write_text("OFF\n4 4 0\n" + TETRAHEDRON.format(s="1"))
    (tmp_path / "loop").symlink_to(tmp_path / "loop")
    for out in (tmp_path / "loop", tmp_path / "loop" / "sub"):
        code, text = _run("build-dataset", source, out, "--views", "10")
        _assert_one_line_bad_input(code, text, f"{out}: symbolic link loop")


def test_a_licence_table_with_a_huge_cell_is_one_line(small_build: Path, tmp_path: Path) -> None:
    table = tmp_path / "licenses.csv"
    table.write_text("name,license,author,url\nm,mit," + "a" * 200_000 + ",u\n")
    code, text = _run("pack", small_build, tmp_path / "rel", "--licenses", table)
    _assert_one_line_bad_input(code, text, "licenses.csv: line 2 is not a CSV row")
    assert not (tmp_path / "rel").exists()


@pytest.mark.parametrize("cell", ["MIT\x1b[2J", "MIT\tBSD", '"MIT\nBSD"', "MIT\x85"],
                         ids=["escape", "tab", "line-break", "c1-control"])
def test_a_licence_table_with_control_characters_is_one_line(small_build: Path, tmp_path: Path,
                                                             cell: str) -> None:
    table = tmp_path / "licenses.csv"
    table.write_text(f"name,license,author,url\nm,{cell},a,u\n", encoding="utf-8")
    code, text = _run("pack", small_build, tmp_path / "rel", "--licenses", table)
    _assert_one_line_bad_input(code, text, "licenses.csv: line 2: the license cell holds the "
                               "control character U+")
    assert not (tmp_path / "rel").exists()


def test_sphere_map_inputs_that_cannot_be_drawn(tmp_path: Path) -> None:
    views = np.eye(3)
    cases = {
        "nan.npz": {"views": views, "normalized": np.full((3, 4), np.nan)},
        "names.npz": {"views": views, "normalized": np.ones((3, 4)),
                      "measures": np.array(["A", "B", "C", "D"])},
        "shape.npz": {"views": views, "normalized": np.ones((5, 4))},
    }
    for file_name, members in cases.items():
        np.savez(tmp_path / file_name, **members)
        code, text = _run("sphere-map", tmp_path / file_name, "-o", tmp_path / "m.png")
        _assert_one_line_bad_input(code, text, f"{file_name}: ")
    assert not (tmp_path / "m.png").exists()


def test_a_short_glb_buffer_is_named(tmp_path: Path) -> None:
    data = sample_path("Duck").read_bytes()
    short = tmp_path / "short.glb"
    short.write_bytes(data[: len(data) // 2])
    code, text = _run("sample", short, "-o", tmp_path / "p.npy")
    _assert_one_line_bad_input(code, text, "short.glb: ")
    assert "no details" not in text


@pytest.mark.parametrize("scale", [1e30, 1e-12])
def test_raycast_measures_a_mesh_at_any_scale_like_the_rasteriser(scale: float) -> None:
    require_package("open3d")
    from vptoolkit.io import load_mesh
    from vptoolkit.measures.quality import compute_view_quality
    from vptoolkit.mesh import Mesh

    teapot = load_mesh(sample_path("teapot"))
    scaled = Mesh(teapot.vertices * scale, teapot.faces, name="teapot")
    settings = MeasureSettings(views=20, resolution=64)
    raster = compute_view_quality(scaled, settings).raw
    raycast = compute_view_quality(scaled, replace(settings, backend="raycast")).raw
    np.testing.assert_allclose(raycast, raster, rtol=0.01)


def test_train_on_too_few_points_says_how_many_it_needs(small_build: Path, tmp_path: Path) -> None:
    code, text = _run("train", small_build, "-o", tmp_path / "m", "--epochs", "1")
    _assert_one_line_bad_input(code, text, "200 points", "at least 1024")


@pytest.mark.parametrize("resume", [False, True], ids=["fresh", "resume"])
def test_train_into_an_existing_run_suggests_cli_flags(small_build: Path, tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch,
                                                      resume: bool) -> None:
    import vptoolkit.learn.train as train
    import vptoolkit.points as points
    from vptoolkit.errors import ExistingRunError

    def refuse(*args: object, **kwargs: object) -> None:
        raise ExistingRunError("m: already holds a training run (model.safetensors); pass "
                               "resume=True to continue it or overwrite=True to replace it")

    monkeypatch.setattr(points, "N_FPS_POINTS", 100)
    monkeypatch.setattr(train, "train_model", refuse)
    code, text = _run("train", small_build, "-o", tmp_path / "m", *(["--resume"] if resume else []))
    _assert_one_line_bad_input(code, text, "nothing to resume from" if resume else "add --resume")
    assert "resume=True" not in text and "overwrite=True" not in text


@pytest.mark.parametrize("points", [
    np.zeros((1, 3)), np.ones((50, 6)), np.array([[0, 0, 0], [1, 2, 3]]),
    np.outer(np.linspace(-1, 1, 5000), [0.3, -2.0, 1.1]) + [5, 6, 7],
], ids=["one-point", "identical-points", "two-points", "collinear-points"])
def test_predict_refuses_a_cloud_without_extent(tmp_path: Path, points: np.ndarray) -> None:
    path = tmp_path / "cloud.npy"
    np.save(path, points.astype(np.float32))
    code, text = _run("predict", path)
    _assert_one_line_bad_input(code, text, "cloud.npy: ", "extent")


def test_build_dataset_refuses_remesh_without_cleaning(tmp_path: Path) -> None:
    src = tmp_path / "src"
    src.mkdir()
    shutil.copy(sample_path("mug.obj"), src / "mug.obj")
    code, text = _run("build-dataset", src, tmp_path / "out", "--remesh", "--no-clean")
    _assert_one_line_bad_input(code, text, "--remesh", "--no-clean")
    assert "clean=True" not in text and not (tmp_path / "out").exists()
    from vptoolkit.errors import InputError

    with pytest.raises(InputError, match="remesh: .* needs clean=True"):
        BuildOptions(clean=False, remesh=True)


def test_train_names_its_options_not_the_python_arguments(small_build: Path, tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    import vptoolkit.learn.train as train
    import vptoolkit.points as points
    from vptoolkit.learn.splits import select_models

    class NoModels:
        path = Path("dataset.zarr")

        def split(self, name: str) -> list[str]:
            return []

    def empty_validation(*args: object, **kwargs: object) -> None:
        select_models(NoModels(), "test", None, None, "val_split")  # type: ignore[arg-type]

    monkeypatch.setattr(points, "N_FPS_POINTS", 1)
    monkeypatch.setattr(train, "train_model", empty_validation)
    code, text = _run("train", small_build, "-o", tmp_path / "m", "--val-split", "test")
    _assert_one_line_bad_input(code, text, "--val-split: split 'test' of dataset.zarr has no "
                               "models; choose another with --val-split")
    assert "val_split" not in text


def test_predict_with_a_per_category_folder_asks_for_the_option(tmp_path: Path) -> None:
    require_package("torch")
    from vptoolkit.learn.checkpoint import PRETRAINED
    from vptoolkit.learn.predict import CATEGORY_MODELS_FORMAT

    folder = tmp_path / "per"
    shutil.copytree(PRETRAINED, folder / "mug")
    (folder / "categories.json").write_text(json.dumps(
        {"format": CATEGORY_MODELS_FORMAT, "categories": {"mug": "mug"}}))
    code, text = _run("predict", sample_path("mug.obj"), "--model", folder)
    last = text.splitlines()[-1]  # after the progress bar
    assert code == 2 and "Traceback" not in text, text
    assert last.startswith("vptool: error: mug: ") and "pass --category" in last
    assert "category=" not in text


def test_thumbnails_refuses_a_model_with_a_view_set_by_its_options(tmp_path: Path) -> None:
    src = tmp_path / "src"
    src.mkdir()
    shutil.copy(sample_path("mug.obj"), src / "mug.obj")
    code, text = _run("thumbnails", src, tmp_path / "out", "--model", "default",
                      "--view-set", "2")
    _assert_one_line_bad_input(code, text, "--view-set: --model gives one view per mesh")
    assert "view_set" not in text and "predictor" not in text


def test_a_default_file_in_the_working_directory_does_not_shadow_the_bundled_network(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    require_package("torch")
    from vptoolkit.learn.checkpoint import PRETRAINED, checkpoint_paths

    monkeypatch.chdir(tmp_path)
    (tmp_path / "default").write_text("not a checkpoint")
    (tmp_path / "points").write_text("not a checkpoint")
    cloud = tmp_path / "cloud.npy"
    np.save(cloud, np.random.default_rng(0).normal(size=(2000, 3)))
    assert checkpoint_paths("default")[0] == PRETRAINED / "model.safetensors"
    assert checkpoint_paths("points")[0] == PRETRAINED / "points" / "model.safetensors"
    code, text = _run("predict", sample_path("mug.obj"), "--model", "default")
    assert code == 0, text
    code, text = _run("predict", cloud, "--model", "points")
    assert code == 0, text
    # the default network reads face areas, which a point file lacks: the bundled network of
    # coordinates answers it, not a file named "points" in the working directory
    code, text = _run("predict", cloud, "--model", "default")
    assert code == 0, text
    code, text = _run("predict", cloud, "--model", "./default")
    assert code == 2 and "default/model.json" in text, text


@pytest.mark.parametrize("folder", ["../outside", "/abs/model", "mug/../../x", ""],
                         ids=["parent", "absolute", "climbing", "empty"])
def test_a_per_category_index_pointing_outside_the_model_folder_is_refused(
        tmp_path: Path, folder: str) -> None:
    require_package("torch")
    from vptoolkit.learn.checkpoint import PRETRAINED
    from vptoolkit.learn.predict import CATEGORY_MODELS_FORMAT

    shutil.copytree(PRETRAINED, tmp_path / "outside")  # a loadable network out there
    model = tmp_path / "per"
    model.mkdir()
    (model / "categories.json").write_text(json.dumps(
        {"format": CATEGORY_MODELS_FORMAT, "categories": {"mug": folder}}))
    code, text = _run("predict", sample_path("mug.obj"), "--model", model, "--category", "mug")
    _assert_one_line_bad_input(code, text, f"{model / 'categories.json'}: category 'mug' names",
                               "not a folder inside the model folder")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
@pytest.mark.parametrize("command", [
    ["predict", "-m", "unoccluded", "{fifo}"],
    ["predict", "{fifo}"],
    ["pack", "{folder}", "{folder}/rel", "--licenses", "{fifo}"],
    ["build-dataset", "{folder}", "{folder}/out", "--splits", "{fifo}"],
    ["build-dataset", "{folder}", "{folder}/out", "--splits", "{fifo}", "--dry-run"],
    ["sphere-map", "{fifo}", "-o", "{folder}/map.png"],
    ["evaluate", "{fifo}", "--dataset", "{folder}"],
], ids=["predict-unoccluded", "predict", "pack-licenses", "build-splits", "dry-run-splits",
        "sphere-map", "evaluate"])
def test_a_named_pipe_nobody_writes_is_refused_not_waited_on(tmp_path: Path,
                                                             command: list[str]) -> None:
    fifo = tmp_path / "pipe.npy"
    os.mkfifo(fifo)  # reading it would block for ever
    code, text = _run(*(part.format(fifo=fifo, folder=tmp_path) for part in command))
    _assert_one_line_bad_input(code, text, f"{fifo}: not a regular file")
