#!/usr/bin/env bash
# The main job on a fresh machine: installs what it needs, builds the server,
# the tool (build/model/tool/motion-manifold, which training jobs run) and the
# command-line client (build/client/motion-manifold-client), and serves the
# shipped default model (models/h36m-dkgm-h100) over gRPC (port 50051) and
# REST (port 8080) until Ctrl-C / SIGTERM.
# The model store is runs/models (the shipped models linked in, and the
# models training jobs publish). Training jobs are on: their records and runs
# live in runs/state, and their datasets must lie under data/ (the H3.6M copy from ../shared is extracted
# there when it exists). It listens on every address without a token: the
# network may call the model, but calls that change state (activate, upload,
# submit, cancel, delete) and clip reads are taken only from this machine
# until a token is given. Any server option can follow, e.g.
#   bash scripts/serve.sh --rest-port 9090 --auth-token-file token   # token: openssl rand -hex 24 > token; chmod 600 token
set -euo pipefail
cd "$(dirname "$0")/.."
# Only what serving needs (the build, curl and jq for the README's examples):
# the test tools (PostgreSQL, Chromium, Blender, clang, Node.js) are .ci/run's.
bash scripts/install-deps.sh --serving
bash scripts/extract-h36m.sh || echo "serve: no H3.6M copy extracted; training jobs need a dataset under data/" >&2
mkdir -p data runs/state runs/models
# The store: the shipped models (linked) and what training jobs publish.
for model in models/*/; do
  name=$(basename "$model")
  [ -e "runs/models/$name" ] || ln -s "../../models/$name" "runs/models/$name"
done
# The test suite needs GoogleTest, which --serving leaves out: a fresh build
# tree is configured without it; one configured before keeps its choice.
tests=()
[ -f build/CMakeCache.txt ] || tests=(-DMM_BUILD_TESTS=OFF)
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "${tests[@]}"
cmake --build build -j "$(nproc)" --target motion-manifold-server motion-manifold motion-manifold-client
exec build/server/motion-manifold-server --model-store runs/models --state-dir runs/state --data-root data "$@"
