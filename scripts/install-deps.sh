#!/usr/bin/env bash
# Installs the build and run-time dependencies from Debian packages.
# libopenblas0-openmp matters: without an optimised BLAS, Debian's LibTorch
# runs on the reference BLAS, many times slower. Never add
# libopenblas0-pthread beside it.
#   bash scripts/install-deps.sh               # building and testing (.ci/run): everything below
#   bash scripts/install-deps.sh --serving     # building and serving (scripts/serve.sh): the build's
#                                              # packages, the README's curl, jq and python3, and
#                                              # what the Python client installs on
#   bash scripts/install-deps.sh --build-only  # building only (the container image's build stage)
#   bash scripts/install-deps.sh --build-tests # building with the tests: the build's packages and the
#                                              # test libraries, not the programs the tests run
#                                              # (.ci/run installs those while it builds)
# A container engine (podman) is not installed here: scripts/build-image.sh
# installs it when an image is built.
set -euo pipefail
mode=${1:-full}
case "$mode" in
  full|--serving|--build-only|--build-tests) ;;
  *) echo "install-deps: unknown option \"$mode\"; expected --serving, --build-only, --build-tests or nothing (everything)" >&2
     exit 2 ;;
esac
packages=(
  build-essential cmake pkg-config git xz-utils
  libtorch-dev libopenblas0-openmp libdnnl-dev
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  libcpp-httplib-dev nlohmann-json3-dev libcli11-dev zlib1g-dev
  libsqlite3-dev libpqxx-dev libspdlog-dev prometheus-cpp-dev
  libassimp-dev libtinygltf-dev
)
# What the README's service examples call beside the client: curl, jq, and
# python3 for scripts/motion_json.py; and the Python client's one-line install
# (client/python/README.md): grpcio, numpy, grpc-tools to generate its stubs,
# venv and wheel to build it into a virtual environment without downloading.
if [ "$mode" = full ] || [ "$mode" = --serving ]; then
  packages+=(curl jq python3)
  packages+=(python3-grpcio python3-grpc-tools python3-numpy python3-venv python3-setuptools python3-wheel)
fi
if [ "$mode" = full ] || [ "$mode" = --build-tests ]; then
  # The test libraries the build links (CMake looks for them when it configures).
  packages+=(libgtest-dev libgmock-dev libbenchmark-dev)
fi
if [ "$mode" = full ]; then
  packages+=(
    postgresql python3-yaml
  )
  # The fuzz targets (tests/fuzz) build with clang and its libFuzzer and
  # sanitizer runtimes; llvm's symbolizer names the lines of a crash.
  packages+=(clang libclang-rt-dev llvm)
  # Node.js and npm run the OpenAPI validator of the tests; a machine that
  # already has them (a newer Node.js) keeps its own.
  command -v npm > /dev/null || packages+=(nodejs npm)
  # The web page's browser test drives Debian's Chromium headless; Blender's
  # own BVH importer reads the BVH the library writes.
  packages+=(chromium blender)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  sudo_cmd=""
  [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
