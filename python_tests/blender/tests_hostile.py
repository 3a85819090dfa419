# SPDX-License-Identifier: GPL-3.0-or-later
"""Hostile cases through the Synthesize operator inside Blender (driven by test_hostile_blender.py):

  blender -b --factory-startup --python tests_hostile.py -- CORPUS_DIR CASES.json FIRST_INDEX

Each case builds a mesh (with foreign UV map and attributes), runs bpy.ops.texsynth.synthesize and
prints one JSON line: ok (layers written, finite, foreign data untouched, one undo restores the mesh
byte-identical), error (a clear error and the mesh byte-identical), or partial / invalid / unclear.
"""
import hashlib
import json
import os
import shutil
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import harness  # noqa: E402

texsynth = harness.load_addon()
from texsynth import native  # noqa: E402
from texsynth.bridge import mesh_io  # noqa: E402
from texsynth.bridge import sources  # noqa: E402

texsynth.register()
CACHE_DIR = tempfile.mkdtemp(prefix="texsynth_hostile_blender_cache_")
sources.default_cache_dir = lambda: CACHE_DIR  # isolated cache, removed at the end


def full_hash(mesh):
    """harness.mesh_hash (positions, loops, every layer and attribute) + edges, face sizes, materials."""
    digest = hashlib.sha256(harness.mesh_hash(mesh).encode())
    for collection, key, size in ((mesh.edges, "vertices", 2), (mesh.polygons, "loop_total", 1),
                                  (mesh.polygons, "material_index", 1)):
        values = np.empty(len(collection) * size, dtype=np.int32)
        collection.foreach_get(key, values)
        digest.update(values.tobytes())
    digest.update(repr([m.name if m else None for m in mesh.materials]).encode())
    return digest.hexdigest()


def foreign_hash(mesh):
    """Everything TexSynth must never touch: geometry, foreign UV maps and attributes."""
    digest = hashlib.sha256()
    for collection, key, dtype, size in ((mesh.vertices, "co", np.float32, 3), (mesh.loops, "vertex_index", np.int32, 1),
                                         (mesh.polygons, "loop_total", np.int32, 1)):
        values = np.empty(len(collection) * size, dtype=dtype)
        collection.foreach_get(key, values)
        digest.update(values.tobytes())
    for layer in mesh.uv_layers:
        if not layer.name.startswith("TexSynth"):
            values = np.empty(len(layer.data) * 2, dtype=np.float32)
            layer.data.foreach_get("uv", values)
            digest.update(layer.name.encode() + values.tobytes())
    for attribute in sorted(mesh.attributes, key=lambda a: a.name):
        if attribute.name.startswith("foreign") or attribute.name == "flow":
            digest.update(attribute.name.encode() + harness._attribute_bytes(attribute))
    return digest.hexdigest()


