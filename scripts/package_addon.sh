#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# One installable package per Blender family, each holding texsynth_native and texsynth_image_io built for
# that Blender's Python:
#   host    Blender 3.x (Debian 12): legacy add-on zip  dist/texsynth-<version>-blender<X.Y>-py<XY>.zip
#           (a folder texsynth/ for Preferences > Add-ons > Install)
#   trixie  Blender 4.2+ (Debian 13), sid  Blender 5.x (Debian sid): an extension built and validated
#           by that Blender's own `blender --command extension build` / `validate`, same naming.
#   blender-org  blender.org builds, Linux x86-64: one self-contained extension per Python ABI,
#           dist/texsynth-<version>-linux_x64-cp311.zip (Blender 4.2 LTS to 5.0) and -cp313.zip (5.1+),
#           from scripts/build_blender_org.sh (texsynth_native + texsynth_native.libs/, no texsynth_image_io),
#           built and validated by the trixie environment's Blender 4.3. At most 50 MB each.
# Usage: scripts/package_addon.sh [host] [trixie] [sid] [blender-org]      (default: host)
# The environments are scripts/blender_envs.sh's; their modules are built when missing.
# Prints "package_addon: <path> ..." for each package.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
envs=("$@")
[ ${#envs[@]} -gt 0 ] || envs=(host)

version="$(sed -n 's/^version = "\(.*\)"/\1/p' "$root/addon/blender_manifest.toml")"
bl_version="$(sed -n 's/.*"version": (\([0-9]*\), \([0-9]*\), \([0-9]*\)).*/\1.\2.\3/p' "$root/addon/__init__.py")"
[ "$version" = "$bl_version" ] || { echo "package_addon: blender_manifest.toml says $version, bl_info says $bl_version" >&2; exit 1; }
mkdir -p "$root/dist"

# Runs a command on the host or inside an environment (the repository is /src there).
in_env() {
  local env="$1"; shift
  if [ "$env" = host ]; then (cd "$root" && "$@"); else bash "$root/scripts/blender_envs.sh" run "$env" "$@"; fi
}
path_in_env() { if [ "$1" = host ]; then echo "$root/$2"; else echo "/src/$2"; fi; }

# The add-on's Python tree (no caches, no modules of other builds) into $1.
copy_py_tree() {
  (cd "$root/addon" && find . -name '*.py' -not -path '*/__pycache__/*' | while read -r file; do
     mkdir -p "$1/$(dirname "$file")" && cp "$file" "$1/$file"; done)
}

MAX_PACKAGE_BYTES=$((50 * 1024 * 1024))
package_blender_org() {
  bash "$root/scripts/build_blender_org.sh" cp311 cp313
  local abi
  for abi in cp311 cp313; do
    local out="$root/build-blender-org/$abi/out" name="texsynth-$version-linux_x64-$abi.zip"
    local stage="$root/dist/stage-blender-org-$abi/texsynth"
    rm -rf "$root/dist/stage-blender-org-$abi" "$root/dist/$name"
    mkdir -p "$stage"
    copy_py_tree "$stage"
    # The repository's manifest with the platform pinned: this package holds one Linux x86-64 module.
    grep -v '^platforms *=' "$root/addon/blender_manifest.toml" \
      | sed '/^license *=/a platforms = ["linux-x64"]' >"$stage/blender_manifest.toml"
    grep -qx 'platforms = \["linux-x64"\]' "$stage/blender_manifest.toml" \
      || { echo "package_addon: could not set platforms in the staged manifest" >&2; exit 1; }
    cp "$out"/texsynth_native.cpython-3*-x86_64-linux-gnu.so "$stage/"
    cp -r "$out/texsynth_native.libs" "$stage/"
    in_env trixie blender --command extension build --source-dir "/src/dist/stage-blender-org-$abi/texsynth" \
      --output-filepath "/src/dist/$name" >/dev/null
    in_env trixie blender --command extension validate "/src/dist/$name"
    rm -rf "$root/dist/stage-blender-org-$abi"
    # What the package is made of, compressed as stored.
    python3 - "$root/dist/$name" "$MAX_PACKAGE_BYTES" <<'PY'
import sys, zipfile
path, limit = sys.argv[1], int(sys.argv[2])
parts = {}
for item in zipfile.ZipFile(path).infolist():
    kind = ("module" if item.filename.startswith("texsynth_native.cpython") else
            "TBB" if "libtbb" in item.filename else "py files" if item.filename.endswith(".py") else "manifest")
    size, stored = parts.get(kind, (0, 0))
    parts[kind] = (size + item.file_size, stored + item.compress_size)
import os
total = os.path.getsize(path)
print("package_addon: %s: %.1f MB (%s)" % (path, total / 1e6, ", ".join(
    "%s %.2f MB unpacked / %.2f MB packed" % (k, v[0] / 1e6, v[1] / 1e6) for k, v in sorted(parts.items()))))
if total > limit:
    sys.exit("package_addon: %s is %d bytes, over the %d-byte limit" % (path, total, limit))
PY
  done
}

for env in "${envs[@]}"; do
  case "$env" in
    host|trixie|sid) ;;
    blender-org) package_blender_org; continue ;;
    *) echo "package_addon: unknown environment '$env' (host, trixie, sid, blender-org)" >&2; exit 2 ;;
  esac
  # What the environment's Blender runs: its version and its Python's module suffix.
  probe="$(in_env "$env" blender -b --factory-startup --python-expr \
    "import bpy, sys, sysconfig; print('PROBE', bpy.app.version_string.split()[0], '%d%d' % sys.version_info[:2], sysconfig.get_config_var('EXT_SUFFIX'))" \
    2>/dev/null | sed -n 's/^PROBE //p')"
  read -r blender_version py_tag suffix <<<"$probe"
  [ -n "${suffix:-}" ] || { echo "package_addon: could not ask $env's Blender for its version and Python" >&2; exit 1; }
  module="$root/addon/texsynth_native$suffix"
  # Debian packages carry both modules: texsynth_image_io (OpenImageIO) reads sample files by path.
  io_module="$root/addon/texsynth_image_io$suffix"
  if [ ! -f "$module" ] || [ ! -f "$io_module" ]; then
    if [ "$env" = host ]; then bash "$root/scripts/build.sh"; else bash "$root/scripts/blender_envs.sh" build "$env"; fi
  fi
  family="${blender_version%.*}"
  name="texsynth-$version-blender$family-py$py_tag.zip"
  stage="$root/dist/stage-$env/texsynth"
  rm -rf "$root/dist/stage-$env" "$root/dist/$name"
  mkdir -p "$stage"
  # The package tree: top-level modules and the sub-packages (no caches, no other builds' modules).
  copy_py_tree "$stage"
  cp "$root/addon/blender_manifest.toml" "$stage/"
  cp "$module" "$io_module" "$stage/"
  if [ "${blender_version%%.*}" -lt 4 ] || { [ "${blender_version%%.*}" -eq 4 ] && [ "${family#*.}" -lt 2 ]; }; then
    # Legacy add-on zip (Blender < 4.2 has no extension platform).
    (cd "$root/dist/stage-$env" && find texsynth -type f | LC_ALL=C sort | zip -q -X -@ "$root/dist/$name")
    kind="legacy add-on zip"
  else
    in_env "$env" blender --command extension build --source-dir "$(path_in_env "$env" "dist/stage-$env/texsynth")" \
      --output-filepath "$(path_in_env "$env" "dist/$name")" >/dev/null
    in_env "$env" blender --command extension validate "$(path_in_env "$env" "dist/$name")"
    kind="extension (built and validated by Blender $blender_version)"
  fi
  rm -rf "$root/dist/stage-$env"
  files="$(unzip -Z1 "$root/dist/$name" | grep -vc '/$')"
  echo "package_addon: $root/dist/$name ($kind, Blender $blender_version, Python ${py_tag:0:1}.${py_tag:1}, $files files, $(du -k "$root/dist/$name" | cut -f1) KB)"
done
