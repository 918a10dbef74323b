#!/usr/bin/env bash
# Build the wheel and the sdist, check their metadata, install the wheel into a
# fresh venv (the light install: numpy, click, tqdm, h5py) and smoke-test it:
# `vptool --help`, and the light reader on RELEASE when one is given.
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
echo "check_package: wheel and sdist build, pass twine check and install; the light reader works" >&2
