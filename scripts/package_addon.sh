#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Builds dist/texsynth-<version>.zip for Preferences > Add-ons > Install: a folder texsynth/ with the
# add-on's Python files, blender_manifest.toml and the compiled texsynth_native module.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
if ! ls "$root"/addon/texsynth_native*.so >/dev/null 2>&1; then
  bash "$root/scripts/build.sh"
fi
/usr/bin/python3.11 - "$root" <<'PY'
import ast, os, sys, zipfile
root = sys.argv[1]
addon = os.path.join(root, "addon")
with open(os.path.join(addon, "__init__.py")) as handle:
    tree = ast.parse(handle.read())
info = next(ast.literal_eval(node.value) for node in tree.body
            if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == "bl_info")
version = ".".join(str(v) for v in info["version"])
os.makedirs(os.path.join(root, "dist"), exist_ok=True)
path = os.path.join(root, "dist", "texsynth-%s.zip" % version)
names = sorted(n for n in os.listdir(addon)
               if n.endswith((".py", ".toml")) or (n.startswith("texsynth_native") and n.endswith(".so")))
with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
    for name in names:
        archive.write(os.path.join(addon, name), "texsynth/" + name)
print("package_addon: %s (%d files, %.1f MB)" % (path, len(names), os.path.getsize(path) / 1e6))
PY
