#!/usr/bin/env bash
# Extracts the H3.6M exponential-map copy from the shared folder into data/
# (git-ignored: the data's licence forbids redistribution). Idempotent.
set -euo pipefail
cd "$(dirname "$0")/.."
shared="${MM_SHARED_DIR:-../shared}"
archive="$shared/data/h36m-expmap.tar.xz"
if [ -d data/h3.6m/dataset/S5 ]; then exit 0; fi
if [ ! -f "$archive" ]; then
  # The tests need the data: a run without it must not pass by skipping.
  if [ "${MM_ALLOW_MISSING_H36M:-0}" = 1 ]; then
    echo "extract-h36m: $archive not found; MM_ALLOW_MISSING_H36M=1, so the tests that need H3.6M will skip" >&2
    exit 0
  fi
  echo "extract-h36m: $archive not found (set MM_SHARED_DIR, or MM_ALLOW_MISSING_H36M=1 to skip those tests)" >&2
  exit 1
fi
mkdir -p data
tar xJf "$archive" -C data
