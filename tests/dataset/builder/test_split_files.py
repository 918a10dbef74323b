"""Published splits from a file: the CSV and small.txt readers, and ``build-dataset --splits``."""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import pytest
from click.testing import CliRunner

from fixtures.paths import REPO
from vptoolkit.cli import main
from vptoolkit.dataset.builder.options import BuildOptions, SplitFile
from vptoolkit.dataset.builder.run import build_dataset
from vptoolkit.dataset.builder.split_files import read_split_file
from vptoolkit.dataset.store.reader import open_store
from vptoolkit.errors import InputError
from vptoolkit.samples import SAMPLE_SPLITS, sample_names, sample_path
from vptoolkit.settings import MeasureSettings

pytest.importorskip("zarr")

TINY = BuildOptions(MeasureSettings(views=20, resolution=16), n_points=16, clean=False)


def source(root: Path, folder: str = "") -> Path:
    """Four sample meshes: kitchen/{mug,bottle}, furniture/{table,lego} (under ``folder``)."""
    for category, names in (("kitchen", ("mug", "bottle")), ("furniture", ("table", "lego"))):
        (root / category / folder).mkdir(parents=True)
        for name in names:
            shutil.copy(sample_path(f"{name}.obj"), root / category / folder / f"{name}.obj")
    return root


def stored_splits(path: Path) -> dict[str, str]:
    with open_store(path) as store:
        return {record["name"]: record["split"] for record in store.models()}


def test_csv_and_small_txt_are_read(tmp_path):
    csv = tmp_path / "splits.csv"
    csv.write_text("name,split\nmug,train\nbottle,val\ntable,validation\nlego,TEST\n")
    assert read_split_file(csv) == {"mug": "train", "bottle": "validation",
                                    "table": "validation", "lego": "test"}
    small = tmp_path / "small.txt"
    small.write_text("".join(f"objfiles/{'chair' if i % 2 else 'lamp'}/train/m{i}.obj\n"
                             for i in range(20)))
    chairs = read_split_file(small, ["chair"])
    assert [name for name, split in chairs.items() if split != "train"] == [
        "chair__train__m17", "chair__train__m19"]
    assert len(read_split_file(small)) == 20


@pytest.mark.parametrize("text, problem", [
    ("name,split\nmug,holdout\n", "line 2: split 'holdout' is not one of"),
    ("name,split\nmug,train\nmug,test\n", "line 3 lists 'mug' a second time"),
    ("name,split\nmug\n", "line 2 is 'mug', expected name,split"),
    ("mug.obj\n", "line 1 is 'mug.obj', expected objfiles/"),
    ("name,split\n" + "x" * 200_000 + ",train\n", "line 2 cannot be read as CSV .*131072"),
])
def test_a_malformed_split_file_is_one_line_naming_it(tmp_path, text, problem):
    path = tmp_path / "splits.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=problem) as caught:
        read_split_file(path)
    assert str(caught.value).startswith(str(path)) and "\n" not in str(caught.value)


@pytest.mark.parametrize("text", [
    "name,split\n" + "y" * 100_000 + "\n",
    "name,split\nmug,train\n" + "mug" * 30_000 + ",train\n" + "mug" * 30_000 + ",test\n",
    "name,split\nmug," + "z" * 100_000 + "\n",
    "z" * 100_000 + "\n",
])
def test_an_error_quotes_at_most_80_characters_of_a_long_line(tmp_path, text):
    path = tmp_path / "splits.csv"
    path.write_text(text)
    with pytest.raises(InputError) as caught:
        read_split_file(path)
    quoted = str(caught.value).split("'", 1)[1].rsplit("...", 1)[0]
    assert len(quoted) == 76 and "..." in str(caught.value) and len(str(caught.value)) < 250


@pytest.mark.parametrize("extra", [[], ["--dry-run"]], ids=["build", "dry-run"])
def test_build_dataset_with_a_cell_too_big_for_csv_is_one_line(tmp_path, extra):
    src = source(tmp_path / "src")
    csv = tmp_path / "bigcell.csv"
    csv.write_text("name,split\n" + "x" * 200_000 + ",train\nmug,train\n")
    result = CliRunner().invoke(main, ["build-dataset", str(src), str(tmp_path / "out"),
                                       "--views", "20", "--no-clean", "--splits", str(csv),
                                       *extra])
    assert result.exit_code == 2, result.output
    assert result.stderr == (f"vptool: error: {csv}: line 2 cannot be read as CSV "
                             "(field larger than field limit (131072))\n")
    assert not (tmp_path / "out").exists()


