#!/usr/bin/env bash
# deploy_container: the image's entrypoint serving for real. With podman and
# the image built (scripts/build-image.sh), it runs the image with its three
# volumes; without them it says so and runs the same docker/entrypoint.sh on
# this machine, with the image's MM_* environment, against the built server.
# Either way: a wrong folder variable fails at once naming it; the server gets
# ready (/readyz), the HEALTHCHECK passes, a Sample call answers from the
# default model, and SIGTERM lets a call in flight finish and exits 0.
#   container_test.sh SERVER_BINARY SOURCE_DIR
# MM_CONTAINER_TEST: auto (default), image (fail without the image), build
# (first build the image from SOURCE_DIR with scripts/build-image.sh, then
# run it), host.
set -euo pipefail
server=$1
source_dir=$2
mode=${MM_CONTAINER_TEST:-auto}
version=$(sed -n 's/^project(motion_manifold VERSION \([0-9.]*\).*/\1/p' "$source_dir/CMakeLists.txt")
image=${MM_IMAGE:-localhost/motion-manifold:$version}
podman_opts=(--runtime runc --ulimit nofile=1024:1024 --ulimit nproc=1024:1024)

seconds_since() { awk -v start="$1" -v now="$(date +%s.%N)" 'BEGIN { printf "%.1f", now - start }'; }
fail() {
  echo "FAIL: $*" >&2
  exit 1
}
say() { echo "deploy_container: $*"; }

if [ "$mode" = build ]; then
  # The image of this very tree; the layer cache and ccache make a rebuild
  # after a small change take minutes, a cold one most of an hour.
  say "building $image from $source_dir with scripts/build-image.sh"
  build_started=$(date +%s.%N)
  MM_IMAGE=$image bash "$source_dir/scripts/build-image.sh" || fail "scripts/build-image.sh failed"
  say "image built in $(seconds_since "$build_started") s"
  mode=image
fi

engine=""
if [ "$mode" != host ]; then
  if ! command -v podman > /dev/null; then
    why="no container engine (podman) on this machine"
  elif [ "$(id -u)" -ne 0 ]; then
    why="podman needs root here (rootful, runc)"
  elif ! podman image exists "$image"; then
    why="image $image not built (bash scripts/build-image.sh)"
  else
    engine=podman
  fi
  [ -n "$engine" ] || [ "$mode" != image ] || fail "MM_CONTAINER_TEST=image: $why"
fi
[ -n "$engine" ] && say "running the image $image with podman" ||
  say "${why:-MM_CONTAINER_TEST=host}: running docker/entrypoint.sh on this machine with $server instead"

