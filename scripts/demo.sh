#!/usr/bin/env bash
# The main job: installs, builds, and renders out/demo.png.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
bash scripts/install_deps.sh
bash scripts/build.sh
mkdir -p out
echo "demo: not yet wired"  # grown by the add-on issue
