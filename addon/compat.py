# SPDX-License-Identifier: GPL-3.0-or-later
"""Everything that differs between the Blender versions TexSynth supports (3.4 ... 5.2 LTS).

The blend group sums weighted colours with Vector Math nodes (same in 3.x and 4.x), so it needs no
MixRGB / Mix node switch."""
import importlib.util
import os
import sys

import bpy

OLDEST_SUPPORTED = (3, 4, 0)
NEWEST_TESTED = (5, 2)


def unsupported_version_message(version):
    """One clear sentence when `version` (a bpy.app.version tuple) is too old for TexSynth, else ''."""
    if tuple(version[:3]) < OLDEST_SUPPORTED:
        return ("TexSynth needs Blender %d.%d or newer; this is Blender %s"
                % (OLDEST_SUPPORTED[0], OLDEST_SUPPORTED[1], ".".join(str(v) for v in version[:3])))
    return ""


def missing_requirement_message(find_spec=importlib.util.find_spec):
    """One sentence when a Python package TexSynth needs is not importable, else ''. Blender from
    blender.org ships NumPy; Debian's blender package does not depend on python3-numpy."""
    try:
        spec = find_spec("numpy")
    except (ImportError, ValueError):
        spec = None
    if spec is None:
        return ("TexSynth needs NumPy, which this Blender's Python (%s) cannot import: on Debian and Ubuntu, "
                "install the python3-numpy package" % ".".join(str(v) for v in sys.version_info[:2]))
    return ""


def untested_version_message(version):
    """A warning when `version` is newer than any Blender TexSynth was tested on, else ''."""
    if tuple(version[:2]) > NEWEST_TESTED:
        return ("TexSynth was tested on Blender 3.4 to %d.%d; Blender %s may behave differently"
                % (NEWEST_TESTED[0], NEWEST_TESTED[1], ".".join(str(v) for v in version[:3])))
    return ""


def group_socket_names(group, in_out):
    """Names of a node group's interface sockets; in_out is 'INPUT' or 'OUTPUT'."""
    if hasattr(group, "interface"):
        return [item.name for item in group.interface.items_tree
                if getattr(item, "item_type", "SOCKET") == "SOCKET" and item.in_out == in_out]
    sockets = group.inputs if in_out == "INPUT" else group.outputs
    return [socket.name for socket in sockets]


def ensure_group_socket(group, name, in_out, socket_type):
    """Adds an interface socket (3.x group.inputs/outputs.new, 4.x group.interface.new_socket) once."""
    if name in group_socket_names(group, in_out):
        return
    if hasattr(group, "interface"):
        group.interface.new_socket(name=name, in_out=in_out, socket_type=socket_type)
    else:
        sockets = group.inputs if in_out == "INPUT" else group.outputs
        sockets.new(socket_type, name)


def import_mesh_file(path):
    """Imports an .obj/.ply/.stl with whichever operator this Blender has; returns the new objects."""
    extension = os.path.splitext(path)[1].lower()
    before = set(bpy.data.objects)
    ops = bpy.ops
    if extension == ".obj":
        if hasattr(ops.wm, "obj_import"):
            ops.wm.obj_import(filepath=path)
        else:
            ops.import_scene.obj(filepath=path)
    elif extension == ".ply":
        if hasattr(ops.wm, "ply_import") and bpy.app.version >= (3, 6, 0):
            ops.wm.ply_import(filepath=path)
        else:
            ops.import_mesh.ply(filepath=path)
    elif extension == ".stl":
        if hasattr(ops.wm, "stl_import") and bpy.app.version >= (4, 1, 0):
            ops.wm.stl_import(filepath=path)
        else:
            ops.import_mesh.stl(filepath=path)
    else:
        raise ValueError("unsupported mesh file type %r (use .obj, .ply or .stl)" % extension)
    return [obj for obj in bpy.data.objects if obj not in before and obj.type == "MESH"]


def use_eevee(scene):
    """Selects Eevee (named BLENDER_EEVEE_NEXT in 4.2 - 4.x, BLENDER_EEVEE otherwise)."""
    for name in ("BLENDER_EEVEE_NEXT", "BLENDER_EEVEE"):
        try:
            scene.render.engine = name
            return name
        except TypeError:
            continue
    raise RuntimeError("this Blender has no Eevee render engine")


