#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Regenerates the pictures of docs/user/images/: screenshots of the TexSynth sidebar in a real Blender UI
# (under Xvfb) and a result per method (scripts/docs_screenshots.py, one Blender per shot, on
# blend_samples/scene.blend). Installs xvfb with apt-get when xvfb-run is missing.
# Usage: scripts/docs_screenshots.sh [--blender PATH] [--out DIR] [SHOT...]
#   SHOT: jumpmap texton round patches particles fields bake full (default: all)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
blender=blender
out="$root/docs/user/images"
shots=()
while [ $# -gt 0 ]; do
  case "$1" in
    --blender) blender="$2"; shift ;;
    --out) out="$2"; shift ;;
    -*) echo "docs_screenshots: unknown option $1" >&2; exit 2 ;;
    *) shots+=("$1") ;;
  esac
  shift
done
[ ${#shots[@]} -gt 0 ] || shots=(jumpmap texton round patches particles fields bake full)
if ! command -v xvfb-run >/dev/null 2>&1; then
  echo "docs_screenshots: installing xvfb" >&2
  sudo_cmd=""; [ "$(id -u)" -eq 0 ] || sudo_cmd=sudo
  $sudo_cmd apt-get update
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y xvfb xauth
fi
command -v "$blender" >/dev/null 2>&1 || { echo "docs_screenshots: no Blender at '$blender' (use --blender PATH)" >&2; exit 1; }
ls "$root"/addon/texsynth_native*.so >/dev/null 2>&1 \
  || { echo "docs_screenshots: addon/texsynth_native*.so not built (run scripts/build.sh)" >&2; exit 1; }
mkdir -p "$out"
# A tall screen: the whole sidebar fits without scrolling. Software GL when there is no GPU.
export LIBGL_ALWAYS_SOFTWARE="${LIBGL_ALWAYS_SOFTWARE:-1}"
failed=0
for shot in "${shots[@]}"; do
  start=$(date +%s)
  log="$out/.${shot}.log"
  xvfb-run -a -s "-screen 0 1600x1800x24" "$blender" --factory-startup --enable-event-simulate \
    "$root/blend_samples/scene.blend" --python "$root/scripts/docs_screenshots.py" -- "$out" "$shot" \
    >"$log" 2>&1 || true
  if grep -q "^DOCSHOT $shot done" "$log"; then
    grep "^DOCSHOT $shot wrote" "$log" | sed 's/^DOCSHOT /docs_screenshots: /'
    echo "docs_screenshots: $shot in $(( $(date +%s) - start )) s"
    rm -f "$log"
  else
    echo "docs_screenshots: $shot FAILED (log: $log)" >&2
    tail -20 "$log" >&2
    failed=1
  fi
done
exit $failed
