"""The authors' released layout: import, export, the paper's split rule, malformed trees;
the paper's four exported from a store of more measures."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from vptoolkit.cli import main
from vptoolkit.dataset.authors.export import export_authors, order_for_paper_rule
from vptoolkit.dataset.authors.importer import AUTHORS_FOLDERS, import_authors
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.dataset.builder.split_files import paper_split, paper_splits, read_model_list
from vptoolkit.dataset.store.reader import open_store
from vptoolkit.errors import InputError
from vptoolkit.measures.quality import normalize_quality
from vptoolkit.measures.registry import PAPER_MEASURES
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere

pytest.importorskip("zarr")


def write_tree(root: Path, models: list[tuple[str, str, str]], *, n_points: int = 16,
               seed: int = 0) -> Path:
    """A tree in the authors' layout with random points, unit normals and measures, a
    tetrahedron mesh per model."""
    rng = np.random.default_rng(seed)
    views = fibonacci_sphere(1000)
    for folder in AUTHORS_FOLDERS.values():
        listing = root / "best_views" / folder / "3D"
        listing.mkdir(parents=True, exist_ok=True)
        np.savetxt(listing / "_point_list.txt", views, fmt="%s", delimiter=",")
    lines = []
    for category, split, name in models:
        stem = f"{category}/{split}/{name}"
        lines.append(f"objfiles/{stem}.obj")
        obj = root / "objfiles" / f"{stem}.obj"
        obj.parent.mkdir(parents=True, exist_ok=True)
        obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
        points = root / "pts_unif" / f"{stem}.txt"
        points.parent.mkdir(parents=True, exist_ok=True)
        table = rng.random((n_points, 6)) + 0.1
        table[:, 3:] /= np.linalg.norm(table[:, 3:], axis=1, keepdims=True)  # unit normals
        np.savetxt(points, table, fmt="%s", delimiter=",")
        for folder in AUTHORS_FOLDERS.values():
            values = root / "best_views" / folder / "3D" / f"{stem}_vq_list.txt"
            values.parent.mkdir(parents=True, exist_ok=True)
            np.savetxt(values, rng.random(1000), fmt="%s")
    (root / "small.txt").write_text("\n".join(lines) + "\n")
    return root


def listed(*categories_and_counts: tuple[str, int]) -> list[tuple[str, str, str]]:
    return [(category, "train", f"{category}_{i:04d}")
            for category, count in categories_and_counts for i in range(1, count + 1)]


# --------------------------------------------------------------------------- the split rule


def test_paper_split_counts_only_the_filtered_lines(tmp_path):
    models = [("chair", "train", "chair_0001"), ("lamp", "train", "lamp_0001")] * 1
    models = [(c, "train", f"{c}_{i:04d}") for i in range(12) for c in ("chair", "lamp")]
    write_tree(tmp_path, models)
    lines = read_model_list(tmp_path / "small.txt")
    chairs = paper_splits(lines, ["chair"])
    assert [split for _, split in chairs] == [paper_split(i) for i in range(12)]
    assert [model.name for model, _ in chairs] == [f"chair_{i:04d}" for i in range(12)]
    assert chairs[8][1] == "validation" and chairs[9][1] == "test"
    everything = paper_splits(lines)
    assert [m.name for m, s in everything if s == "test"] == ["lamp_0004", "lamp_0009"]


def test_import_keeps_the_rule_with_missing_files_and_filtered_categories(tmp_path):
    models = [(c, "train", f"{c}_{i:04d}") for i in range(11) for c in ("chair", "lamp")]
    tree = write_tree(tmp_path / "set", models)
    (tree / "pts_unif/chair/train/chair_0002.txt").unlink()  # index 2 is skipped, not reused
    result = import_authors(tree, tmp_path / "out", categories=["chair"])
    assert result.n_models == 10 and result.n_failures == 1
    assert "chair_0002.txt: points file is missing" in result.failures[0]["reason"]
    with open_store(result.path) as store:
        splits = {r["name"]: r["split"] for r in store.models()}
        assert store.attrs["provenance"]["measures"] == "imported, not computed"
    assert splits["chair_0008"] == "validation" and splits["chair_0009"] == "test"
    assert splits["chair_0010"] == "train" and "chair_0002" not in splits
    assert result.split_counts == {"train": 8, "validation": 1, "test": 1}


def test_imported_measures_follow_the_authors_normalisation(tmp_path):
    tree = write_tree(tmp_path / "set", listed(("chair", 2)))
    result = import_authors(tree, tmp_path / "out", meshes=False)
    with open_store(result.path) as store:
        entry = store.entry(0)
    for column, measure in enumerate(PAPER_MEASURES):
        theirs = np.loadtxt(tree / "best_views" / AUTHORS_FOLDERS[measure] / "3D/chair/train"
                            / "chair_0001_vq_list.txt")
        np.testing.assert_allclose(entry.quality_raw[:, column], theirs, rtol=1e-6)
        if measure in ("VKL", "VMI"):
            theirs = theirs.max() - theirs
        expected = (theirs - theirs.min()) / (theirs.max() - theirs.min())
        np.testing.assert_allclose(entry.quality[:, column], expected, atol=1e-6)
        assert entry.best_index[column] == np.argmax(expected)
    assert len(entry.faces) == 0
    np.testing.assert_allclose(normalize_quality(entry.quality_raw), entry.quality, atol=1e-6)


def test_order_for_paper_rule_reproduces_fitting_splits_and_names_the_rest():
    splits = ["train"] * 8 + ["validation", "test"] + ["train"] * 3 + ["test"] * 2
    order, mismatched = order_for_paper_rule([(f"m{i}", s) for i, s in enumerate(splits)])
    by_name = dict((f"m{i}", s) for i, s in enumerate(splits))
    assert sorted(order) == sorted(by_name)
    wrong = [name for i, name in enumerate(order) if paper_split(i) != by_name[name]]
    assert wrong == mismatched and len(wrong) == 2  # 15 lines have one test slot


# --------------------------------------------------------------------------- malformed input


def test_a_malformed_model_is_a_failure_and_the_import_goes_on(tmp_path):
    tree = write_tree(tmp_path / "set", listed(("chair", 4)))
    ve = tree / "best_views/vq5/3D/chair/train"
    (ve / "chair_0001_vq_list.txt").write_text("0.5\n" * 999)
    (tree / "best_views/vq7/3D/chair/train/chair_0002_vq_list.txt").write_text("nan\n" * 1000)
    (tree / "objfiles/chair/train/chair_0003.obj").write_text("not a mesh\n")
    result = import_authors(tree, tmp_path / "out")
    assert result.n_models == 1
    reasons = [failure["reason"] for failure in result.failures]
    assert "expected 1000 lines" in reasons[0] and "chair_0001_vq_list.txt" in reasons[0]
    assert "NaN" in reasons[1]
    assert "chair_0003.obj" in reasons[2]
    assert all("\n" not in reason for reason in reasons)


@pytest.mark.parametrize("damage", ["no_small", "bad_line", "views", "no_point_list"])
def test_a_tree_not_in_the_layout_is_refused_with_one_line(tmp_path, damage):
    tree = write_tree(tmp_path / "set", listed(("chair", 2)))
    point_list = tree / "best_views/vq4/3D/_point_list.txt"
    if damage == "no_small":
        (tree / "small.txt").unlink()
    elif damage == "bad_line":
        (tree / "small.txt").write_text("chair_0001.obj\n")
    elif damage == "views":
        views = fibonacci_sphere(1000)[::-1]
        np.savetxt(point_list, views, fmt="%s", delimiter=",")
    else:
        point_list.unlink()
    with pytest.raises(InputError) as caught:
        import_authors(tree, tmp_path / "out")
    assert "\n" not in str(caught.value)
    assert str(tree) in str(caught.value)
    assert not (tmp_path / "out").exists()


# --------------------------------------------------------------------------- round trip


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    from vptoolkit.dataset.builder.run import build_dataset

    src = tmp_path_factory.mktemp("src")
    for category, sample in (("bottle", "bottle.obj"), ("mug", "mug.obj"), ("table", "table.obj")):
        (src / category).mkdir()
        shutil.copy(sample_path(sample), src / category / sample)
    out = tmp_path_factory.mktemp("built")
    options = BuildOptions(MeasureSettings(views=1000, resolution=32), n_points=64, clean=False)
    result = build_dataset(src, out, options)
    assert result.n_failures == 0
    return result.path


def test_export_then_import_gives_back_every_array(built, tmp_path):
    exported = export_authors(built, tmp_path / "ModelNet")
    assert exported.n_models == 3
    assert (tmp_path / "ModelNet/small.txt").is_file()
    imported = import_authors(tmp_path / "ModelNet", tmp_path / "back")
    assert imported.n_failures == 0
    with open_store(built) as ours, open_store(imported.path) as back:
        assert [r["name"] for r in ours.models()] == [r["name"] for r in back.models()]
        mismatched = set(exported.mismatched)
        for a, b in zip(ours.models(), back.models()):
            assert a["name"] in mismatched or a["split"] == b["split"]
        np.testing.assert_array_equal(np.asarray(ours.array("views")),
                                      np.asarray(back.array("views")))
        for name in ("points", "normals", "quality_raw", "mesh_vertices", "mesh_faces",
                     "best_index", "worst_index"):
            np.testing.assert_array_equal(np.asarray(ours.array(name)),
                                          np.asarray(back.array(name)), err_msg=name)
        np.testing.assert_allclose(np.asarray(ours.array("quality")),
                                   np.asarray(back.array("quality")), atol=1e-6)
        assert back.attrs["provenance"]["n_files"] == 3 * 6


def test_import_is_repeatable_byte_for_byte(tmp_path):
    tree = write_tree(tmp_path / "set", listed(("chair", 3)))
    first = import_authors(tree, tmp_path / "a").path
    second = import_authors(tree, tmp_path / "b").path
    files = sorted(p.relative_to(first) for p in first.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(second) for p in second.rglob("*") if p.is_file())
    for name in files:
        assert (first / name).read_bytes() == (second / name).read_bytes(), name


def test_export_refuses_a_store_without_the_authors_views(tmp_path):
    from vptoolkit.dataset.builder.run import build_dataset

    src = tmp_path / "src" / "mug"
    src.mkdir(parents=True)
    shutil.copy(sample_path("mug.obj"), src)
    result = build_dataset(
        tmp_path / "src", tmp_path / "built",
        BuildOptions(MeasureSettings(views=20, resolution=16), n_points=16, clean=False))
    with pytest.raises(InputError, match="Fibonacci sphere of 1000"):
        export_authors(result.path, tmp_path / "ModelNet")
    assert not (tmp_path / "ModelNet").exists()


# --------------------------------------------------------------------------- command line


def test_import_and_export_from_the_command_line(tmp_path):
    import json

    from click.testing import CliRunner

    from vptoolkit.cli import main
    from vptoolkit.data import open_dataset
    from vptoolkit.evaluate.baselines import oracle_directions

    runner = CliRunner()
    tree = write_tree(tmp_path / "set", listed(("chair", 10), ("lamp", 10)), n_points=64)
    (tree / "pts_unif/lamp/train/lamp_0003.txt").write_text("1,2,3\n")
    out = tmp_path / "out"
    imported = runner.invoke(main, ["import-authors", str(tree), str(out)])
    assert imported.exit_code == 1, imported.output
    assert imported.stdout.startswith("imported ") and "19 models" in imported.stdout
    assert "lamp_0003.txt" in imported.stderr and "Traceback" not in imported.output
    for command in (["info", str(out)], ["verify", str(out)],
                    ["pack", str(out), str(tmp_path / "release")]):
        result = runner.invoke(main, command)
        assert result.exit_code == 0, (command, result.output)
    card = (tmp_path / "release/README.md").read_text()
    assert "The measures were imported, not computed" in card and "index % 10" in card
    with open_dataset(out) as dataset:
        test = dataset.split("test")
        assert test.names == ["chair_0010", "lamp_0010"]
        np.save(tmp_path / "oracle.npy", oracle_directions(test))
    scored = runner.invoke(main, ["evaluate", str(tmp_path / "oracle.npy"), "--dataset",
                                  str(out), "--json"])
    assert scored.exit_code == 0, scored.output
    assert json.loads(scored.stdout)["mean"] == {m: 100.0 for m in PAPER_MEASURES}
    only = runner.invoke(main, ["import-authors", str(tree), str(tmp_path / "chairs"),
                                "--categories", "chair", "--no-meshes"])
    assert only.exit_code == 0 and "10 models (8 train, 1 validation, 1 test)" in only.stdout
    exported = runner.invoke(main, ["export-authors", str(out), str(tmp_path / "again")])
    assert exported.exit_code == 0, exported.output
    assert (tmp_path / "again/small.txt").read_text().count("\n") == 19
    refused = runner.invoke(main, ["import-authors", str(tmp_path), str(tmp_path / "x")])
    assert refused.exit_code == 2 and refused.stderr.count("\n") == 1
    assert "not in the authors' layout" in refused.stderr


# --------------------------------------------------------------------------- the measures check


def test_check_finds_our_own_measures_in_an_exported_build(built, tmp_path):
    from vptoolkit.dataset.authors.check import check_measures

    export_authors(built, tmp_path / "set")
    imported = import_authors(tmp_path / "set", tmp_path / "back")
    check = check_measures(imported.path, 2, resolution=32)
    # a build's names (category__stem) become the exported files' stems and come back
    assert [m.name for m in check.models] == ["bottle__bottle", "table__table"]
    assert not check.failures
    for row in check.summary().values():
        assert row["mean_correlation"] > 0.99 and row["median_angle_deg"] < 1.0


def test_check_from_the_command_line_and_without_meshes(tmp_path):
    from click.testing import CliRunner

    from vptoolkit.cli import main

    tree = write_tree(tmp_path / "set", listed(("chair", 2)))
    result = CliRunner().invoke(main, ["import-authors", str(tree), str(tmp_path / "out"),
                                       "--check", "5", "--check-resolution", "16"])
    assert result.exit_code == 0, result.output
    assert "check: our measures at 16 px on 2 models against theirs" in result.stdout
    assert "VKL: rank correlation" in result.stdout and "deg apart (median)" in result.stdout
    bare = CliRunner().invoke(main, ["import-authors", str(tree), str(tmp_path / "bare"),
                                     "--no-meshes", "--check", "1"])
    assert bare.exit_code == 0 and "no stored mesh" in bare.stderr


def test_unprefixed_lines_duplicates_and_unknown_categories(tmp_path):
    tree = write_tree(tmp_path / "set", listed(("chair", 2)))
    lines = (tree / "small.txt").read_text().splitlines()
    (tree / "small.txt").write_text("\n".join([lines[0].removeprefix("objfiles/"), *lines,
                                               ""]))
    result = import_authors(tree, tmp_path / "out")
    assert result.n_models == 2 and result.n_failures == 1
    assert "lists 'chair_0001' a second time" in result.failures[0]["reason"]
    with pytest.raises(InputError, match="no lines of the categories lamp"):
        import_authors(tree, tmp_path / "other", categories=["chair", "lamp"])
    with pytest.raises(InputError, match="exists and is not an empty folder"):
        import_authors(tree, tmp_path / "out")
    with pytest.raises(InputError, match="exists and is not an empty folder"):
        export_authors(result.path, tree)


# --------------------------------------------------------------------------- hostile trees


def _import_quietly(tree: Path, out: Path, **options):
    """import_authors, failing the test on any warning (a batch catches the warning as error)."""
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = import_authors(tree, out, **options)
    assert [str(w.message) for w in caught] == []
    return result


def test_a_category_of_dot_dot_is_a_failure_and_nothing_is_read_outside(tmp_path):
    tree = write_tree(tmp_path / "set", listed(("chair", 3)))
    # objfiles/../train/x.obj: every file of the line lies one folder up from its place
    for source, target in (("objfiles/chair/train/chair_0003.obj", "train/chair_0003.obj"),
                           ("pts_unif/chair/train/chair_0003.txt", "train/chair_0003.txt")):
        (tree / target).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(tree / source, tree / target)
    for folder in AUTHORS_FOLDERS.values():
        lists = tree / "best_views" / folder
        (lists / "train").mkdir()
        shutil.copy(lists / "3D/chair/train/chair_0003_vq_list.txt", lists / "train")
    lines = (tree / "small.txt").read_text().splitlines()
    (tree / "small.txt").write_text("\n".join([*lines[:2], "objfiles/../train/chair_0003.obj",
                                               "objfiles/chair/train/.hidden.obj", ""]))
    result = _import_quietly(tree, tmp_path / "out")
    assert result.n_models == 2 and result.n_failures == 2
    dots, hidden = (failure["reason"] for failure in result.failures)
    assert dots == (f"{tree / 'small.txt'}: line 3: category '..' cannot name a file or folder "
                    "(it starts with '.')")
    assert "line 4: model name '.hidden' cannot name" in hidden
    with open_store(result.path) as store:
        assert {record["category"] for record in store.models()} == {"chair"}


def test_normals_not_of_unit_length_are_a_failure_naming_the_file(tmp_path):
    tree = write_tree(tmp_path / "set", listed(("chair", 3)))
    for name, normal in (("chair_0001", "0,0,0"), ("chair_0002", "0,0,7")):
        points = tree / f"pts_unif/chair/train/{name}.txt"
        lines = points.read_text().splitlines()
        points.write_text("".join(",".join(line.split(",")[:3]) + f",{normal}\n"
                                  for line in lines))
    result = _import_quietly(tree, tmp_path / "out")
    assert result.n_models == 1
    zero, seven = (failure["reason"] for failure in result.failures)
    assert zero == (f"{tree / 'pts_unif/chair/train/chair_0001.txt'}: points file: 16 of 16 "
                    "normals are not of unit length (the first, normal 1, has length 0)")
    assert "chair_0002.txt: points file: 16 of 16 normals" in seven and "length 7)" in seven


def test_values_beyond_float32_and_empty_files_are_one_models_failure(tmp_path):
    tree = write_tree(tmp_path / "set", listed(("chair", 5)))
    pts = tree / "pts_unif/chair/train"
    (pts / "chair_0001.txt").write_text("1e300,0,0,0,0,1\n" * 16)
    (pts / "chair_0002.txt").write_text("0,0,0,1e300,0,0\n" * 16)
    (tree / "best_views/vq7/3D/chair/train/chair_0003_vq_list.txt").write_text(
        "1.7e308\n-1.7e308\n" * 500)
    (pts / "chair_0004.txt").write_text("")
    result = _import_quietly(tree, tmp_path / "out")
    assert result.n_models == 1
    reasons = [failure["reason"] for failure in result.failures]
    assert [reason.split(": ")[0] for reason in reasons] == [
        str(pts / "chair_0001.txt"), str(pts / "chair_0002.txt"),
        str(tree / "best_views/vq7/3D/chair/train/chair_0003_vq_list.txt"),
        str(pts / "chair_0004.txt")]
    assert all("beyond the float32 range" in reason for reason in reasons[:3])
    assert reasons[3].endswith("points file is empty")


def test_an_empty_or_fifo_small_txt_is_refused_in_one_line(tmp_path):
    import os

    from click.testing import CliRunner

    from vptoolkit.cli import main

    tree = write_tree(tmp_path / "set", listed(("chair", 2)))
    (tree / "small.txt").write_text("\n\n")
    with pytest.raises(InputError, match="small.txt: lists no models"):
        import_authors(tree, tmp_path / "out")
    assert not (tmp_path / "out").exists()
    if not hasattr(os, "mkfifo"):
        return
    (tree / "small.txt").unlink()
    os.mkfifo(tree / "small.txt")  # nobody writes it: reading it would block for ever
    result = CliRunner().invoke(main, ["import-authors", str(tree), str(tmp_path / "out")])
    assert result.exit_code == 2 and result.stderr == (
        f"vptool: error: {tree / 'small.txt'}: not a regular file\n")


def test_a_rerun_after_a_killed_import_removes_its_stale_staging(tmp_path):
    import tempfile

    from vptoolkit.files import held, temporary_prefix

    tree = write_tree(tmp_path / "set", listed(("chair", 2)))
    out = tmp_path / "out"
    out.mkdir()
    (tmp_path / "busy").mkdir()
    # what kill -9 during the write leaves: the store's hidden staging, half written
    stale = Path(tempfile.mkdtemp(prefix=temporary_prefix("dataset.zarr"), suffix=".partial",
                                  dir=out))
    (stale / "points").mkdir()
    (stale / "points" / "0.0.0").write_bytes(b"half")
    result = import_authors(tree, out, meshes=False)
    assert result.n_models == 2
    assert sorted(path.name for path in out.iterdir()) == ["dataset.zarr"]
    live = Path(tempfile.mkdtemp(prefix=temporary_prefix("dataset.zarr"), suffix=".partial",
                                 dir=tmp_path / "busy"))
    with held(live), pytest.raises(InputError, match="exists and is not an empty folder"):
        import_authors(tree, tmp_path / "busy")  # another import is writing there
    (out / "notes.txt").write_text("mine")  # other content still makes OUT not empty
    with pytest.raises(InputError, match="exists and is not an empty folder"):
        import_authors(tree, tmp_path / "out")


def test_export_names_out_not_its_staging_and_removes_stale_staging(tmp_path, monkeypatch):
    import errno
    import tempfile

    from click.testing import CliRunner

    from vptoolkit.cli import main
    from vptoolkit.dataset.authors import export as authors_export
    from vptoolkit.files import temporary_prefix

    tree = write_tree(tmp_path / "set", listed(("chair", 2)))
    store = import_authors(tree, tmp_path / "store", meshes=False).path
    stale = [Path(tempfile.mkdtemp(prefix=temporary_prefix("tree"), suffix=".partial",
                                   dir=tmp_path)) for _ in range(2)]
    (stale[0] / "small.txt").write_text("half")
    other = Path(tempfile.mkdtemp(prefix=temporary_prefix("tree2"), suffix=".partial",
                                  dir=tmp_path))  # another output's: kept
    target = tmp_path / "tree"

    def full_disk(path, payload):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    with monkeypatch.context() as patch:
        patch.setattr(authors_export, "_write", full_disk)
        result = CliRunner().invoke(main, ["export-authors", str(store), str(target)])
    assert result.exit_code == 2 and result.stderr == (
        f"vptool: error: {target}: No space left on device\n")

    def read_only(*args, **kwargs):
        hidden = tmp_path / ".tree.12345678.partial"
        raise PermissionError(errno.EROFS, "Read-only file system", str(hidden))

    with monkeypatch.context() as patch:
        patch.setattr(tempfile, "mkdtemp", read_only)
        result = CliRunner().invoke(main, ["export-authors", str(store), str(target)])
    assert result.exit_code == 2 and result.stderr == (
        f"vptool: error: {target}: Read-only file system\n")
    assert all(path.exists() for path in stale) and not target.exists()
    export_authors(store, target)
    assert (target / "small.txt").is_file()
    assert not any(path.exists() for path in stale) and other.is_dir()
    assert sorted(path.name for path in tmp_path.iterdir() if path.name.startswith(".")) == [
        other.name]


# --- a store of more measures than the paper's four ---------------------------------------


FIVE = ("SL", "VMI", "VE", "VKL", "VR")
"""The paper's four among another measure, in an order of the store's own."""


def _build(root: Path, measures: str, views: int) -> Path:
    from vptoolkit.dataset.builder.run import build_dataset

    src = root / "src"
    for category, sample in (("bottle", "bottle.obj"), ("mug", "mug.obj")):
        (src / category).mkdir(parents=True)
        shutil.copy(sample_path(sample), src / category / sample)
    options = BuildOptions(MeasureSettings(views=views, resolution=32), measures=measures,
                           n_points=64, clean=False)
    result = build_dataset(src, root / "out", options)
    assert result.n_failures == 0
    return result.path


@pytest.fixture(scope="module")
def five(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two samples measured with :data:`FIVE` over the authors' 1000 views."""
    return _build(tmp_path_factory.mktemp("five"), ",".join(FIVE), 1000)