work=$(mktemp -d /tmp/mm-container-test.XXXXXX)
container=mm-container-test-$$
cleanup() {
  [ -z "$engine" ] || podman rm -f "$container" > /dev/null 2>&1 || true
  [ -z "${server_pid:-}" ] || kill -KILL "$server_pid" 2> /dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
mkdir -p "$work/models" "$work/state" "$work/data"
# The image's user owns its volumes, as a Kubernetes fsGroup or a chown makes it.
[ -z "$engine" ] || chown -R 10001:10001 "$work/models" "$work/state" "$work/data"
token=container-test-token

# 1. A folder variable naming no folder is refused at once, by name.
bad=/nonexistent/state
if [ -n "$engine" ]; then
  set +e
  podman run --rm "${podman_opts[@]}" -e MM_STATE_DIR=$bad "$image" > "$work/bad.log" 2>&1
  code=$?
  set -e
else
  set +e
  env SERVER_BINARY="$server" SHIPPED_MODELS="$source_dir/models" MM_MODEL_STORE="$work/models" \
    MM_STATE_DIR=$bad MM_DATA_ROOT="$work/data" bash "$source_dir/docker/entrypoint.sh" > "$work/bad.log" 2>&1
  code=$?
  set -e
fi
[ "$code" -eq 2 ] && grep -q "MM_STATE_DIR=$bad: not a folder" "$work/bad.log" ||
  fail "a missing state folder: exit $code, expected 2 and a message naming MM_STATE_DIR: $(cat "$work/bad.log")"

# 2. Start, with the three volumes.
start=$(date +%s.%N)
if [ -n "$engine" ]; then
  podman run -d --name "$container" "${podman_opts[@]}" \
    -p 127.0.0.1::8080 -p 127.0.0.1::50051 \
    -v "$work/models:/var/lib/motion-manifold/models" \
    -v "$work/state:/var/lib/motion-manifold/state" \
    -v "$work/data:/var/lib/motion-manifold/data:ro" \
    -e MM_AUTH_TOKEN=$token "$image" > /dev/null
  rest_port=$(podman port "$container" 8080/tcp | sed 's/.*://')
  logs() { podman logs "$container" 2>&1; }
else
  # The image's environment, then this machine's folders and free ports.
  image_env=$(python3 "$source_dir/tests/deploy/dockerfile_env.py" "$source_dir/docker/Dockerfile")
  # shellcheck disable=SC2086
  env $image_env SERVER_BINARY="$server" SHIPPED_MODELS="$source_dir/models" \
    MM_MODEL_STORE="$work/models" MM_STATE_DIR="$work/state" MM_DATA_ROOT="$work/data" MM_WEB_ROOT="$source_dir/web" \
    MM_ADDRESS=127.0.0.1 MM_GRPC_PORT=0 MM_REST_PORT=0 MM_READY_FILE="$work/ready.json" MM_AUTH_TOKEN=$token \
    bash "$source_dir/docker/entrypoint.sh" > "$work/server.log" 2>&1 &
  server_pid=$!
  logs() { cat "$work/server.log"; }
  for _ in $(seq 600); do
    [ -s "$work/ready.json" ] && break
    kill -0 "$server_pid" 2> /dev/null || fail "the server exited before serving: $(logs)"
    sleep 0.2
  done
  rest_port=$(sed -n 's/.*"rest_port": *\([0-9]*\).*/\1/p' "$work/ready.json")
fi
[ -n "$rest_port" ] || fail "no REST port: $(logs)"
api=http://127.0.0.1:$rest_port
ready=""
for _ in $(seq 600); do
  if [ "$(curl -s -o /dev/null -w '%{http_code}' "$api/readyz")" = 200 ]; then
    ready=yes
    break
  fi
  sleep 0.2
done
[ -n "$ready" ] || fail "/readyz not 200 within 120 s: $(logs)"
say "ready $(seconds_since "$start") s after start"
# A line is looked for in a copy of the log, for up to 5 s: under pipefail
# `logs | grep -q` fails when grep stops reading before `podman logs` has
# written everything, and the engine may store a line a moment after the
# server wrote it.
log_has() {
  for _ in $(seq 50); do
    logs > "$work/log.txt"
    grep -q "$1" "$work/log.txt" && return 0
    sleep 0.1
  done
  return 1
}
log_has "serving gRPC on" || fail "the running server's log lacks its serving line: $(logs)"

# 3. The shipped model was linked into the empty store; the job database is
# on the state volume; the HEALTHCHECK passes.
# (In the image's case the link points into the image: it resolves inside it.)
[ -L "$work/models/h36m-dkgm-h100" ] || fail "the default model is not linked into the model store volume"
[ -n "$(ls -A "$work/state")" ] || fail "nothing written to the state volume (the job database)"
if [ -n "$engine" ]; then
  podman healthcheck run "$container" || fail "the image's HEALTHCHECK failed: $(logs)"
  [ "$(podman exec "$container" id -u)" = 10001 ] || fail "the server does not run as uid 10001"
  podman exec "$container" test -e /var/lib/motion-manifold/models/h36m-dkgm-h100/manifest.json ||
    fail "the linked default model does not resolve in the container"
else
  [ -e "$work/models/h36m-dkgm-h100/manifest.json" ] || fail "the linked default model does not resolve"
  MM_REST_PORT=0 MM_READY_FILE="$work/ready.json" MM_ADDRESS=127.0.0.1 \
    bash "$source_dir/docker/healthcheck.sh" || fail "docker/healthcheck.sh failed"
fi

# 4. The web page, then one operation answered by the default model.
curl -sf -o "$work/page.html" "$api/" || fail "GET / failed"
grep -q "<title>Motion Manifold</title>" "$work/page.html" || fail "GET / did not serve the web page: $(head -c 300 "$work/page.html")"
curl -sf -o "$work/sample.json" "$api/v1/sample" -d '{"count": 2, "seed": 7}' || fail "POST /v1/sample failed"
python3 - "$work/sample.json" << 'PY' || fail "unexpected /v1/sample reply: $(head -c 300 "$work/sample.json")"
import json, sys
reply = json.load(open(sys.argv[1]))
assert reply["answered_by"]["model"] == "h36m-dkgm-h100", reply["answered_by"]
assert len(reply["motions"]) == 2 and reply["motions"][0]["frames"] == 150, "two clips of 150 frames"
PY
# The token from the environment guards state changes.
code=$(curl -s -o /dev/null -w '%{http_code}' -X POST "$api/v1/models/h36m-dkgm-h100:activate")
[ "$code" = 401 ] || fail "activate without the token: HTTP $code, expected 401"

# 5. SIGTERM with a call in flight: the call is answered, the server exits 0.
curl -s -o "$work/inflight.json" -w '%{http_code}' "$api/v1/sample" -d '{"count": 64, "seed": 1}' > "$work/inflight.code" &
curl_pid=$!
sleep 0.3
stop=$(date +%s.%N)
if [ -n "$engine" ]; then
  podman kill --signal TERM "$container" > /dev/null
  code=$(podman wait "$container")
else
  kill -TERM "$server_pid"
  set +e
  wait "$server_pid"
  code=$?
  set -e
  server_pid=""
fi
wait "$curl_pid" || true
say "stopped $(seconds_since "$stop") s after SIGTERM, exit code $code"
[ "$code" = 0 ] || fail "exit code $code after SIGTERM, expected 0: $(logs)"
[ "$(cat "$work/inflight.code")" = 200 ] || fail "the call in flight at SIGTERM got HTTP $(cat "$work/inflight.code")"
log_has "draining calls in flight" || fail "no drain in the log: $(logs)"
log_has '"stopped"\|[0-9] info stopped' || fail "the server did not log its stop: $(logs)"
say "passed"
