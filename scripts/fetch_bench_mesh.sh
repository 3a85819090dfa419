#!/usr/bin/env bash
# Fetches the Stanford bunny (37,706 vertices, 75,408 triangles: the scanned bunny with its holes
# closed) for python_tests/bench/bench_addon.py. It ships in Debian 12's libcgal-demo package
# (data/meshes/bunny00.off inside /usr/share/doc/libcgal-dev/data.tar.gz); the package is only
# downloaded and unpacked here, not installed. 2.6 MB, so it is not committed (assets stay small).
# Usage: scripts/fetch_bench_mesh.sh [output dir, default out/bench]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out_dir="${1:-$root/out/bench}"
target="$out_dir/bunny00.off"
if [ -s "$target" ]; then
  echo "fetch_bench_mesh: $target already there"
  exit 0
fi
mkdir -p "$out_dir"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
chmod 777 "$work"  # apt's _apt user downloads into it
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
(cd "$work" && $SUDO apt-get download -q libcgal-demo) || {
  $SUDO apt-get update -q && (cd "$work" && $SUDO apt-get download -q libcgal-demo)
}
dpkg-deb -x "$work"/libcgal-demo_*.deb "$work/pkg"
tar -xzf "$work/pkg/usr/share/doc/libcgal-dev/data.tar.gz" -C "$work" data/meshes/bunny00.off
mv "$work/data/meshes/bunny00.off" "$target"
echo "fetch_bench_mesh: wrote $target ($(head -2 "$target" | tail -1 | cut -d' ' -f1-2) vertices/faces)"