def test_the_paper_four_are_exported_from_among_more(five: Path, tmp_path: Path) -> None:
    exported = export_authors(five, tmp_path / "set")
    assert exported.n_models == 2
    imported = import_authors(tmp_path / "set", tmp_path / "back")
    columns = [FIVE.index(measure) for measure in PAPER_MEASURES]
    with open_store(five) as ours, open_store(imported.path) as back:
        assert back.measures == PAPER_MEASURES
        ours_by_name = {r["name"]: row for row, r in enumerate(ours.models())}
        for row, record in enumerate(back.models()):
            mine = ours_by_name[record["name"]]
            np.testing.assert_array_equal(back.array("quality_raw")[row],
                                          ours.array("quality_raw")[mine][:, columns])
            np.testing.assert_array_equal(back.array("best_index")[row],
                                          ours.array("best_index")[mine][columns])


def test_the_measures_check_follows_the_stores_names(five: Path) -> None:
    from vptoolkit.dataset.authors.check import check_measures

    check = check_measures(five, 1, resolution=32)
    assert check.measures == FIVE and list(check.summary()) == list(FIVE)
    # our own pipeline at the same settings: the same order of views, up to the float32
    # rounding of the stored quality among near ties
    for measure, row in check.summary().items():
        assert row["mean_correlation"] > 0.9999, measure
        assert row["median_angle_deg"] == pytest.approx(0.0, abs=1e-6), measure


def test_a_store_without_the_paper_four_is_refused_in_one_line(tmp_path: Path) -> None:
    store = _build(tmp_path, "VE,NVT,SL", 40)
    result = CliRunner().invoke(main, ["export-authors", str(store), str(tmp_path / "set")])
    assert result.exit_code == 2
    assert result.stderr == (
        f"vptool: error: {store}: the authors' tree holds VE, VR, VKL, VMI; this store "
        "records VE, NVT, SL, without VR, VKL, VMI\n")
    assert not (tmp_path / "set").exists()
