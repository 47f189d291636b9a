#!/usr/bin/env bash
# Prints the Debian packages holding the shared libraries that the given
# programs load, so that the runtime stage installs those and no -dev package.
# Run where the programs were built (the image's build stage).
set -euo pipefail
owner() {  # the package of a file, under its own name, its target or its /usr twin
  local real path
  real=$(readlink -f "$1")
  for path in "$1" "$real" "/usr$real" "${real#/usr}"; do
    dpkg -S "$path" 2> /dev/null | sed -n '1s/:.*//p' | grep . && return 0
  done
  echo "runtime-packages: no package holds $1" >&2
  return 1
}
libraries=$(ldd "$@" | awk '$2 == "=>" && $3 ~ /^\// {print $3}' | sort -u)
for library in $libraries; do owner "$library"; done | sort -u
