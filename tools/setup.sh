#!/usr/bin/env bash
# Set up .venv/ with vptoolkit, its optional extras and the test tools, on a
# Debian-like machine with Python >= 3.11. Safe to run again.
#
# System packages: libusb-1.0-0 (Open3D needs it to import), libvulkan1 and
# mesa-vulkan-drivers (Open3D's offscreen renderer uses Vulkan; Mesa's
# software driver serves on machines without a GPU), chromium (the HTML
# report's browser test drives it headless).
set -euo pipefail
cd "$(dirname "$0")/.."

APT_PACKAGES=(libusb-1.0-0 libvulkan1 mesa-vulkan-drivers chromium)
missing=()
for package in "${APT_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" \
        || missing+=("$package")
done
if [ ${#missing[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ]; then sudo=""; else sudo="sudo"; fi
    echo "setup: installing ${missing[*]}" >&2
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

python="${PYTHON:-python3}"
[ -x .venv/bin/python ] || "$python" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
# torch first, pinned: this version's CPU wheel; an unpinned requirement would
# pull a CUDA build of several GB. Then the package with every extra.
.venv/bin/python -m pip install -q torch==2.13.0
.venv/bin/python -m pip install -q -e '.[all,dev]'
echo "setup: ready; run .venv/bin/vptool --help" >&2
