#!/usr/bin/env bash
# Extracts the H3.6M exponential-map copy from the shared folder into data/
# (git-ignored: the data's licence forbids redistribution). Idempotent.
set -euo pipefail
cd "$(dirname "$0")/.."
shared="${MM_SHARED_DIR:-../shared}"
archive="$shared/data/h36m-expmap.tar.xz"
if [ -d data/h3.6m/dataset/S5 ]; then exit 0; fi
if [ ! -f "$archive" ]; then
  echo "extract-h36m: $archive not found; tests that need H3.6M will be skipped" >&2
  exit 0
fi
mkdir -p data
tar xJf "$archive" -C data
