"""vptool pack, verify, info and build-dataset."""

from fixtures.paths import MALFORMED
from vptoolkit.cli import main
from vptoolkit.samples import sample_path


def test_pack_verify_info_on_a_small_store(runner, tmp_path):
    from fixtures.stores import write_synthetic

    store = write_synthetic(tmp_path / "dataset.zarr")
    release = tmp_path / "release"
    packed = runner.invoke(main, ["pack", str(store), str(release)])
    assert packed.exit_code == 0, packed.output
    assert (release / "SHA256SUMS").exists() and (release / "README.md").exists()
    verified = runner.invoke(main, ["verify", str(release)])
    assert verified.exit_code == 0, verified.output
    shown = runner.invoke(main, ["info", str(release), "--json"])
    assert shown.exit_code == 0
    h5 = next(release.glob("*.h5"))
    data = bytearray(h5.read_bytes())
    data[len(data) // 2] ^= 0xFF
    h5.write_bytes(bytes(data))
    broken = runner.invoke(main, ["verify", str(release)])
    assert broken.exit_code == 1 and h5.name in broken.stderr


def test_build_dataset_records_failures_and_exits_1(runner, tmp_path):
    import shutil

    src = tmp_path / "src"
    (src / "things").mkdir(parents=True)
    for name in ("teapot.stl", "suzanne.ply"):
        shutil.copy(sample_path(name), src / "things" / name)
    shutil.copy(MALFORMED / "empty.obj", src / "things" / "empty.obj")
    result = runner.invoke(main, ["build-dataset", str(src), str(tmp_path / "out"), "--views", "40",
                                  "--resolution", "48", "--points", "200", "--no-clean"])
    assert result.exit_code == 1, result.output
    assert "2 models, 1 failures" in result.stdout
    assert "failed things/empty.obj: " in result.stderr
    shown = runner.invoke(main, ["info", str(tmp_path / "out")])
    assert shown.exit_code == 0 and "things" in shown.stdout
