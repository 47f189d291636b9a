#!/usr/bin/env bash
# Unpacks, without installing, the Debian header packages that
# scripts/build-cuda.sh needs on a GPU machine that has the Python `torch`
# but neither these packages nor a package mirror. Run it where apt works,
# carry DIR to the GPU machine, and build there with
# `DEPS=DIR bash scripts/build-cuda.sh`.
#
#   bash scripts/unpack-build-deps.sh [DIR]      (default .deps)
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:-.deps}
mkdir -p "$dir/debs" "$dir/root"
(cd "$dir/debs" && apt-get download nlohmann-json3-dev libcli11-dev zlib1g-dev libgtest-dev libgmock-dev)
for deb in "$dir"/debs/*.deb; do dpkg -x "$deb" "$dir/root"; done
# zlib1g-dev's libz.so points at the runtime package, which is not unpacked;
# build-cuda.sh links the static libz.a instead.
rm -f "$dir/root/usr/lib/x86_64-linux-gnu/libz.so"
echo "unpack-build-deps: DEPS=$dir/root bash scripts/build-cuda.sh"
