# SPDX-License-Identifier: GPL-3.0-or-later
"""Small helpers hiding Blender-version-dependent API (3.4 ... 4.x).

The blend group sums weighted colours with Vector Math nodes (same in 3.x and 4.x), so it needs no
MixRGB / Mix node switch."""
import os

import bpy


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


def new_separate_color_node(nodes):
    """A node splitting a colour into R, G, B outputs (ShaderNodeSeparateColor since 3.3)."""
    if hasattr(bpy.types, "ShaderNodeSeparateColor"):
        return nodes.new("ShaderNodeSeparateColor")
    return nodes.new("ShaderNodeSeparateRGB")


def separate_color_outputs(node):
    """The three channel outputs of new_separate_color_node()."""
    names = ("Red", "Green", "Blue") if node.bl_idname == "ShaderNodeSeparateColor" else ("R", "G", "B")
    return [node.outputs[name] for name in names]


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
