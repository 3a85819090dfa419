# SPDX-License-Identifier: GPL-3.0-or-later
"""Helpers for scripts run inside `blender -b --factory-startup --python-exit-code 1 --python <script>`:
load the add-on from the source tree, build test meshes, hash meshes, tiny check framework."""
import hashlib
import importlib.util
import os
import sys
import tempfile
import traceback

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ADDON_DIR = os.path.join(ROOT, "addon")
SAMPLES_DIR = os.path.join(ROOT, "blend_samples")


def load_addon(name="texsynth"):
    """Imports addon/ as package `name` (as when installed), without enabling it."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, os.path.join(ADDON_DIR, "__init__.py"),
                                                  submodule_search_locations=[ADDON_DIR])
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def reset_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def flat_render_settings(scene, pixels, samples=1):
    """Eevee (the version's own), `samples` samples, a square image of `pixels`, the Standard view
    transform with no look: rendered values are the shaders' values, for measurements."""
    load_addon().compat.use_eevee(scene)
    scene.eevee.taa_render_samples = samples
    scene.render.resolution_x = scene.render.resolution_y = pixels
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    return scene


def emission_material(name, build_color):
    """A material whose surface is Emission(colour) with colour = build_color(nodes, links)."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    emission = nodes.new("ShaderNodeEmission")
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(emission.outputs["Emission"], output.inputs["Surface"])
    links.new(build_color(nodes, links), emission.inputs["Color"])
    return material


def select_only(objects):
    # 4.x lists removed objects as None until the view layer is updated.
    bpy.context.view_layer.update()
    for obj in bpy.context.view_layer.objects:
        if obj is not None:
            obj.select_set(False)
    for obj in objects:
        obj.select_set(True)
    if objects:
        bpy.context.view_layer.objects.active = objects[0]


def add_primitive(kind, name, **kwargs):
    getattr(bpy.ops.mesh, "primitive_%s_add" % kind)(**kwargs)
    obj = bpy.context.active_object
    obj.name = name
    obj.data.name = name
    return obj


def mesh_from_arrays(name, positions, corner_verts, poly_starts, poly_sizes):
    """A linked object from Blender-layout arrays, built with foreach_set (primitive operators are
    far too slow for the large meshes of benchmarks and cancellation tests)."""
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", np.ascontiguousarray(positions, dtype=np.float32).ravel())
    mesh.loops.add(len(corner_verts))
    mesh.loops.foreach_set("vertex_index", corner_verts)
    mesh.polygons.add(len(poly_starts))
    mesh.polygons.foreach_set("loop_start", poly_starts)
    mesh.polygons.foreach_set("loop_total", poly_sizes)
    mesh.update(calc_edges=True)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def save_png(path, rgba_bottom_first):
    """Writes an (H, W, 4) float RGBA array (row 0 = bottom, Blender's order) as a PNG file; returns path."""
    height, width = rgba_bottom_first.shape[:2]
    image = bpy.data.images.new("save_png", width, height, alpha=True)
    try:
        image.pixels.foreach_set(np.ascontiguousarray(rgba_bottom_first, dtype=np.float32).ravel())
        image.filepath_raw, image.file_format = path, "PNG"
        image.save()
    finally:
        bpy.data.images.remove(image)
    return path


def pixel_digest(image):
    """sha256 of an image's float pixels (what Blender shows), to compare an image across a save + reload or undo."""
    values = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(values)
    return hashlib.sha256(values.tobytes()).hexdigest()


def save_and_reload(name="reload.blend"):
    """wm.save_as_mainfile to a new temporary folder, then wm.open_mainfile of that file: only what a .blend
    keeps survives (datablocks with no user and no fake user are dropped). Every Python reference to a
    datablock is stale afterwards. Returns the path."""
    path = os.path.join(tempfile.mkdtemp(prefix="texsynth_reload_"), name)
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    return path


def mixed_grid(name="Mixed"):
    """A flat mesh mixing quads, triangles and a pentagon that share edges."""
    verts = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0), (3, 1, 0),
             (1.5, 1.8, 0), (0.5, 1.6, 0), (2.5, 1.6, 0)]
    faces = [(0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7), (2, 7, 6), (4, 5, 8, 9), (5, 6, 7, 10, 8)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def mesh_hash(mesh):
    """Hash of every attribute and UV layer (names, domains, types, values), layer order and flags."""
    digest = hashlib.sha256()
    for attribute in sorted(mesh.attributes, key=lambda a: a.name):
        digest.update(("%s|%s|%s|" % (attribute.name, attribute.domain, attribute.data_type)).encode())
        digest.update(_attribute_bytes(attribute))
    digest.update(repr([(l.name, l.active_render) for l in mesh.uv_layers]).encode())
    digest.update(repr(mesh.uv_layers.active_index).encode())
    for layer in mesh.uv_layers:
        values = np.empty(len(layer.data) * 2, dtype=np.float32)
        layer.data.foreach_get("uv", values)
        digest.update(values.tobytes())
    for collection, key, dtype, size in ((mesh.vertices, "co", np.float32, 3),
                                         (mesh.loops, "vertex_index", np.int32, 1),
                                         (mesh.polygons, "loop_start", np.int32, 1)):
        values = np.empty(len(collection) * size, dtype=dtype)
        collection.foreach_get(key, values)
        digest.update(values.tobytes())
    return digest.hexdigest()


def _attribute_bytes(attribute):
    key = {"FLOAT": "value", "INT": "value", "BOOLEAN": "value", "FLOAT_VECTOR": "vector",
           "FLOAT_COLOR": "color", "BYTE_COLOR": "color", "FLOAT2": "vector", "INT8": "value",
           "STRING": None}.get(attribute.data_type)
    if key is None or len(attribute.data) == 0:
        return b""
    width = {"vector": 3 if attribute.data_type == "FLOAT_VECTOR" else 2, "color": 4}.get(key, 1)
    dtype = {"INT": np.int32, "INT8": np.int32, "BOOLEAN": bool}.get(attribute.data_type, np.float32)
    values = np.empty(len(attribute.data) * width, dtype=dtype)
    attribute.data.foreach_get(key, values)
    return values.tobytes()


class Checks:
    """Runs test functions, prints PASS/FAIL lines, exits non-zero when any failed."""

    def __init__(self):
        self.failed = []

    def run(self, functions, only=None):
        for function in functions:
            if only and function.__name__ not in only:
                continue
            try:
                function()
                print("PASS", function.__name__, flush=True)
            except Exception:
                self.failed.append(function.__name__)
                print("FAIL", function.__name__, flush=True)
                traceback.print_exc(file=sys.stdout)  # under its FAIL line: the pytest case shows it
                sys.stdout.flush()
        print("SUMMARY failed=%d %s" % (len(self.failed), " ".join(self.failed)), flush=True)
        sys.exit(1 if self.failed else 0)


def script_args():
    return sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
