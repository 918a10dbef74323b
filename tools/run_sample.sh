#!/usr/bin/env bash
# The main job on the bundled sample meshes: build a viewpoint-quality dataset
# (cleaning, 20000 points, 1000 views at 1024 px), pack it into a release with
# checksums and a dataset card, verify the release and show what it holds,
# search every model's best views within 64 drawn views and score them, let the
# bundled network predict them and score that beside (and on the test split
# alone), and write an HTML
# report with pictures from the best and the predicted views.
# Usage: bash tools/run_sample.sh [OUT]   (default OUT: sample_run/)
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-sample_run}"
vptool=.venv/bin/vptool

# The samples' split file gives 8 train, 2 validation and 2 test models.
"$vptool" build-dataset vptoolkit/samples "$out/build" --workers 2 \
    --splits vptoolkit/samples/splits.csv
# A release folder must be new: replace the one this script made last time.
if [ -f "$out/release/SHA256SUMS" ]; then rm -r "$out/release"; fi
# Reproducible: the same build and release time give the same SHA256SUMS anywhere.
"$vptool" pack "$out/build" "$out/release" --version 1.0.0 --created 2026-01-01T00:00:00Z \
    --pretty-name "Viewpoint quality of the vptoolkit sample meshes" \
    --licenses vptoolkit/samples/LICENSES.csv
"$vptool" verify "$out/release"
"$vptool" info "$out/release"
"$vptool" best-view --dataset "$out/release" --split all -o "$out/best_views.npz"
"$vptool" evaluate "$out/best_views.npz" --dataset "$out/release" --split all
"$vptool" predict --dataset "$out/release" --split all -o "$out/predictions.npz"
"$vptool" evaluate "$out/predictions.npz" --dataset "$out/release" --split all
# The held-out test split alone, scored as the README's "Train and evaluate" does.
"$vptool" predict --dataset "$out/release" --split test -o "$out/test.npz"
"$vptool" evaluate "$out/test.npz" --dataset "$out/release" --split test
"$vptool" report "$out/release" --predictions "$out/predictions.npz" -o "$out/report"
echo "open $out/report/index.html in a browser" >&2