def build_object(arrays, direction):
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    for mesh in list(bpy.data.meshes):
        bpy.data.meshes.remove(mesh)
    positions = arrays["positions"].astype(np.float32)
    mesh = bpy.data.meshes.new("Hostile")
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", positions.ravel())
    if len(arrays["poly_sizes"]):
        mesh.loops.add(len(arrays["corner_verts"]))
        mesh.loops.foreach_set("vertex_index", arrays["corner_verts"])
        mesh.polygons.add(len(arrays["poly_sizes"]))
        mesh.polygons.foreach_set("loop_start", arrays["poly_starts"])
        mesh.polygons.foreach_set("loop_total", arrays["poly_sizes"])
    elif len(positions) > 1:  # loose edges only: a chain through every vertex
        mesh.edges.add(len(positions) - 1)
        mesh.edges.foreach_set("vertices", np.repeat(np.arange(len(positions), dtype=np.int32), 2)[1:-1])
    mesh.update(calc_edges=True)
    uv = mesh.uv_layers.new(name="UVMap")
    if len(mesh.loops):
        uv.data.foreach_set("uv", (np.arange(len(mesh.loops) * 2) % 7 / 7.0).astype(np.float32))
    mesh.attributes.new("foreign_float", "FLOAT", "POINT").data.foreach_set(
        "value", np.arange(len(mesh.vertices), dtype=np.float32))
    mesh.attributes.new("foreign_color", "FLOAT_COLOR", "CORNER")
    if direction:
        vectors = np.zeros((len(mesh.vertices), 3), np.float32)
        if direction == "first_vertex" and len(vectors):
            vectors[0] = (1, 0, 0)
        elif direction == "nan" and len(vectors):
            vectors[:] = (1, 0, 0)
            vectors[len(vectors) // 2] = np.nan
        mesh.attributes.new("flow", "FLOAT_VECTOR", "POINT").data.foreach_set("vector", vectors.ravel())
    obj = bpy.data.objects.new("Hostile", mesh)
    bpy.context.scene.collection.objects.link(obj)
    harness.select_only([obj])
    return obj


def configure(corpus, settings):
    props = bpy.context.scene.texsynth
    values = dict(sample_source="FILE", sample_path=os.path.join(corpus, settings.get("sample", "images/sample.png")),
                  method="JUMPMAP", scale=4.0, seed=7, jump_rate=20.0, orientation="AXIS", axis=(0.0, 0.0, 1.0),
                  direction_attribute="", blend=True, allow_oversized=False, material_mode="NEW")
    values.update({k: v for k, v in settings.items() if k not in ("sample", "direction")})
    for key, value in values.items():
        setattr(props, key, value)
    return props


class Outcome(Exception):
    def __init__(self, outcome, detail):
        super().__init__(detail)
        self.outcome = outcome


def written_layers_ok(mesh):
    names = [layer.name for layer in mesh.uv_layers if layer.name.startswith("TexSynth")]
    for name in names:
        values = np.empty(len(mesh.loops) * 2, dtype=np.float32)
        mesh.uv_layers[name].data.foreach_get("uv", values)
        if not np.all(np.isfinite(values)):
            raise Outcome("invalid", "non-finite UVs in %s" % name)
    return names


def synthesize_checked(with_undo):
    """Runs the operator; returns (error message or None, written)."""
    mesh = bpy.data.objects["Hostile"].data
    before, before_foreign = full_hash(mesh), foreign_hash(mesh)
    if with_undo:
        bpy.ops.ed.undo_push(message="before TexSynth")
    try:
        result = bpy.ops.texsynth.synthesize("EXEC_DEFAULT", True) if with_undo else bpy.ops.texsynth.synthesize()
        error = None if result == {"FINISHED"} else "operator returned %s" % result
    except RuntimeError as exc:  # the operator's ERROR report
        error = str(exc).strip()
        if not error:
            raise Outcome("unclear", "empty error message")
    mesh = bpy.data.objects["Hostile"].data
    if error is not None:
        if full_hash(mesh) != before:
            raise Outcome("partial", "failed (%s) but the mesh changed" % error)
        return error, False
    if foreign_hash(mesh) != before_foreign:
        raise Outcome("partial", "geometry or foreign layers changed")
    names = written_layers_ok(mesh)
    if not names:
        raise Outcome("invalid", "FINISHED but nothing written")
    if with_undo:
        bpy.ops.ed.undo()
        if full_hash(bpy.data.objects["Hostile"].data) != before:
            raise Outcome("partial", "one undo did not restore the mesh exactly")
    return None, True


def run_case(corpus, case):
    arrays = dict(np.load(os.path.join(corpus, case["mesh"])))
    settings = case.get("settings", {})
    build_object(arrays, settings.get("direction"))
    configure(corpus, settings)
    if case.get("corrupt_cache"):
        props = bpy.context.scene.texsynth
        # Keyed on the pixels the add-on hands over (Blender's decoding of the sample).
        path = native.get().cache_file_path(sources.Sample(path=props.sample_path).native_input(), cache_dir=CACHE_DIR,
                                            **props.to_settings().preprocess_params())
        shutil.copyfile(os.path.join(corpus, case["corrupt_cache"]), path)
    if case.get("fail_at"):
        return run_failure_injection(case["fail_at"])
    error, written = synthesize_checked(with_undo=True)
    return ("error", error) if error else ("ok", "written and undone")


def run_failure_injection(point):
    """Fails at `point` on a fresh mesh, then again when replacing an earlier result: unchanged both times."""
    os.environ[mesh_io.FAIL_AT_ENV] = point
    try:
        first, _ = synthesize_checked(with_undo=False)
        if first is None or "injected" not in first:
            raise Outcome("invalid", "injected failure did not surface: %s" % first)
        del os.environ[mesh_io.FAIL_AT_ENV]
        ok, _ = synthesize_checked(with_undo=False)
        if ok is not None:
            raise Outcome("invalid", "clean run failed: %s" % ok)
        bpy.context.scene.texsynth.seed = 12345
        os.environ[mesh_io.FAIL_AT_ENV] = point
        second, _ = synthesize_checked(with_undo=False)
        if second is None:
            raise Outcome("invalid", "injected failure on rerun did not surface")
    finally:
        os.environ.pop(mesh_io.FAIL_AT_ENV, None)
    return "error", second


def main():
    args = harness.script_args()
    corpus, cases_file, first = args[0], args[1], int(args[2])
    cases = json.load(open(cases_file))
    print("NATIVE", "real" if hasattr(native.get(), "synthesize_jumpmap") else "missing", flush=True)
    try:
        for index in range(first, len(cases)):
            print(json.dumps({"start": index}), flush=True)
            try:
                outcome, detail = run_case(corpus, cases[index])
            except Outcome as result:
                outcome, detail = result.outcome, str(result)
            except Exception as error:  # noqa: B902 - anything else escaping the operator is a finding
                outcome, detail = "unclear", "%s: %s" % (type(error).__name__, error)
            print(json.dumps({"index": index, "outcome": outcome, "detail": str(detail)[:300]}), flush=True)
    finally:
        shutil.rmtree(CACHE_DIR, ignore_errors=True)


main()