def test_build_takes_its_split_from_a_csv(tmp_path):
    src = source(tmp_path / "src")
    csv = tmp_path / "splits.csv"
    csv.write_text("name,split\nkitchen__mug,test\nkitchen__bottle,val\nfurniture__table,train\n"
                   "furniture__lego,train\nmug,test\n")
    result = build_dataset(src, tmp_path / "out", replace(TINY, splits=SplitFile.read(csv)))
    assert stored_splits(result.path) == {"kitchen__mug": "test", "kitchen__bottle": "val",
                                          "furniture__table": "train", "furniture__lego": "train"}
    assert result.split_file.n_placed == 4 and result.split_file.not_in_source == ("mug",)
    with open_store(result.path) as store:
        assert store.attrs["split_file"]["name"] == "splits.csv"


def test_build_applies_the_papers_rule_to_small_txt(tmp_path):
    src = source(tmp_path / "src", "train")
    small = tmp_path / "small.txt"
    names = ["k0", "k1", "k2", "k3", "k4", "k5", "k6", "k7", "mug", "bottle"]
    lines = [f"objfiles/kitchen/train/{name}.obj\n" for name in names]
    lines.insert(3, "objfiles/furniture/test/table.obj\n")  # another category: no index
    small.write_text("".join(lines))
    result = build_dataset(src, tmp_path / "out", replace(TINY, splits=SplitFile.read(small)),
                           categories=["kitchen"])
    assert stored_splits(result.path) == {"kitchen__train__mug": "val",
                                          "kitchen__train__bottle": "test"}
    assert result.split_file.n_placed == 2 and len(result.split_file.not_in_source) == 8


def test_a_model_the_file_does_not_place_is_refused_before_any_work(tmp_path):
    src = source(tmp_path / "src")
    csv = tmp_path / "splits.csv"
    csv.write_text("name,split\nkitchen__mug,train\nkitchen__bottle,train\n")
    with pytest.raises(InputError, match=r"does not place 2 of the 4 models .*lego\.obj") \
            as caught:
        build_dataset(src, tmp_path / "out", replace(TINY, splits=SplitFile.read(csv)))
    assert "\n" not in str(caught.value) and not (tmp_path / "out").exists()


def test_resume_refuses_an_edited_split_file(tmp_path):
    src = source(tmp_path / "src")
    csv = tmp_path / "splits.csv"
    csv.write_text("name,split\nkitchen__mug,test\nkitchen__bottle,val\nfurniture__table,train\nfurniture__lego,train\n")
    out = tmp_path / "out"
    build_dataset(src, out, replace(TINY, splits=SplitFile.read(csv)))
    again = build_dataset(src, out, replace(TINY, splits=SplitFile.read(csv)))
    assert again.n_resumed == 4
    csv.write_text("name,split\nkitchen__mug,train\nkitchen__bottle,val\nfurniture__table,train\nfurniture__lego,train\n")
    with pytest.raises(InputError, match="splits_sha256="):
        build_dataset(src, out, replace(TINY, splits=SplitFile.read(csv)))
    with pytest.raises(InputError, match="splits_sha256="):
        build_dataset(src, out, TINY)


def test_build_dataset_says_how_many_the_file_placed(tmp_path):
    src = source(tmp_path / "src")
    csv = tmp_path / "splits.csv"
    csv.write_text("name,split\nkitchen__mug,test\nkitchen__bottle,val\nfurniture__table,train\nfurniture__lego,train\nvase,test\n")
    result = CliRunner().invoke(main, ["build-dataset", str(src), str(tmp_path / "out"),
                                       "--views", "20", "--resolution", "16", "--points", "16",
                                       "--no-clean", "--splits", str(csv)])
    assert result.exit_code == 0, result.output
    assert f"split from {csv}: placed 4 models" in result.stdout
    assert "1 names in" in result.stderr and "vase" in result.stderr
    csv.write_text("name,split\nkitchen__mug,test\n")
    refused = CliRunner().invoke(main, ["build-dataset", str(src), str(tmp_path / "new"),
                                        "--views", "20", "--no-clean", "--splits", str(csv)])
    assert refused.exit_code == 2 and refused.stderr.count("\n") == 1


