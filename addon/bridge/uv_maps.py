# SPDX-License-Identifier: GPL-3.0-or-later
"""UV maps for image targets (bake, surface colour): choosing one, or adding one with Smart UV Project and
packing its islands, without changing the mesh's other UV maps, selection or hide state."""
import math

import bpy
import numpy as np

from ..core import bake_options as options
from ..core.bake_options import BakeError
from ..core.layers import MAX_UV_LAYERS, is_texsynth_uv_name


def choose_uv_map(mesh, request):
    """(name of an existing UV map, or None when one must be created); BakeError if there is none to use."""
    names = [layer.name for layer in mesh.uv_layers]
    if request.uv_map == options.BASE_UV_NAME:
        raise BakeError(options.uv_refusal())
    if not request.auto_uv:
        if request.uv_map not in names:
            others = [n for n in names if not is_texsynth_uv_name(n)]
            raise BakeError("mesh %r has no UV map %r (its UV maps: %s)"
                            % (mesh.name, request.uv_map, ", ".join(others) or "none besides TexSynth's"))
        return request.uv_map
    others = [n for n in names if not is_texsynth_uv_name(n)]
    if others:
        active = mesh.uv_layers.active.name if mesh.uv_layers.active is not None else ""
        return active if active in others else others[0]
    if not request.create_uv:
        raise BakeError("mesh %r has no UV map besides TexSynth's (whose islands overlap): choose to create one "
                        "with Smart UV Project (operator option, CLI --bake-uv auto)" % mesh.name)
    if len(names) >= MAX_UV_LAYERS:
        raise BakeError("mesh %r already has Blender's maximum of %d UV maps" % (mesh.name, MAX_UV_LAYERS))
    return None


def _read_flags(collection, name):
    values = np.empty(len(collection), dtype=bool)
    collection.foreach_get(name, values)
    return values


def _mesh_flags(mesh):
    return {(kind, flag): _read_flags(getattr(mesh, kind), flag)
            for kind in ("vertices", "edges", "polygons") for flag in ("select", "hide")}


def _set_flags(mesh, flags):
    for (kind, flag), values in flags.items():
        getattr(mesh, kind).foreach_set(flag, values)


def pack_islands(size):
    """Packs the selected faces' islands options.PACK_GAP_TEXELS apart in a size² image. Blender 3.6+
    packs by shape when asked, 30-80 s on a 75k-face mesh: bounding boxes are packed (under a second)."""
    extra = {}
    properties = bpy.ops.uv.pack_islands.get_rna_type().properties.keys()
    if "shape_method" in properties:
        extra["shape_method"] = "AABB"
    if "margin_method" in properties:
        extra["margin_method"] = "FRACTION"
    bpy.ops.uv.select_all(action="SELECT")
    bpy.ops.uv.pack_islands(rotate=True, margin=options.pack_margin(size), **extra)


def smart_project(obj, request, context):
    """Adds a UV map (Smart UV Project over all faces, hidden ones too) without changing the others, the
    active UV map or the mesh's selection and hide state; returns its name. A mesh that had no active UV
    map (no UV map at all) gets the new one as its active map: an active index of -1 next to an existing
    map stays -1 on Blender 3.4 (4.x clamps it to 0), and Cycles' bake refuses such a mesh ("No active
    UV layer found")."""
    mesh = obj.data
    flags = _mesh_flags(mesh)
    # Blender 4+ stores these flags as internal attributes, created when first written: remove the
    # ones this function created (their values were all False before) so the mesh is as it was.
    attributes_before = set(mesh.attributes.keys())
    active_index = mesh.uv_layers.active_index
    render_active = [layer.active_render for layer in mesh.uv_layers]
    layer = mesh.uv_layers.new(name=options.SMART_UV_NAME, do_init=False)
    if layer is None:
        raise BakeError("could not add a UV map to mesh %r" % mesh.name)
    name = layer.name
    mesh.uv_layers.active = layer
    try:
        for kind in ("vertices", "edges", "polygons"):
            count = len(getattr(mesh, kind))
            if flags[(kind, "hide")].any():
                getattr(mesh, kind).foreach_set("hide", np.zeros(count, bool))
            getattr(mesh, kind).foreach_set("select", np.ones(count, bool))
        with _edit_mode(obj, context):
            bpy.ops.uv.smart_project(angle_limit=math.radians(options.SMART_UV_ANGLE_DEGREES), island_margin=0.0)
            pack_islands(request.size)
    except Exception:
        remove_uv_map(mesh, name)
        raise
    finally:
        _set_flags(mesh, flags)
        for kind in ("vert", "edge", "poly"):
            for flag in ("hide", "select"):
                created = mesh.attributes.get(".%s_%s" % (flag, kind))
                if created is not None and created.name not in attributes_before:
                    mesh.attributes.remove(created)
        if active_index >= 0 or mesh.uv_layers.get(name) is None:
            mesh.uv_layers.active_index = active_index
        else:
            mesh.uv_layers.active = mesh.uv_layers[name]
        for layer, flag in zip(mesh.uv_layers, render_active):
            layer.active_render = flag
        mesh.update()
    return name


def remove_uv_map(mesh, name):
    layer = mesh.uv_layers.get(name)
    if layer is not None:
        mesh.uv_layers.remove(layer)


class _edit_mode:
    """Edit mode on obj, made the only selected, active object for one operator call: Edit Mode takes
    every selected mesh along, and Smart UV Project would re-project their UV maps too. The selection
    and the active object are restored afterwards."""

    def __init__(self, obj, context):
        self.obj, self.context = obj, context

    def __enter__(self):
        objects = self.context.view_layer.objects
        self.active = objects.active
        self.selected = [o for o in objects if o is not None and o.select_get()]
        for other in self.selected:
            if other is not self.obj:
                other.select_set(False)
        self.obj.select_set(True)
        objects.active = self.obj
        bpy.ops.object.mode_set(mode="EDIT")
        return self

    def __exit__(self, *exc):
        bpy.ops.object.mode_set(mode="OBJECT")
        objects = self.context.view_layer.objects
        if self.obj not in self.selected:
            self.obj.select_set(False)
        for other in self.selected:
            other.select_set(True)
        objects.active = self.active
        return False
