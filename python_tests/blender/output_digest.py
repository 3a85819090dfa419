# SPDX-License-Identifier: GPL-3.0-or-later
"""Runs every method through the CLI's code path on small meshes inside one Blender and prints one
digest per method of everything it wrote (mesh attributes and UV maps, images' pixels, child objects
and their transforms). Preprocessing caches go to a fresh folder, so every run computes them.

  blender -b --factory-startup --python-exit-code 1 --python python_tests/blender/output_digest.py \
      [-- [METHOD ...] [--cache-sizes L1 L2 L3]]

Prints `DIGEST {"jumpmap": "...", ...}`. python_tests/blender/test_cross_cpu.py compares the digests under
every run-time dispatch it can vary (docs/dev/determinism.md)."""
import hashlib
import json
import os
import sys
import tempfile

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402

METHODS = ("jumpmap", "texton", "round", "patches", "particles")
SAMPLES = {"jumpmap": "bricks.png", "texton": "moss.png", "round": "bark.png", "patches": "bricks.png",
           "particles": "pebbles.png"}
# Surface colours per vertex: no image to bake (Smart UV Project would add Blender's own arithmetic).
EXTRA = {"round": ["--target", "vertices"], "patches": ["--target", "vertices"], "particles": ["--classes", "3"]}


def scene_digest():
    digest = hashlib.sha256()
    for obj in sorted(bpy.data.objects, key=lambda o: o.name):
        digest.update(("object|%s|%s|%s|" % (obj.name, obj.type, obj.parent.name if obj.parent else "")).encode())
        digest.update(np.array(obj.matrix_world, dtype=np.float32).tobytes())
        if obj.type == "MESH":
            digest.update(harness.mesh_hash(obj.data).encode())
    for image in sorted(bpy.data.images, key=lambda i: i.name):
        if not image.has_data and image.source != "GENERATED" and not image.packed_file:
            continue
        pixels = np.empty(len(image.pixels), dtype=np.float32)
        image.pixels.foreach_get(pixels)
        digest.update(("image|%s|%d|%d|" % (image.name, image.size[0], image.size[1])).encode())
        digest.update(pixels.tobytes())
    return digest.hexdigest()[:16]


def torus(name, rings=72, segments=36, major=1.0, minor=0.4):
    """A quad torus from arrays (positive and negative curvature). Not a Blender primitive: the UV
    sphere's own UV map differs from run to run in Blender 3.4.1."""
    u, v = np.meshgrid(np.arange(rings) * 2 * np.pi / rings, np.arange(segments) * 2 * np.pi / segments,
                       indexing="ij")
    radius = major + minor * np.cos(v)
    positions = np.stack([radius * np.cos(u), radius * np.sin(u), minor * np.sin(v)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(rings), np.arange(segments), indexing="ij")
    a, b = i * segments + j, ((i + 1) % rings) * segments + j
    c, d = ((i + 1) % rings) * segments + (j + 1) % segments, i * segments + (j + 1) % segments
    corners = np.stack([a, b, c, d], axis=-1).reshape(-1).astype(np.int32)
    polys = rings * segments
    return harness.mesh_from_arrays(name, positions, corners, np.arange(polys, dtype=np.int32) * 4,
                                    np.full(polys, 4, dtype=np.int32))


def main():
    args = harness.script_args()
    methods = [a for a in args if a in METHODS] or list(METHODS)
    sys.path.insert(0, harness.ADDON_DIR)
    import texsynth_cli

    texsynth_cli.load_addon()
    from texsynth import native

    if "--cache-sizes" in args:  # L1 L2 L3 in bytes, as another CPU reports them to Eigen
        at = args.index("--cache-sizes")
        native.get()._set_matrix_cache_sizes(*(int(v) for v in args[at + 1:at + 4]))

    digests = {}
    with tempfile.TemporaryDirectory() as cache:
        for method in methods:
            harness.reset_scene()
            torus("Target")
            args = ["--sample", os.path.join(harness.SAMPLES_DIR, SAMPLES[method]), "--object", "Target",
                    "--method", method, "--scale", "1.5", "--seed", "5",
                    "--cache-dir", os.path.join(cache, method)] + EXTRA.get(method, [])
            texsynth_cli.main(args)
            digests[method] = scene_digest()
    print("DIGEST " + json.dumps(digests, sort_keys=True), flush=True)


main()
