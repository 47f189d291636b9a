#!/usr/bin/env bash
# Prints the Debian packages holding the shared libraries that the given
# programs load, so that the runtime stage installs those and no -dev package.
# Run where the programs were built (the image's build stage).
set -euo pipefail
libraries=$(ldd "$@" | awk '$2 == "=>" && $3 ~ /^\// {print $3}' | sort -u)
# Each library under its own name, its link target and their /usr twins
# (dpkg records a file under the path its package ships, merged /usr or not).
candidates=$(mktemp)
trap 'rm -f "$candidates"' EXIT
for library in $libraries; do
  real=$(readlink -f "$library")
  printf '%s\n' "$library" "$real" "/usr$library" "/usr$real" "${library#/usr}" "${real#/usr}"
done | sort -u > "$candidates"
# One pass over dpkg's file lists (dpkg -S per library takes minutes).
owned=$(grep -HxF -f "$candidates" /var/lib/dpkg/info/*.list |
  sed 's#^/var/lib/dpkg/info/\([^:]*\)\(:[a-z0-9]*\)\?\.list:#\1 #')
status=0
for library in $libraries; do
  real=$(readlink -f "$library")
  if ! awk -v a="$library" -v b="$real" -v c="/usr$library" -v d="/usr$real" -v e="${library#/usr}" -v f="${real#/usr}" \
      '$2 == a || $2 == b || $2 == c || $2 == d || $2 == e || $2 == f { found = 1 } END { exit !found }' <<< "$owned"; then
    echo "runtime-packages: no package holds $library" >&2
    status=1
  fi
done
awk '{print $1}' <<< "$owned" | sort -u
exit $status
