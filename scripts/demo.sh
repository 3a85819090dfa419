#!/usr/bin/env bash
# The main job: installs, builds, and renders out/demo.png (Eevee): the sample scene's ground
# textured with moss and Suzanne with bricks by TexSynth, through the headless CLI.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
bash scripts/install_deps.sh
bash scripts/build.sh
mkdir -p out
cli=(--factory-startup --python-exit-code 1 --python addon/texsynth_cli.py --)
blender -b blend_samples/scene.blend "${cli[@]}" --sample blend_samples/moss.png --object Ground \
  --scale 2.0 --seed 11 --save out/demo_scene.blend
blender -b out/demo_scene.blend "${cli[@]}" --sample blend_samples/bricks.png --object Suzanne \
  --scale 1.2 --seed 5 --render out/demo.png --resolution 640 480 --stats out/demo_stats.json
echo "demo: wrote out/demo.png (stats: out/demo_stats.json)"