def status_text_set(context, text):
    """Shows text in the status bar when there is a UI (no-op in background mode)."""
    workspace = getattr(context, "workspace", None)
    if workspace is not None and not bpy.app.background:
        try:
            workspace.status_text_set(text)
        except (AttributeError, RuntimeError):
            pass


def uniform_color_shader():
    """The built-in flat-colour 3D shader: 'UNIFORM_COLOR' in 4.x, '3D_UNIFORM_COLOR' in 3.x."""
    import gpu
    try:
        return gpu.shader.from_builtin("UNIFORM_COLOR")
    except (ValueError, TypeError):
        return gpu.shader.from_builtin("3D_UNIFORM_COLOR")


# Grease Pencil objects: GPENCIL (legacy, 3.x) and GREASEPENCIL (Grease Pencil v3, 4.3+).
GREASE_PENCIL_OBJECT_TYPES = {"GPENCIL", "GREASEPENCIL"}


def scene_annotation(context):
    """The annotation data the artist draws with: context.annotation_data in the UI, else the scene's
    (scene.grease_pencil up to 4.x, scene.annotation from 5.0)."""
    data = getattr(context, "annotation_data", None)
    if data is None:
        scene = context.scene
        data = getattr(scene, "annotation", None) or getattr(scene, "grease_pencil", None)
    return data


def _displayed_frame(layer, current):
    """The frame a layer shows at frame `current`: the last one at or before it."""
    if hasattr(layer, "current_frame"):  # Grease Pencil v3
        return layer.current_frame()
    frame = getattr(layer, "active_frame", None)  # legacy: only set once the layer has been drawn
    if frame is not None:
        return frame
    shown = [f for f in layer.frames if f.frame_number <= current]
    return max(shown, key=lambda f: f.frame_number) if shown else None


def stroke_polylines(data, current_frame):
    """Polylines (n x 3 float64, in data space) of every visible layer's displayed strokes, read in bulk:
    legacy strokes (annotations, 3.x Grease Pencil) point by stroke, Grease Pencil v3 drawings (4.3+)
    through their position attribute and curve offsets."""
    import numpy as np  # lazily: compat must import without NumPy (missing_requirement_message)

    polylines = []
    for layer in data.layers:
        if getattr(layer, "hide", False):
            continue
        frame = _displayed_frame(layer, current_frame)
        if frame is None:
            continue
        drawing = getattr(frame, "drawing", None)
        if drawing is not None:
            positions_attribute = drawing.attributes.get("position")
            count = len(positions_attribute.data) if positions_attribute is not None else 0
            if count == 0:
                continue
            positions = np.empty(count * 3, np.float32)
            positions_attribute.data.foreach_get("vector", positions)
            positions = positions.reshape(-1, 3).astype(np.float64)
            offsets = np.empty(len(drawing.curve_offsets), np.int32)
            drawing.curve_offsets.foreach_get("value", offsets)
            polylines += [positions[start:end] for start, end in zip(offsets[:-1], offsets[1:]) if end > start]
            continue
        for stroke in frame.strokes:
            points = np.empty(len(stroke.points) * 3, np.float32)
            stroke.points.foreach_get("co", points)
            polylines.append(points.reshape(-1, 3).astype(np.float64))
    return polylines


def use_alpha_blend(material):
    """Alpha-blended surface in Eevee: blend_method 'BLEND' up to 4.1, surface_render_method 'BLENDED'
    from 4.2 (Eevee Next; blend_method is gone in 5.x). Cycles reads the Principled Alpha either way."""
    if hasattr(material, "surface_render_method"):
        material.surface_render_method = "BLENDED"
    else:
        material.blend_method = "BLEND"
        if hasattr(material, "shadow_method"):
            material.shadow_method = "HASHED"
    if hasattr(material, "show_transparent_back"):
        material.show_transparent_back = False  # decals of one class never sort against each other


def mark_modifier_group(group):
    """Geometry Nodes groups must be flagged as modifiers to be listed in the modifier (4.0+)."""
    if hasattr(group, "is_modifier"):
        group.is_modifier = True


def named_attribute_output(node):
    """The Named Attribute node's value output: one 'Attribute' socket in 4.x; in 3.x one per data type,
    only the one of node.data_type enabled."""
    outputs = [socket for socket in node.outputs if socket.name == "Attribute"]
    enabled = [socket for socket in outputs if getattr(socket, "enabled", True)]
    return (enabled or outputs)[0]
