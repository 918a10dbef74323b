"""Bytes a remote open reads: one split and one model of a served release.

Builds a release from synthetic shapes (``write_collection``, ``vptool
build-dataset``, ``vptool pack``), larger than the bundled samples, serves it
on 127.0.0.1 (a port the system picks) with a handler that counts the bytes it
sends and answers Range requests, and prints, for a fresh cache each time, the
bytes sent to open the release and read one split, and to read one model: with
the whole archive downloaded and verified (``partial=False``) and read by
ranges (``partial=True``, the default). With ``--results FILE`` what it
printed replaces the ``remote`` section of FILE (``docs/benchmarks.md``).

    python tools/bench_remote.py --per-category 30 --work /tmp/bench-remote
    python tools/bench_remote.py --results docs/benchmarks.md
"""

from __future__ import annotations

import argparse
import functools
import http.server
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path

from results_doc import add_results_option, printed_section

from vptoolkit.data import ViewpointDataset, open_dataset
from vptoolkit.synthetic import write_collection


class _CountingHandler(http.server.SimpleHTTPRequestHandler):
    """Serves a folder, answers ``Range: bytes=a-[b]`` with 206, and adds up the body bytes."""

    sent = [0]

    def do_GET(self) -> None:  # noqa: N802 - the http.server name
        path = Path(self.translate_path(self.path))
        wanted = self.headers.get("Range")
        if not path.is_file() or not wanted:
            super().do_GET()
            return
        data = path.read_bytes()
        first_text, last_text = wanted.removeprefix("bytes=").split("-")
        first = int(first_text)
        last = min(int(last_text), len(data) - 1) if last_text else len(data) - 1
        self.send_response(206)
        self.send_header("Content-Range", f"bytes {first}-{last}/{len(data)}")
        self.send_header("Content-Length", str(last + 1 - first))
        self.end_headers()
        self.wfile.write(data[first:last + 1])
        self.sent[0] += last + 1 - first

    def copyfile(self, source, outputfile) -> None:  # type: ignore[no-untyped-def]
        before = source.tell()
        super().copyfile(source, outputfile)
        self.sent[0] += source.tell() - before

    def log_message(self, *args: object) -> None:
        pass


def build_release(work: Path, per_category: int) -> Path:
    """A packed release of ``per_category`` synthetic models in each category, built once."""
    release = work / "release"
    if (release / "SHA256SUMS").is_file():
        return release
    write_collection(work / "meshes", n_per_category=per_category)
    vptool = [str(Path(sys.executable).with_name("vptool"))]
    subprocess.run([*vptool, "build-dataset", str(work / "meshes"), str(work / "build"),
                    "--format", "hdf5", "--views", "200", "--resolution", "96",
                    "--points", "4096", "--max-faces", "2000"], check=False)
    subprocess.run([*vptool, "pack", str(work / "build"), str(release), "--license", "CC-BY-4.0",
                    "--force-license"], check=True)
    return release


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-category", type=int, default=30)
    parser.add_argument("--work", type=Path, default=Path(tempfile.gettempdir()) / "bench-remote")
    add_results_option(parser, "remote")
    arguments = parser.parse_args()
    release = build_release(arguments.work, arguments.per_category)
    archive = next(release.glob("*.h5"))
    handler = functools.partial(_CountingHandler, directory=str(release.parent))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    url = f"http://127.0.0.1:{server.server_address[1]}/{release.name}/"
    with open_dataset(release) as dataset:
        n_models, n_test = len(dataset), len(dataset.split("test"))
        name = dataset.names[n_models // 2]
    try:
        with printed_section(arguments.results, arguments.section):
            print(f"release: {n_models} models, {archive.name} {archive.stat().st_size} bytes")
            for partial in (False, True):
                split_bytes = _bytes_sent(url, partial, lambda dataset: dataset.split("test"))
                model_bytes = _bytes_sent(url, partial, lambda dataset: dataset[name]["points"])
                print(f"partial={partial}: open + split('test') ({n_test} models): "
                      f"{split_bytes} bytes sent; open + one model ({name}): "
                      f"{model_bytes} bytes sent")
    finally:
        server.shutdown()
        server.server_close()


def _bytes_sent(url: str, partial: bool, read: Callable[[ViewpointDataset], object]) -> int:
    """Bytes the server sends to open ``url`` into a fresh cache and ``read`` the dataset."""
    with tempfile.TemporaryDirectory() as cache:
        _CountingHandler.sent[0] = 0
        with open_dataset(url, cache_dir=cache, partial=partial) as dataset:
            read(dataset)
        return _CountingHandler.sent[0]


if __name__ == "__main__":
    main()
