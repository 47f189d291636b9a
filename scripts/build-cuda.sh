#!/usr/bin/env bash
# Builds model/ (the motion-manifold tool and the model tests) against the
# LibTorch of the Python `torch` on this machine, typically a CUDA build on a
# GPU machine, without the service parts.
#
#   bash scripts/build-cuda.sh [BUILD_DIR]      (default build-cuda)
#
# Header packages that the machine lacks (nlohmann-json3-dev, libcli11-dev,
# zlib1g-dev, libgtest-dev, libgmock-dev) can be unpacked elsewhere by
# scripts/unpack-build-deps.sh and named with DEPS=DIR: DIR/usr joins the
# search path, and zlib is taken from there statically.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${1:-build-cuda}
torch_prefix=$(python3 -c 'import torch; print(torch.utils.cmake_prefix_path)')
args=(-DMM_BUILD_SERVICE=OFF -DCMAKE_BUILD_TYPE=Release)
prefix="$torch_prefix"
if [[ -n "${DEPS:-}" ]]; then
  deps=$(cd "$DEPS" && pwd)/usr
  prefix="$prefix;$deps"
  args+=(-DZLIB_INCLUDE_DIR="$deps/include" -DZLIB_LIBRARY="$deps/lib/x86_64-linux-gnu/libz.a"
        -DGTest_DIR="$deps/lib/x86_64-linux-gnu/cmake/GTest")
fi
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
cmake -S . -B "$build_dir" "${generator[@]}" -DCMAKE_PREFIX_PATH="$prefix" "${args[@]}"
cmake --build "$build_dir" -j "$(nproc)" --target motion-manifold
# The tests need GoogleTest built with the same C++ ABI as this LibTorch.
cmake --build "$build_dir" -j "$(nproc)" --target model_tests || echo "build-cuda: model tests not built" >&2
