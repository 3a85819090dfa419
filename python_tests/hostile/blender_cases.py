# SPDX-License-Identifier: GPL-3.0-or-later
"""The hostile cases run through the add-on inside Blender (python_tests/blender/tests_hostile.py),
derived from the native corpus (make_corpus.py). Meshes whose index arrays Blender itself cannot hold
(out-of-range corners, faces of < 3 corners, overlapping loops) are left to the native harness."""
import json
import os

BLENDER_MESHES = ["empty", "one_vertex", "loose_edges_only", "grid_quads", "grid_tris", "zero_area_faces",
                  "sliver_faces", "duplicate_vertices", "nonmanifold_fan", "inconsistent_winding", "tris_quads_20gon",
                  "coords_1e30", "coords_near_float_max", "coords_nan", "coords_inf", "coords_neg_inf",
                  "two_components", "repeated_vertex_in_face"]

SETTINGS_VARIANTS = {
    "default": {},
    "no_blend": dict(blend=False),
    "tiny_world_size": dict(scale=1e-4),  # the property's minimum: faces far larger than the sample
    "tiny_world_size_allow_oversized": dict(scale=1e-4, allow_oversized=True),
    "huge_world_size": dict(scale=1e9),
    "seed_max": dict(seed=2**31 - 1),
    "jump_rate_zero": dict(jump_rate=0.0),
    "jump_rate_huge": dict(jump_rate=3e38),
    "anchors_on_first_component": dict(orientation="ANCHORS", direction_attribute="flow", direction="first_vertex"),
    "field_all_zero": dict(orientation="FIELD", direction_attribute="flow", direction="zeros"),
    "field_nan": dict(orientation="FIELD", direction_attribute="flow", direction="nan"),
    "field_missing_attribute": dict(orientation="FIELD", direction_attribute="missing"),
}

VALID_MESHES = {"grid_quads", "grid_tris", "zero_area_faces", "sliver_faces", "duplicate_vertices", "nonmanifold_fan",
                "inconsistent_winding", "tris_quads_20gon", "two_components", "repeated_vertex_in_face"}

CLI_IMAGES = ["zero_bytes.png", "truncated_50.png", "truncated_half.jpg", "truncated_half.exr", "1x1.png",
              "huge_16k.png", "nan_inf.exr", "palette.png", "two_channel.png", "16bit.png", "cmyk.tif",
              "directory.png", "missing.png"]


def generate(corpus, native_cases):
    cases = []
    for mesh in BLENDER_MESHES:
        variants = SETTINGS_VARIANTS if mesh in ("grid_quads", "two_components", "tris_quads_20gon") else \
            {k: SETTINGS_VARIANTS[k] for k in ("default", "tiny_world_size", "no_blend")}
        for name, settings in variants.items():
            valid = mesh in VALID_MESHES and name in ("default", "no_blend", "seed_max", "huge_world_size",
                                                      "anchors_on_first_component", "field_all_zero",
                                                      "tiny_world_size_allow_oversized")
            cases.append(dict(id="blender/mesh/%s/%s" % (mesh, name), kind="mesh", mesh="meshes/%s.npz" % mesh,
                              settings=settings, expect="ok" if valid else "either"))
    for case in native_cases:
        if case["kind"] == "image":
            cases.append(dict(id="blender/" + case["id"], kind="mesh", mesh="meshes/grid_quads.npz",
                              settings=dict(sample=case["file"], scale=8.0),
                              expect="ok" if case["expect"] == "ok" else "either"))
    corrupt = [c for c in native_cases if c["kind"] == "cache" and c["expect"] == "error"
               and not c["id"].endswith("hash_mismatch") and "directory" not in c["id"]]
    for case in corrupt[::max(1, len(corrupt) // 12)]:
        cases.append(dict(id="blender/corrupt_" + case["id"], kind="mesh", mesh="meshes/grid_quads.npz",
                          settings=dict(scale=8.0), corrupt_cache=case["file"], expect="ok"))
    for point in ("uv_layer", "sets", "weights", "material"):  # jump map: no "extras" (texton only)
        cases.append(dict(id="blender/fail_at/" + point, kind="mesh", mesh="meshes/tris_quads_20gon.npz",
                          settings=dict(scale=4.0), fail_at=point, expect="error"))
    with open(os.path.join(corpus, "blender_cases.json"), "w") as f:
        json.dump(cases, f, indent=1)
    return cases
