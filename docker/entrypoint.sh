#!/usr/bin/env bash
# The image's entrypoint. The server reads its whole configuration from MM_*
# variables itself (motion-manifold-server --help lists them); this script
# checks the folders they name, so that a volume mounted with the wrong owner
# fails at once with the variable's name, links the models shipped in the
# image into the model store (a fresh volume is empty), and then becomes the
# server, which so receives SIGTERM itself and drains.
#   entrypoint.sh [SERVER FLAGS...]    serve
#   entrypoint.sh COMMAND [ARGS...]    run COMMAND instead (e.g. motion-manifold-client)
# Its own two variables, for running it outside the image: SERVER_BINARY and
# SHIPPED_MODELS (default: the image's /opt/motion-manifold paths).
set -euo pipefail
server=${SERVER_BINARY:-/opt/motion-manifold/bin/motion-manifold-server}
shipped=${SHIPPED_MODELS:-/opt/motion-manifold/models}

if [ $# -gt 0 ] && [ "${1#-}" = "$1" ]; then
  exec "$@"
fi

fail() {
  echo "entrypoint: $*" >&2
  exit 2
}
# folder VARIABLE PURPOSE WRITABLE: the folder a set variable names must exist
# (and be writable by this user when WRITABLE is "writable").
folder() {
  local name=$1 purpose=$2 access=$3 value=${!1:-}
  [ -n "$value" ] || return 0
  [ -d "$value" ] || fail "$name=$value: not a folder; expected the folder of $purpose (a mounted volume)"
  if [ "$access" = writable ] && ! [ -w "$value" ]; then
    fail "$name=$value: not writable by uid $(id -u); expected a folder this user can write, for $purpose"
  fi
}
[ -n "${MM_MODEL_STORE:-}" ] || fail "MM_MODEL_STORE is empty; expected the model store folder"
folder MM_MODEL_STORE "the model store (training jobs publish into it)" writable
folder MM_STATE_DIR "the job database and job runs" writable
folder MM_DATA_ROOT "the training datasets" readable

# Several replicas may share the store and link at once: losing the race is fine.
for model in "$shipped"/*/; do
  [ -d "$model" ] || continue
  name=$(basename "$model")
  [ -e "$MM_MODEL_STORE/$name" ] || ln -s "${model%/}" "$MM_MODEL_STORE/$name" 2> /dev/null ||
    [ -e "$MM_MODEL_STORE/$name" ] || fail "cannot link the shipped model $name into MM_MODEL_STORE=$MM_MODEL_STORE"
done

exec "$server" "$@"