def test_the_samples_split_file_places_every_sample_in_all_three_splits(tmp_path):
    from vptoolkit.dataset.builder.plan import plan_build

    splits = read_split_file(SAMPLE_SPLITS)
    assert sorted(splits) == sorted(Path(name).stem for name in sample_names())
    assert sorted(splits.values()).count("test") == 2
    options = BuildOptions(splits=SplitFile.read(SAMPLE_SPLITS))
    plan = plan_build(SAMPLE_SPLITS.parent, tmp_path / "out", options, calibrate=0)
    assert plan.counts == {"samples": {"train": 8, "val": 2, "test": 2}}
    script = (REPO / "tools" / "run_sample.sh").read_text()
    assert "build-dataset vptoolkit/samples" in script
    assert "--splits vptoolkit/samples/splits.csv" in script


def test_class_split_is_stratified_and_ignores_order():
    from vptoolkit.dataset.builder.split_files import class_split

    models = [(category, f"{category}{i}") for category, n in (("jet", 40), ("cup", 5),
                                                               ("hat", 2), ("one", 1))
              for i in range(n)]
    split = class_split(models, fraction=0.1, seed=3)
    by = {category: [split[name] for c, name in models if c == category]
          for category in ("jet", "cup", "hat", "one")}
    assert by["jet"].count("validation") == 4  # round(0.1 * 40)
    assert by["cup"].count("validation") == 1 and by["hat"].count("validation") == 1
    assert by["one"] == ["train"]  # a single model stays in train
    assert class_split(models[::-1], fraction=0.1, seed=3) == split  # order does not matter
    assert class_split(models, fraction=0.1, seed=4) != split
    with pytest.raises(InputError, match="occurs twice"):
        class_split([("a", "x"), ("b", "x")])
    with pytest.raises(InputError, match="fraction"):
        class_split(models, fraction=1.0)


def test_split_command_writes_a_file_build_dataset_reads(tmp_path):
    src = source(tmp_path / "src")
    result = CliRunner().invoke(main, ["split", str(src), "-o", str(tmp_path / "splits.csv"),
                                       "--validation", "0.1"])
    assert result.exit_code == 0, result.output
    assert "2 train, 2 validation models in 2 categories" in result.output
    written = read_split_file(tmp_path / "splits.csv")
    assert sorted(written) == ["furniture__lego", "furniture__table", "kitchen__bottle",
                               "kitchen__mug"]
    assert sorted(written.values()) == ["train", "train", "validation", "validation"]
    built = build_dataset(src, tmp_path / "out",
                          replace(TINY, splits=SplitFile.read(tmp_path / "splits.csv")))
    assert {name: ("validation" if split == "val" else split)
            for name, split in stored_splits(built.path).items()} == written


def test_split_leaves_out_names_a_split_file_cannot_hold(tmp_path):
    from vptoolkit.dataset.builder.split_files import write_split_file

    src = source(tmp_path / "src")
    mesh = next(next(path for path in src.iterdir() if path.is_dir()).iterdir())
    for name in (" lead", "=cmd()", "tab\there"):  # in SRC itself, so the stem is the name
        shutil.copy(mesh, src / f"{name}{mesh.suffix}")
    result = CliRunner().invoke(main, ["split", str(src), "-o", str(tmp_path / "splits.csv")])
    assert result.exit_code == 0, result.output
    warnings = [line for line in result.stderr.splitlines() if line.startswith("vptool: warning")]
    assert len(warnings) == 3, result.stderr
    assert any("' lead' has a space at one end" in line for line in warnings)
    assert any("'=cmd()' starts with a spreadsheet formula character" in line
               for line in warnings)
    assert any("cannot name a file or folder" in line for line in warnings)
    assert sorted(read_split_file(tmp_path / "splits.csv")) == [
        "furniture__lego", "furniture__table", "kitchen__bottle", "kitchen__mug"]
    with pytest.raises(InputError, match="formula"):
        write_split_file(tmp_path / "other.csv", {"=cmd()": "train"})
