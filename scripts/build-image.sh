#!/usr/bin/env bash
# Builds the container image of the service with podman (rootful, runc) from a
# Debian bookworm base made here with debootstrap: no image registry is needed.
# The base is made once (image localhost/motion-manifold-base:bookworm) and
# reused; the image's build stage compiles with ccache on a cache folder of
# this machine (MM_IMAGE_CCACHE_DIR, default: this machine's ccache folder), so
# a rebuild after a small change recompiles only what changed.
#   bash scripts/build-image.sh            # -> localhost/motion-manifold:VERSION (and :latest)
#   bash scripts/build-image.sh --base     # only the base image
# Environment: MM_IMAGE (the tag), MM_BASE_IMAGE, MM_DEBIAN_MIRROR (default:
# this machine's apt source), MM_IMAGE_CCACHE_DIR (empty: no ccache).
set -euo pipefail
cd "$(dirname "$0")/.."

version=$(sed -n 's/^project(motion_manifold VERSION \([0-9.]*\).*/\1/p' CMakeLists.txt)
image=${MM_IMAGE:-localhost/motion-manifold:$version}
base=${MM_BASE_IMAGE:-localhost/motion-manifold-base:bookworm}
# runc and these limits: what rootful podman needs on machines whose default
# runtime or hard limits a container cannot take over.
podman_opts=(--runtime runc --ulimit nofile=1024:1024 --ulimit nproc=1024:1024)

if [ "$(id -u)" -ne 0 ]; then
  echo "build-image: run as root (rootful podman and debootstrap)" >&2
  exit 2
fi
missing=()
for tool in podman buildah runc debootstrap; do
  command -v "$tool" > /dev/null || missing+=("$tool")
done
if ((${#missing[@]})); then
  apt-get update -q
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}" \
    netavark aardvark-dns containernetworking-plugins
fi

# The mirror this machine's apt uses (deb822 or one-line sources).
apt_mirror() {
  { sed -n 's/^URIs: *\([^ ]*\).*/\1/p' /etc/apt/sources.list.d/*.sources
    sed -n 's/^deb \+\([^ []*\) \+bookworm .*/\1/p' /etc/apt/sources.list; } 2>/dev/null |
    grep -v security | head -n 1 || true
}
mirror=${MM_DEBIAN_MIRROR:-$(apt_mirror)}

make_base() {
  local rootfs
  rootfs=$(mktemp -d /var/tmp/mm-bookworm-rootfs.XXXXXX)
  trap 'rm -rf "$rootfs"' RETURN
  echo "build-image: debootstrap bookworm (minbase) from ${mirror:-the default mirror of debootstrap}" >&2
  debootstrap --variant=minbase --include=ca-certificates bookworm "$rootfs" ${mirror:+"$mirror"}
  # bookworm-updates and the security suite too, as apt on this machine has them.
  cat > "$rootfs/etc/apt/sources.list" <<SOURCES
deb ${mirror:-http://deb.debian.org/debian} bookworm main
deb ${mirror:-http://deb.debian.org/debian} bookworm-updates main
deb ${mirror:-http://deb.debian.org/debian}-security bookworm-security main
SOURCES
  chroot "$rootfs" apt-get clean
  rm -rf "$rootfs"/var/lib/apt/lists/* "$rootfs"/var/cache/apt/*.bin
  tar -C "$rootfs" --numeric-owner -c . | podman import --change 'CMD ["/bin/bash"]' - "$base"
}

if ! podman image exists "$base"; then
  start=$(date +%s)
  make_base
  echo "build-image: base $base made in $(($(date +%s) - start)) s" >&2
fi
[ "${1:-}" = "--base" ] && exit 0

ccache_dir=${MM_IMAGE_CCACHE_DIR-$(ccache -k cache_dir 2>/dev/null || true)}
build_opts=()
if [ -n "$ccache_dir" ]; then
  mkdir -p "$ccache_dir"
  build_opts+=(--volume "$ccache_dir:/ccache")
fi
start=$(date +%s)
# Docker format: the OCI format has no HEALTHCHECK.
podman build "${podman_opts[@]}" "${build_opts[@]}" --pull=never --format docker \
  --build-arg BASE_IMAGE="$base" -f docker/Dockerfile -t "$image" -t "${image%:*}:latest" .
echo "build-image: $image built in $(($(date +%s) - start)) s," \
  "$(podman image inspect --format '{{.Size}}' "$image") bytes" >&2
