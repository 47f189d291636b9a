#!/usr/bin/env bash
# The image's HEALTHCHECK: GET /healthz of the server in this container, on the
# REST port of its environment (https when it serves TLS; with port 0, the
# port its MM_READY_FILE names).
set -euo pipefail
port=${MM_REST_PORT:-8080}
if [ "$port" = 0 ] && [ -n "${MM_READY_FILE:-}" ]; then
  port=$(sed -n 's/.*"rest_port": *\([0-9]*\).*/\1/p' "$MM_READY_FILE")
fi
host=${MM_ADDRESS:-0.0.0.0}
case $host in 0.0.0.0 | "::" | "[::]") host=127.0.0.1 ;; esac
scheme=http
[ -z "${MM_TLS_CERT:-}" ] || scheme=https
# -k: the health of the server is asked, not its certificate's.
exec curl -fsS -k --max-time 4 -o /dev/null "$scheme://$host:$port/healthz"
