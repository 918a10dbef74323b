#!/usr/bin/env bash
# Build the wheel and the sdist, check their metadata, install the wheel into a
# fresh venv (the light install: numpy, click, tqdm, h5py, packaging) and smoke-test
# it: `vptool --help`, and the light reader on RELEASE when one is given. Then unpack
# the sdist and run a quick subset of its own tests from that copy against the
# wheel, which proves that the sdist carries what its tests import (tests/fixtures/,
# tests/assets/, tools/, docs/: MANIFEST.in).
# Usage: bash tools/check_package.sh [RELEASE]    (needs .venv from tools/setup.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
release="${1:-}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
.venv/bin/python -m pip install -q build twine
.venv/bin/python -m build --sdist --wheel --outdir "$work/dist" . >/dev/null
.venv/bin/python -m twine check --strict "$work"/dist/*
ls -l "$work"/dist
python3 -m venv "$work/venv"
"$work/venv/bin/pip" install -q "$work"/dist/vptoolkit-*.whl
"$work/venv/bin/vptool" --help >/dev/null
(cd "$work" && venv/bin/python - "$release" <<'PY'
import sys
import vptoolkit.data
from vptoolkit.data import open_dataset

heavy = {"torch", "open3d", "numba", "pymeshlab", "trimesh", "zarr"} & set(sys.modules)
assert not heavy, f"the light reader imported {sorted(heavy)}"
if sys.argv[1]:
    with open_dataset(sys.argv[1]) as dataset:
        n = sum(1 for item in dataset if item["quality"].shape == (len(dataset.views), 4))
    print(f"light install: read {n} models of {sys.argv[1]}")
PY
)
# The sdist's own tests, run from its unpacked copy against the built wheel: the
# wheel goes into a folder of its own that leads PYTHONPATH, and .venv lends the
# test tools and the extras the fixtures import (torch, zarr, ...). .venv's editable
# vptoolkit comes last on the import path, and `pytest` (not `python -m pytest`)
# keeps the copy's own vptoolkit/ off it, so what runs is the wheel's code.
tar -xzf "$work"/dist/vptoolkit-*.tar.gz -C "$work"
.venv/bin/python -m pip install -q --no-deps --target "$work/wheel" "$work"/dist/vptoolkit-*.whl
venv_bin="$PWD/.venv/bin"
(cd "$work"/vptoolkit-*/ && export PYTHONPATH="$work/wheel" \
    && "$venv_bin/python" -P -c "import sys, vptoolkit; sys.exit(None if vptoolkit.__file__ \
.startswith(sys.argv[1]) else f'the sdist tests would import {vptoolkit.__file__}')" "$work/wheel" \
    && "$venv_bin/pytest" -q -x -p no:cacheprovider tests/test_checks.py tests/test_sphere.py \
        tests/project/test_install_docs.py tests/dataset/release/test_licenses.py)
echo "check_package: wheel and sdist build, pass twine check and install; the light reader" \
    "works; the sdist's own tests pass from its unpacked copy" >&2
