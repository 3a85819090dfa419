#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Installs the add-on into Blender's user scripts as `texsynth` (symlink to addon/, or a copy with
# --copy), enables it and saves the preferences. Honours BLENDER_USER_SCRIPTS / BLENDER_USER_CONFIG.
# Usage: scripts/install_addon.sh [--copy] [--blender /path/to/blender]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
mode=link
blender=blender
while [ $# -gt 0 ]; do
  case "$1" in
    --copy) mode=copy ;;
    --blender) blender="$2"; shift ;;
    *) echo "install_addon: unknown option $1 (use --copy, --blender PATH)" >&2; exit 2 ;;
  esac
  shift
done
if ! ls "$root"/addon/texsynth_native*.so >/dev/null 2>&1; then
  echo "install_addon: warning: addon/texsynth_native*.so not built yet (run scripts/build.sh); the panel will say so" >&2
fi
addons_dir="$("$blender" -b --factory-startup --python-expr \
  "import bpy; print('ADDONS_DIR=' + bpy.utils.user_resource('SCRIPTS', path='addons', create=True))" 2>/dev/null \
  | sed -n 's/^ADDONS_DIR=//p')"
[ -n "$addons_dir" ] || { echo "install_addon: could not ask Blender for its user scripts folder" >&2; exit 1; }
mkdir -p "$addons_dir"
target="$addons_dir/texsynth"
rm -rf "$target"
if [ "$mode" = link ]; then
  ln -s "$root/addon" "$target"
else
  mkdir -p "$target"
  (cd "$root/addon" && find . -name '__pycache__' -prune -o -type f \( -name '*.py' -o -name '*.so' -o -name '*.toml' \) -print \
    | while read -r f; do mkdir -p "$target/$(dirname "$f")"; cp "$f" "$target/$f"; done)
fi
"$blender" -b --python-exit-code 1 --python-expr "
import addon_utils, bpy
module = addon_utils.enable('texsynth', default_set=True, handle_error=None)
assert module is not None, 'enabling texsynth failed'
bpy.ops.wm.save_userpref()
reason = module.native.reason()
print('TEXSYNTH_INSTALLED', module.__file__, '(native module: %s)' % (reason or 'ok'))
 " 2>/dev/null | sed -n 's/^TEXSYNTH_INSTALLED /install_addon: enabled /p'
echo "install_addon: $mode $target -> enabled in Blender's preferences"
