"""Opening a release from a URL: a local http.server in the test serves a packed release."""

from __future__ import annotations

import functools
import http.server
import shutil
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fixtures.environment import require_package
from fixtures.releases import write_release_build
from vptoolkit.cli import main
from vptoolkit.data import open_dataset
from vptoolkit.data.remote import default_cache_dir, fetch_release, is_remote
from vptoolkit.dataset.release_options import ReleaseOptions
from vptoolkit.errors import InputError, VerificationError


@pytest.fixture(scope="module")
def release(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A release with Parquet shards and an HDF5 archive (the default formats)."""
    require_package("h5py")
    require_package("pyarrow")
    from vptoolkit.dataset.release import pack_release

    base = tmp_path_factory.mktemp("remote")
    write_release_build(base / "build")
    return pack_release(base / "build", base / "release",
                        ReleaseOptions(formats=["parquet", "hdf5"], license="cc-by-4.0")).path


class _Server:
    """A release folder served on 127.0.0.1 (port chosen by the system); counts requests."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.requests: list[str] = []
        log = self.requests

        class Handler(http.server.SimpleHTTPRequestHandler):
            def do_GET(self) -> None:  # noqa: N802 - the http.server name
                log.append(self.path)
                super().do_GET()

            def log_message(self, *args: object) -> None:
                pass

        handler = functools.partial(Handler, directory=str(folder))
        self.httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/release/"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)

    def downloads(self) -> list[str]:
        """The paths requested other than the manifest."""
        return [path for path in self.requests if not path.endswith("/SHA256SUMS")]


@pytest.fixture()
def served(release: Path, tmp_path: Path) -> Iterator[_Server]:
    root = tmp_path / "www"
    shutil.copytree(release, root / "release")
    server = _Server(root)
    server.thread.start()
    try:
        yield server
    finally:
        server.httpd.shutdown()
        server.httpd.server_close()


def test_is_remote_tells_urls_from_paths() -> None:
    assert is_remote("https://example.org/x/")
    assert is_remote("hf://datasets/user/repo")
    assert not is_remote("release/")
    assert not is_remote(Path("http:/x"))


def test_default_cache_dir_follows_xdg(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert default_cache_dir() == tmp_path / "vptoolkit"


def test_first_open_downloads_and_verifies_the_second_uses_the_cache(
        served: _Server, release: Path, tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    with open_dataset(served.url, cache_dir=cache) as remote, open_dataset(release) as local:
        assert remote.names == local.names
        np.testing.assert_array_equal(remote[3]["quality"], local[3]["quality"])
        assert remote.path.parent.parent.parent == cache
    first = served.downloads()
    assert any(path.endswith(".h5") for path in first)
    assert not any(path.endswith(".parquet") for path in first)  # only what reading needs
    served.requests.clear()
    with open_dataset(served.url, cache_dir=cache) as again:
        assert len(again) == len(local.names)
    assert served.requests == ["/release/SHA256SUMS"]
    cached = [p for p in cache.rglob("*") if p.is_file()]
    assert not [p for p in cached if p.name.startswith(".")]


def test_a_changed_release_is_fetched_again(served: _Server, tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    first = fetch_release(served.url, cache_dir=cache)
    manifest = served.folder / "release" / "SHA256SUMS"
    manifest.write_text(manifest.read_text(encoding="utf-8") + "\n", encoding="utf-8")
    served.requests.clear()
    second = fetch_release(served.url, cache_dir=cache)
    assert second != first
    assert any(path.endswith(".h5") for path in served.downloads())


def test_a_corrupted_download_is_refused_and_not_cached(served: _Server, tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    archive = next((served.folder / "release").glob("*.h5"))
    data = bytearray(archive.read_bytes())
    data[len(data) // 2] ^= 0xFF
    archive.write_bytes(bytes(data))
    with pytest.raises(VerificationError, match=r"\.h5: SHA-256 .* differs from SHA256SUMS"):
        open_dataset(served.url, cache_dir=cache)
    assert not [p for p in cache.rglob("*") if p.is_file() and p.name.endswith(".h5")]
    assert not [p for p in cache.rglob(".*")]  # no temporary file left
    result = CliRunner().invoke(main, ["info", served.url, "--cache-dir", str(cache)])
    assert result.exit_code == 1
    assert len(result.output.strip().splitlines()) == 1
    assert "differs from SHA256SUMS" in result.output


def test_a_missing_release_is_one_line_naming_the_url(served: _Server, tmp_path: Path) -> None:
    url = served.url.replace("/release/", "/nothing/")
    with pytest.raises(InputError, match=r"nothing/SHA256SUMS: HTTP 404"):
        fetch_release(url, cache_dir=tmp_path)
    result = CliRunner().invoke(main, ["verify", url, "--cache-dir", str(tmp_path)])
    assert result.exit_code == 2
    assert "HTTP 404" in result.output


def test_a_url_naming_an_archive_fetches_that_archive(served: _Server, release: Path,
                                                      tmp_path: Path) -> None:
    name = next(release.glob("*.h5")).name
    path = fetch_release(served.url + name, cache_dir=tmp_path)
    assert path.name == name and path.is_file()


def test_cli_info_and_verify_read_a_url(served: _Server, tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    result = CliRunner().invoke(main, ["info", served.url, "--cache-dir", str(cache)])
    assert result.exit_code == 0, result.output
    assert "airplane" in result.output
    result = CliRunner().invoke(main, ["verify", served.url, "--cache-dir", str(cache)])
    assert result.exit_code == 0, result.output
    assert any(path.endswith(".parquet") for path in served.downloads())


def test_a_file_url_goes_through_fsspec(release: Path, tmp_path: Path) -> None:
    require_package("fsspec")
    with open_dataset(release.as_uri(), cache_dir=tmp_path) as dataset:
        assert len(dataset) > 0


def test_cli_evaluate_scores_against_a_release_url_as_against_the_folder(
        served: _Server, release: Path, tmp_path: Path) -> None:
    import json

    from vptoolkit.evaluate.baselines import oracle_directions

    with open_dataset(release) as dataset:
        np.save(tmp_path / "oracle.npy", oracle_directions(dataset.split("test")))
    remote = CliRunner().invoke(main, ["evaluate", str(tmp_path / "oracle.npy"), "--dataset",
                                       served.url, "--cache-dir", str(tmp_path / "cache"),
                                       "--json"])
    local = CliRunner().invoke(main, ["evaluate", str(tmp_path / "oracle.npy"), "--dataset",
                                      str(release), "--json"])
    assert remote.exit_code == 0, remote.output
    assert json.loads(remote.stdout) == json.loads(local.stdout)
