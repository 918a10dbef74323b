"""Opening a release from a URL: a local http.server in the test serves a packed release."""

from __future__ import annotations

import functools
import hashlib
import http.server
import json
import logging
import os
import pickle
import shutil
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner, Result

from fixtures.environment import require_package
from fixtures.releases import write_release_build
from vptoolkit.cli import main
from vptoolkit.data import download, open_dataset, ranges, remote
from vptoolkit.data.remote import default_cache_dir, fetch_release, is_remote
from vptoolkit.dataset.release.manifest import write_sha256sums
from vptoolkit.dataset.release.options import ReleaseOptions
from vptoolkit.errors import InputError, VerificationError


@pytest.fixture(autouse=True)
def _quick_retries(monkeypatch: pytest.MonkeyPatch) -> None:
    """Retries wait milliseconds, not seconds."""
    monkeypatch.setattr(download, "BACKOFF_S", 0.001)


@pytest.fixture(scope="module")
def release(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A release with Parquet shards and an HDF5 archive (the default formats)."""
    require_package("h5py")
    require_package("pyarrow")
    from vptoolkit.dataset.release.pack import pack_release

    base = tmp_path_factory.mktemp("remote")
    write_release_build(base / "build")
    return pack_release(base / "build", base / "release",
                        ReleaseOptions(formats=["parquet", "hdf5"], license="cc-by-4.0",
                                       force_license=True)).path


Route = Callable[[http.server.BaseHTTPRequestHandler], None]
"""Answers one request in place of the file server."""


class _Server:
    """A release folder served on 127.0.0.1 (port chosen by the system); counts requests.

    ``routes`` maps a request path to a :data:`Route` that answers it instead.
    """

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.requests: list[str] = []
        self.ranges: list[str | None] = []  # the Range header of each request
        self.routes: dict[str, Route] = {}
        self.serves_ranges = True
        log, ranges, routes, server = self.requests, self.ranges, self.routes, self

        class Handler(http.server.SimpleHTTPRequestHandler):
            def do_GET(self) -> None:  # noqa: N802 - the http.server name
                log.append(self.path)
                ranges.append(self.headers.get("Range"))
                if self.path in routes:
                    routes[self.path](self)
                elif server.serves_ranges and self.headers.get("Range"):
                    _send_range(self, Path(self.translate_path(self.path)))
                else:
                    super().do_GET()

            def log_message(self, *args: object) -> None:
                pass

        handler = functools.partial(Handler, directory=str(folder))
        self.httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/release/"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)

    def stop(self) -> None:
        """Stop serving and close the socket: every later request is refused."""
        self.httpd.shutdown()
        self.httpd.server_close()

    def downloads(self) -> list[str]:
        """The paths requested other than the manifest."""
        return [path for path in self.requests if not path.endswith("/SHA256SUMS")]

    def path_of(self, name: str) -> str:
        """The request path of a file of the served release."""
        return f"/release/{name}"


def _send(body: bytes, *, announced: int | None = None, chunked: bool = False,
          byte_every_s: float = 0.0) -> Route:
    """A route answering 200 with ``body`` (at most its bytes, then the connection closes).

    ``announced`` is the Content-Length sent (none if None), ``chunked`` sends
    one chunk header announcing twice the body, ``byte_every_s`` trickles it
    one byte at a time.
    """
    def route(handler: http.server.BaseHTTPRequestHandler) -> None:
        handler.send_response(200)
        handler.send_header("Connection", "close")
        if announced is not None:
            handler.send_header("Content-Length", str(announced))
        if chunked:
            handler.send_header("Transfer-Encoding", "chunked")
        handler.end_headers()
        handler.close_connection = True
        try:
            if chunked:
                handler.wfile.write(f"{2 * len(body):x}\r\n".encode())
            if byte_every_s:
                for index in range(len(body)):
                    handler.wfile.write(body[index:index + 1])
                    handler.wfile.flush()
                    time.sleep(byte_every_s)
            else:
                for start in range(0, len(body), 1 << 16):
                    handler.wfile.write(body[start:start + (1 << 16)])
        except (BrokenPipeError, ConnectionResetError):
            pass  # the client gave up, as it should

    return route


def _send_range(handler: http.server.BaseHTTPRequestHandler, path: Path) -> None:
    """Answer ``Range: bytes=<first>-[<last>]`` with 206 and that part of ``path``."""
    first_text, last_text = handler.headers["Range"].removeprefix("bytes=").split("-")
    data = path.read_bytes()
    first = int(first_text)
    last = min(int(last_text), len(data) - 1) if last_text else len(data) - 1
    if first >= len(data):
        handler.send_error(416)
        return
    handler.send_response(206)
    handler.send_header("Content-Range", f"bytes {first}-{last}/{len(data)}")
    handler.send_header("Content-Length", str(last + 1 - first))
    handler.end_headers()
    handler.wfile.write(data[first:last + 1])


def _fail_first(times: int, answer: Route) -> Route:
    """A route answering with ``answer`` ``times`` times, then as the file server does."""
    left = [times]

    def route(handler: http.server.BaseHTTPRequestHandler) -> None:
        if left[0] > 0:
            left[0] -= 1
            answer(handler)
        elif handler.headers.get("Range"):
            _send_range(handler, Path(handler.translate_path(handler.path)))
        else:
            http.server.SimpleHTTPRequestHandler.do_GET(handler)

    return route


def _status(code: int) -> Route:
    """A route answering ``code`` with an empty body."""
    def route(handler: http.server.BaseHTTPRequestHandler) -> None:
        handler.send_response(code)
        handler.send_header("Content-Length", "0")
        handler.end_headers()

    return route


def _redirect(location: str) -> Route:
    """A route answering 302 to ``location``."""
    def route(handler: http.server.BaseHTTPRequestHandler) -> None:
        handler.send_response(302)
        handler.send_header("Location", location)
        handler.send_header("Content-Length", "0")
        handler.end_headers()

    return route


def _archive_name(served: _Server) -> str:
    return next((served.folder / "release").glob("*.h5")).name


def _cached(cache: Path) -> list[Path]:
    """Every file and folder below the cache's release folders."""
    return sorted(path for path in cache.rglob("*") if "releases" in path.parts)


def _one_line(result: Result, code: int) -> str:
    """The CLI's one error line, checked for its exit code."""
    assert result.exit_code == code, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


@pytest.fixture()
def served(release: Path, tmp_path: Path) -> Iterator[_Server]:
    root = tmp_path / "www"
    shutil.copytree(release, root / "release")
    server = _Server(root)
    server.thread.start()
    try:
        yield server
    finally:
        server.stop()


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
    with open_dataset(served.url, cache_dir=cache, partial=False) as remote, \
            open_dataset(release) as local:
        assert remote.names == local.names
        np.testing.assert_array_equal(remote[3]["quality"], local[3]["quality"])
        assert remote.path.parent.parent.parent == cache
    first = served.downloads()
    assert any(path.endswith(".h5") for path in first)
    assert not any(path.endswith(".parquet") for path in first)  # only what reading needs
    served.requests.clear()
    with open_dataset(served.url, cache_dir=cache) as again:  # cached: not read by ranges
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
        open_dataset(served.url, cache_dir=cache, partial=False)
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


@pytest.mark.parametrize("announced", [None, 10**15], ids=["endless", "content-length-1e15"])
def test_a_manifest_over_its_cap_is_one_line_naming_the_url(
        served: _Server, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        announced: int | None) -> None:
    monkeypatch.setattr(remote, "MAX_MANIFEST_BYTES", 1 << 20)
    served.routes[served.path_of("SHA256SUMS")] = _send(b"a" * (4 << 20), announced=announced)
    message = r"release/SHA256SUMS: more than 1048576 bytes, the most a SHA256SUMS manifest"
    with pytest.raises(InputError, match=message):
        fetch_release(served.url, cache_dir=tmp_path)
    result = CliRunner().invoke(main, ["info", served.url, "--cache-dir", str(tmp_path)])
    assert "release/SHA256SUMS: more than 1048576 bytes" in _one_line(result, 2)
    assert not _cached(tmp_path)


def test_names_the_reader_does_not_read_are_not_downloaded(served: _Server,
                                                           tmp_path: Path) -> None:
    manifest = served.folder / "release" / "SHA256SUMS"
    extra = "".join(f"{'0' * 64}  x{number:06d}.bin\n" for number in range(200_000))
    manifest.write_text(manifest.read_text(encoding="utf-8") + extra, encoding="utf-8")
    with open_dataset(served.url, cache_dir=tmp_path, partial=False) as dataset:
        assert len(dataset) > 0
    assert sorted(served.downloads()) == sorted(
        served.path_of(name) for name in ("README.md", "croissant.json", _archive_name(served)))


def _record_size(folder: Path, name: str, size: int) -> None:
    """Rewrite a release's croissant.json so that it records ``size`` bytes for ``name``."""
    croissant = folder / "croissant.json"
    document = json.loads(croissant.read_text(encoding="utf-8"))
    for entry in document["distribution"]:
        if entry.get("contentUrl") == name:
            entry["contentSize"] = f"{size} B"
    croissant.write_text(json.dumps(document), encoding="utf-8")
    write_sha256sums(folder)


@pytest.mark.parametrize("case", ["recorded-smaller", "endless", "unrecorded"])
def test_a_file_past_its_size_is_refused_and_nothing_is_cached(
        served: _Server, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, case: str) -> None:
    name = _archive_name(served)
    size = (served.folder / "release" / name).stat().st_size
    if case == "recorded-smaller":
        _record_size(served.folder / "release", name, 1000)
        message = rf"{name}: more than 1000 bytes, its contentSize in croissant.json"
    elif case == "endless":  # no Content-Length: refused once the recorded size is passed
        served.routes[served.path_of(name)] = _send(b"\0" * (8 << 20))
        message = rf"{name}: more than {size} bytes, its contentSize in croissant.json"
    else:
        (served.folder / "release" / "croissant.json").unlink()
        write_sha256sums(served.folder / "release")
        monkeypatch.setattr(remote, "MAX_FILE_BYTES", 1000)
        message = rf"{name}: more than 1000 bytes, the most one file may hold"
    with pytest.raises(InputError, match=message):
        fetch_release(served.url, cache_dir=tmp_path)
    assert not [path for path in _cached(tmp_path) if name in path.name]


def test_a_file_url_is_bounded_by_the_recorded_size_too(release: Path, tmp_path: Path) -> None:
    require_package("fsspec")
    copy = shutil.copytree(release, tmp_path / "release")
    name = next(copy.glob("*.h5")).name
    _record_size(copy, name, 1000)
    with pytest.raises(InputError, match=rf"{name}: more than 1000 bytes, its contentSize"):
        fetch_release(copy.as_uri(), cache_dir=tmp_path / "cache")


@pytest.mark.parametrize("where", ["manifest", "archive", "chunked-manifest"])
def test_a_download_cut_short_is_one_line_exit_2(served: _Server, tmp_path: Path,
                                                 where: str) -> None:
    name = "SHA256SUMS" if where.endswith("manifest") else _archive_name(served)
    body = (served.folder / "release" / name).read_bytes()[:406]
    served.routes[served.path_of(name)] = (
        _send(body, chunked=True) if where == "chunked-manifest" else _send(body, announced=812))
    with pytest.raises(InputError, match=rf"{name}: download broke off"):
        fetch_release(served.url, cache_dir=tmp_path)
    result = CliRunner().invoke(main, ["info", served.url, "--cache-dir", str(tmp_path)])
    assert f"{name}: download broke off" in _one_line(result, 2)
    if where == "manifest":
        assert "(406 of the 812 bytes announced)" in result.output
    assert "gave up after 4 tries" in result.output
    kept = [path.name for path in _cached(tmp_path) if name in path.name]
    assert kept == ([] if name == "SHA256SUMS" else [f".{name}.download"])  # to go on from


@pytest.mark.parametrize("where", ["manifest", "archive"])
def test_a_trickling_server_is_refused_below_the_minimum_rate(
        served: _Server, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, where: str) -> None:
    monkeypatch.setattr(download, "GRACE_S", 0.5)
    monkeypatch.setattr(download, "MIN_BYTES_PER_S", 1000)
    name = "SHA256SUMS" if where == "manifest" else _archive_name(served)
    # 100 bytes at one per 0.1 s: done after 10 s at most, refused after about 0.6 s
    served.routes[served.path_of(name)] = _send(b"x" * 100, announced=100, byte_every_s=0.1)
    with pytest.raises(InputError, match=rf"{name}: too slow \(\d+ bytes in \d+ s, below 1000"):
        fetch_release(served.url, cache_dir=tmp_path)
    assert not [path for path in _cached(tmp_path) if name in path.name]


def test_a_killed_download_leaves_no_partial_file_for_long(served: _Server,
                                                           tmp_path: Path) -> None:
    fcntl = pytest.importorskip("fcntl")
    cache = tmp_path / "cache"
    folder = fetch_release(served.url, cache_dir=cache)
    name = _archive_name(served)
    (folder / name).unlink()  # as kill -9 during its download and the card's leaves them
    (folder / "README.md").unlink()
    stale = [folder / f".{name}.0123abcd.partial", folder / ".README.md.4567cdef.partial"]
    for path in stale:
        path.write_bytes(b"half")
    live = folder / f".{name}.89abcdef.partial"  # another process is writing it
    live.write_bytes(b"half")
    handle = os.open(live, os.O_RDONLY)
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        fetch_release(served.url, cache_dir=cache)
        assert not any(path.exists() for path in stale)
        assert live.exists()
    finally:
        os.close(handle)
    (folder / name).unlink()
    result = CliRunner().invoke(main, ["verify", served.url, "--cache-dir", str(cache)])
    assert result.exit_code == 0, result.output
    assert "partial" not in result.output and "not listed" not in result.output
    assert not [path for path in folder.iterdir() if path.name.startswith(".")]


@pytest.mark.parametrize(("line", "problem"), [
    (".", r"lists '\.', which is not the path of a file"),
    ("data//x.parquet", r"lists 'data//x\.parquet', which is not the path of a file"),
    ("README.md/x", r"lists README\.md both as a file and as the folder of README\.md/x"),
], ids=["dot", "empty-part", "below-a-file"])
def test_a_manifest_path_that_names_no_file_is_one_line(served: _Server, tmp_path: Path,
                                                        line: str, problem: str) -> None:
    manifest = served.folder / "release" / "SHA256SUMS"
    manifest.write_text(manifest.read_text(encoding="utf-8") + f"{'0' * 64}  {line}\n",
                        encoding="utf-8")
    with pytest.raises(VerificationError, match=rf"release/SHA256SUMS: {problem}"):
        fetch_release(served.url, cache_dir=tmp_path, everything=True)
    result = CliRunner().invoke(main, ["verify", served.url, "--cache-dir", str(tmp_path)])
    assert "release/SHA256SUMS: lists" in _one_line(result, 1)
    assert not _cached(tmp_path)


def test_a_redirect_to_another_scheme_than_http_is_refused(served: _Server,
                                                           tmp_path: Path) -> None:
    served.routes[served.path_of("SHA256SUMS")] = _redirect("ftp://127.0.0.1:9/SHA256SUMS")
    with pytest.raises(InputError, match=r"release/SHA256SUMS: HTTP 302 .* Redirection to url "
                                         r"'ftp://127\.0\.0\.1:9/SHA256SUMS' is not allowed"):
        fetch_release(served.url, cache_dir=tmp_path)
    moved = served.url.replace("/release/", "/moved/")
    served.routes["/moved/SHA256SUMS"] = _redirect(served.url + "SHA256SUMS")
    served.routes.pop(served.path_of("SHA256SUMS"))
    with pytest.raises(InputError, match=r"moved/croissant\.json: HTTP 404"):
        fetch_release(moved, cache_dir=tmp_path)  # an http redirect is followed


@pytest.mark.parametrize("damage", ["flipped-byte", "truncated"])
def test_a_cached_file_that_changed_is_fetched_again(served: _Server, release: Path,
                                                     tmp_path: Path, damage: str) -> None:
    folder = fetch_release(served.url, cache_dir=tmp_path)
    cached = folder / _archive_name(served)
    data = bytearray(cached.read_bytes())
    if damage == "truncated":
        del data[len(data) // 2:]
    else:
        data[len(data) // 2] ^= 0xFF
    with cached.open("r+b") as stream:  # in place, as a stray write would
        stream.write(bytes(data))
        stream.truncate()
    served.requests.clear()
    with open_dataset(served.url, cache_dir=tmp_path, partial=False) as remote_set, \
            open_dataset(release) as local:
        np.testing.assert_array_equal(remote_set[3]["quality"], local[3]["quality"])
    assert served.downloads() == [served.path_of(cached.name)]


def test_an_unchanged_cache_is_not_hashed_again(served: _Server, tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    fetch_release(served.url, cache_dir=tmp_path)

    def refuse(path: object) -> str:
        raise AssertionError(f"{path} hashed again")

    monkeypatch.setattr(remote, "sha256_file", refuse)
    served.requests.clear()
    fetch_release(served.url, cache_dir=tmp_path)
    assert served.downloads() == []


def _release_folder(served: _Server, cache: Path) -> Path:
    """The cache folder of the served release (named by the SHA-256 of its SHA256SUMS)."""
    listing = (served.folder / "release" / "SHA256SUMS").read_bytes()
    return cache / "releases" / hashlib.sha256(listing).hexdigest()


def test_a_complete_cache_opens_offline_with_one_notice(
        served: _Server, release: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    cache = tmp_path / "cache"
    fetch_release(served.url, cache_dir=cache)
    served.stop()
    notice = f"offline: using the cached copy of {served.url.rstrip('/')}"
    with caplog.at_level(logging.WARNING, logger="vptoolkit.data.remote"):
        result = CliRunner().invoke(main, ["info", served.url, "--cache-dir", str(cache)])
        assert result.exit_code == 0, result.output
        assert "airplane" in result.output
        with open_dataset(served.url, cache_dir=cache) as remote_set, \
                open_dataset(release) as local:
            np.testing.assert_array_equal(remote_set[3]["quality"], local[3]["quality"])
    assert [record.getMessage() for record in caplog.records] == [notice]  # once per process
    (_release_folder(served, cache) / _archive_name(served)).unlink()  # no longer complete
    with pytest.raises(InputError,
                       match=r"release/SHA256SUMS: cannot be fetched .*gave up after 4"):
        open_dataset(served.url, cache_dir=cache)


def test_an_http_error_is_not_taken_for_offline(served: _Server, tmp_path: Path) -> None:
    fetch_release(served.url, cache_dir=tmp_path)
    served.routes[served.path_of("SHA256SUMS")] = _status(404)
    with pytest.raises(InputError, match=r"release/SHA256SUMS: HTTP 404"):
        fetch_release(served.url, cache_dir=tmp_path)


def test_a_download_is_tried_again_after_two_503s(served: _Server, tmp_path: Path) -> None:
    name = _archive_name(served)
    served.routes[served.path_of(name)] = _fail_first(2, _status(503))
    served.routes[served.path_of("SHA256SUMS")] = _fail_first(2, _status(503))
    folder = fetch_release(served.url, cache_dir=tmp_path)
    assert (folder / name).read_bytes() == (served.folder / "release" / name).read_bytes()
    assert served.requests.count(served.path_of(name)) == 3
    assert served.requests.count(served.path_of("SHA256SUMS")) == 3
    served.routes[served.path_of("SHA256SUMS")] = _status(503)
    with pytest.raises(InputError, match=r"SHA256SUMS: HTTP 503 .*; gave up after 4 tries"):
        fetch_release(served.url, cache_dir=tmp_path / "other")


@pytest.mark.parametrize("case", ["broken-off", "left-by-a-killed-run", "no-ranges", "damaged"])
def test_a_partial_download_goes_on_with_a_range_request(served: _Server, tmp_path: Path,
                                                         case: str) -> None:
    name = _archive_name(served)
    data = (served.folder / "release" / name).read_bytes()
    half = len(data) // 2
    if case == "broken-off":  # the first answer stops half way: the second try asks for the rest
        served.routes[served.path_of(name)] = _fail_first(
            1, _send(data[:half], announced=len(data)))
    else:  # a partial file that a killed run left
        partial = _release_folder(served, tmp_path) / f".{name}.download"
        partial.parent.mkdir(parents=True)
        partial.write_bytes(data[:half] if case != "damaged" else b"\0" * half)
        served.serves_ranges = case != "no-ranges"
    folder = fetch_release(served.url, cache_dir=tmp_path)
    assert (folder / name).read_bytes() == data
    asked = [ranges for path, ranges in zip(served.requests, served.ranges, strict=True)
             if path == served.path_of(name)]
    assert asked[-1 if case != "damaged" else -2] == f"bytes={half}-"
    if case == "damaged":  # the resumed file did not match: fetched again, whole
        assert asked[-1] is None
    assert not [path for path in folder.iterdir() if path.name.startswith(".")]


def _range_bytes(served: _Server, name: str) -> int:
    """Bytes the archive's requests asked for, all by Range (none asked for the whole file)."""
    asked = [ranges for path, ranges in zip(served.requests, served.ranges, strict=True)
             if path == served.path_of(name)]
    assert asked and None not in asked, asked
    spans = [text.removeprefix("bytes=").split("-") for text in asked if text is not None]
    return sum(int(last) + 1 - int(first) for first, last in spans)


def test_one_split_is_read_by_ranges_with_the_arrays_of_a_local_open(
        served: _Server, release: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(ranges, "RANGE_BLOCK_BYTES", 4 << 10)
    name = _archive_name(served)
    with open_dataset(served.url, cache_dir=tmp_path) as remote_set, \
            open_dataset(release) as local:
        remote_test, local_test = remote_set.split("test"), local.split("test")
        assert remote_test.names == local_test.names
        np.testing.assert_array_equal(remote_test.array("quality"), local_test.array("quality"))
        for key in ("points", "normals", "quality_raw", "best_index"):
            np.testing.assert_array_equal(remote_test[0][key], local_test[0][key])
        for remote_part, local_part in zip(remote_test.mesh(0), local_test.mesh(0), strict=True):
            np.testing.assert_array_equal(remote_part, local_part)
        assert remote_set.path.name == name and not remote_set.path.exists()
    assert _range_bytes(served, name) < (served.folder / "release" / name).stat().st_size
    assert not [path for path in _cached(tmp_path) if name in path.name]  # nothing half-cached


def test_a_server_without_ranges_gets_the_whole_verified_download(
        served: _Server, release: Path, tmp_path: Path) -> None:
    served.serves_ranges = False
    name = _archive_name(served)
    with open_dataset(served.url, cache_dir=tmp_path) as remote_set, \
            open_dataset(release) as local:
        np.testing.assert_array_equal(remote_set[3]["quality"], local[3]["quality"])
        assert remote_set.path.read_bytes() == (served.folder / "release" / name).read_bytes()
    asked = [ranges for path, ranges in zip(served.requests, served.ranges, strict=True)
             if path == served.path_of(name)]
    assert asked == ["bytes=0-0", None]  # the probe answered 200, then the whole file


def _answer_range(content_range: Callable[[int, int, int], str]) -> Route:
    """A route answering a Range request with 206, the bytes asked for and ``content_range``.

    ``content_range(first, last, size)`` gives the header sent.
    """
    def route(handler: http.server.BaseHTTPRequestHandler) -> None:
        data = Path(handler.translate_path(handler.path)).read_bytes()
        first_text, last_text = handler.headers["Range"].removeprefix("bytes=").split("-")
        first, last = int(first_text), int(last_text)
        handler.send_response(206)
        handler.send_header("Content-Range", content_range(first, last, len(data)))
        handler.send_header("Content-Length", str(last + 1 - first))
        handler.end_headers()
        handler.wfile.write(data[first:last + 1])

    return route


@pytest.mark.parametrize("case", ["wrong-start", "wrong-total", "recorded-size-differs",
                                  "wrong-later"])
def test_a_wrong_content_range_or_size_is_one_line_naming_the_url(
        served: _Server, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, case: str) -> None:
    monkeypatch.setattr(ranges, "RANGE_BLOCK_BYTES", 16 << 10)
    name = _archive_name(served)
    folder = served.folder / "release"
    wrong = _answer_range(lambda first, last, size: f"bytes {first + 1}-{last + 1}/{size}")
    if case == "wrong-start":
        served.routes[served.path_of(name)] = wrong
    elif case == "wrong-total":
        served.routes[served.path_of(name)] = _answer_range(
            lambda first, last, size: f"bytes {first}-{last}/{size + 1}")
    elif case == "recorded-size-differs":
        _record_size(folder, name, (folder / name).stat().st_size - 1)
    with pytest.raises(InputError) as raised:
        with open_dataset(served.url, cache_dir=tmp_path) as dataset:
            served.routes[served.path_of(name)] = wrong  # the server goes wrong after the open
            dataset.array("points")
    message = str(raised.value)
    assert message.startswith(served.url + name + ": answered a request for bytes ")
    assert "\n" not in message and "Content-Range" in message
    assert not [path for path in _cached(tmp_path) if name in path.name]


def test_a_pickled_split_reopens_over_ranges(served: _Server, release: Path,
                                             tmp_path: Path) -> None:
    name = _archive_name(served)
    with open_dataset(served.url, cache_dir=tmp_path) as remote_set, \
            open_dataset(release) as local:
        remote_test = remote_set.split("test")
        served.requests.clear()
        served.ranges.clear()
        copy = pickle.loads(pickle.dumps(remote_test))  # as a data loader's worker receives it
        for key in ("points", "quality"):
            np.testing.assert_array_equal(copy[1][key], local.split("test")[1][key])
        assert _range_bytes(served, name) > 0  # reopened by ranges, not downloaded
    assert not [path for path in _cached(tmp_path) if name in path.name]


def test_ranges_of_damaged_hdf5_metadata_are_a_verification_error(
        served: _Server, tmp_path: Path) -> None:
    name = _archive_name(served)
    data = bytearray((served.folder / "release" / name).read_bytes())
    data[data.index(b"FRHP") + 12] ^= 1  # the root attributes' heap, under its checksum
    damaged = tmp_path / "damaged.h5"
    damaged.write_bytes(bytes(data))
    served.routes[served.path_of(name)] = lambda handler: _send_range(handler, damaged)
    with pytest.raises(VerificationError) as raised:
        open_dataset(served.url, cache_dir=tmp_path / "cache")
    message = str(raised.value)
    assert message.startswith(f"{served.url}{name}: the bytes served by ranges do not read as "
                              f"the archive ({name}: the HDF5 metadata cannot be read"), message
    assert "partial=False downloads the whole archive" in message and "\n" not in message


def test_verify_of_a_url_names_a_content_size_that_lies(served: _Server, tmp_path: Path) -> None:
    name = _archive_name(served)
    folder = served.folder / "release"
    size = (folder / name).stat().st_size
    _record_size(folder, name, size + 1)
    line = _one_line(CliRunner().invoke(
        main, ["verify", served.url, "--cache-dir", str(tmp_path)]), 1)
    assert f"{name}: croissant.json records {size + 1} bytes, the file has {size}" in line


class _ConnectError(Exception):
    """A client's failure to connect that is not an ``OSError``, as ``httpx.ConnectError``."""


@pytest.fixture()
def hub(release: Path) -> Iterator[type]:
    """The release on a fake fsspec file system, ``fakehub://rel``, in memory; its class
    attribute ``reachable`` set to False makes every open fail as an unknown host does."""
    require_package("fsspec")
    import fsspec
    from fsspec.implementations.memory import MemoryFileSystem

    class FakeHub(MemoryFileSystem):
        protocol = "fakehub"
        store: dict[str, object] = {}
        pseudo_dirs = [""]
        reachable = True

        @classmethod
        def _strip_protocol(cls, path: str) -> str:
            return super()._strip_protocol(str(path).removeprefix("fakehub://"))

        def _open(self, path: str, mode: str = "rb", **kwargs: object) -> object:
            if not FakeHub.reachable:
                raise _ConnectError("[Errno -2] Name or service not known")
            return super()._open(path, mode, **kwargs)

    fsspec.register_implementation("fakehub", FakeHub, clobber=True)
    hub_fs = FakeHub(skip_instance_cache=True)
    for file in release.rglob("*"):
        if file.is_file():
            hub_fs.pipe(f"/rel/{file.relative_to(release).as_posix()}", file.read_bytes())
    yield FakeHub
    FakeHub.store.clear()


def test_an_unreachable_fsspec_release_is_one_line_and_its_complete_cache_is_used(
        hub: type, tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    url = "fakehub://rel"
    cache = tmp_path / "cache"
    hub.reachable = False
    line = _one_line(CliRunner().invoke(main, ["info", url, "--cache-dir", str(cache)]), 2)
    assert line == (f"vptool: error: {url}/SHA256SUMS: cannot be fetched ([Errno -2] Name or "
                    "service not known); gave up after 4 tries")
    hub.reachable = True
    fetch_release(url, cache_dir=cache)
    hub.reachable = False
    with caplog.at_level(logging.WARNING, logger="vptoolkit.data.remote"):
        result = CliRunner().invoke(main, ["info", url, "--cache-dir", str(cache)])
    assert result.exit_code == 0, result.output
    assert "airplane" in result.output
    assert f"offline: using the cached copy of {url}" in caplog.text


def test_an_fsspec_scheme_that_connects_when_opened_names_the_url(tmp_path: Path) -> None:
    require_package("fsspec")
    import socket

    with socket.socket() as probe:  # a port on 127.0.0.1 that nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    url = f"ftp://127.0.0.1:{port}/ok/"
    line = _one_line(CliRunner().invoke(main, ["info", url, "--cache-dir", str(tmp_path)]), 2)
    assert line.startswith(f"vptool: error: {url.rstrip('/')}: cannot be fetched (")


def test_a_copied_cache_opens_offline_and_a_ranged_one_says_it_is_incomplete(
        served: _Server, tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    fetch_release(served.url, cache_dir=cache)
    ranged = tmp_path / "ranged"
    with open_dataset(served.url, cache_dir=ranged) as dataset:  # the archive read by ranges
        assert len(dataset) > 0
    served.stop()
    copied = tmp_path / "copied"
    shutil.copytree(cache, copied)  # bytes and modification times kept, new change times
    with open_dataset(served.url, cache_dir=copied) as offline, open_dataset(
            _release_folder(served, cache) / _archive_name(served)) as local:
        np.testing.assert_array_equal(offline[2]["quality"], local[2]["quality"])
    with pytest.raises(InputError, match=r"cannot be fetched .*; the cached copy in .* is "
                                         r"incomplete \(no .*\.h5; an archive read by byte "
                                         r"ranges is not cached\)"):
        open_dataset(served.url, cache_dir=ranged)


def test_a_range_answer_longer_than_asked_says_so(served: _Server, tmp_path: Path) -> None:
    name = _archive_name(served)

    def longer(handler: http.server.BaseHTTPRequestHandler) -> None:
        data = Path(handler.translate_path(handler.path)).read_bytes()
        first, last = map(int, handler.headers["Range"].removeprefix("bytes=").split("-"))
        handler.send_response(206)
        handler.send_header("Content-Range", f"bytes {first}-{last}/{len(data)}")
        handler.send_header("Content-Length", str(last + 2 - first))
        handler.end_headers()
        handler.wfile.write(data[first:last + 2])

    served.routes[served.path_of(name)] = longer
    with pytest.raises(InputError, match=r"answered a request for bytes 0-0/\d+ with a body of 2 "
                                         r"bytes, more than the 1 asked for"):
        open_dataset(served.url, cache_dir=tmp_path)


def test_a_manifest_cut_short_by_its_content_length_is_named(served: _Server,
                                                              tmp_path: Path) -> None:
    listing = (served.folder / "release" / "SHA256SUMS").read_bytes()
    half = len(listing) // 2 + 7  # within a line
    served.routes[served.path_of("SHA256SUMS")] = _send(listing[:half], announced=half)
    line = _one_line(CliRunner().invoke(main, ["info", served.url, "--cache-dir",
                                               str(tmp_path)]), 1)
    assert "SHA256SUMS: ends in the middle of line" in line and "cut short?" in line


def test_bytes_from_the_wrong_offset_are_named_as_the_servers(served: _Server,
                                                              tmp_path: Path) -> None:
    name = _archive_name(served)
    data = (served.folder / "release" / name).read_bytes()
    shifted = tmp_path / "shifted.h5"  # every block from one byte further on, the size kept
    shifted.write_bytes(data[:4096] + data[4097:] + b"\0")
    served.routes[served.path_of(name)] = lambda handler: _send_range(handler, shifted)
    with pytest.raises((InputError, VerificationError)) as raised:
        with open_dataset(served.url, cache_dir=tmp_path / "cache") as dataset:
            dataset.array("points")
    message = str(raised.value)
    assert message.startswith(f"{served.url}{name}: the bytes served by ranges do not read"), \
        message
    assert "cache" not in message.split("(")[0]
