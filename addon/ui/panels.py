# SPDX-License-Identifier: GPL-3.0-or-later
"""3D Viewport sidebar tab "TexSynth"."""
import bpy

from .. import native
from ..core import pipeline
from . import operators


class TEXSYNTH_PT_main(bpy.types.Panel):
    bl_label = "TexSynth"
    bl_idname = "TEXSYNTH_PT_main"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "TexSynth"

    def draw(self, context):
        layout = self.layout
        props = context.scene.texsynth
        if native.reason():
            box = layout.box()
            box.label(text="Native module unavailable:", icon="ERROR")
            for line in _wrap(native.reason(), 40):
                box.label(text=line)

        layout.prop(props, "sample_source", expand=True)
        if props.sample_source == "FILE":
            layout.prop(props, "sample_path", text="")
            key = props.sample_path or "<none>"
        else:
            layout.template_ID(props, "sample_image", open="image.open")
            key = props.sample_image.name if props.sample_image else "<none>"
        row = layout.row(align=True)
        row.operator("texsynth.preprocess")
        row.operator("texsynth.check_cache", text="", icon="FILE_REFRESH")
        layout.label(text="Cache: %s" % operators.cache_status_by_sample.get(key, "unknown"))

        layout.prop(props, "method")
        layout.prop(props, "scale")
        layout.prop(props, "seed")
        if props.method == "JUMPMAP":
            layout.prop(props, "jump_rate")
        layout.prop(props, "orientation")
        if props.orientation == "AXIS":
            layout.prop(props, "axis")
        else:
            layout.prop(props, "direction_attribute")
        layout.prop(props, "scale_source")
        if props.scale_source == "ATTRIBUTE":
            layout.prop(props, "scale_attribute")
        elif props.scale_source == "VERTEX_GROUP":
            obj = context.active_object
            if obj is not None and obj.type == "MESH":
                layout.prop_search(props, "scale_group", obj, "vertex_groups")
            else:
                layout.prop(props, "scale_group")
            row = layout.row(align=True)
            row.prop(props, "scale_min")
            row.prop(props, "scale_max")
        layout.prop(props, "blend")
        if props.blend:
            layout.prop(props, "blend_mode")
        if props.method == "TEXTON" and props.blend:
            layout.prop(props, "blend_threshold")
            if props.blend_threshold > 0.0 and context.scene.camera is None:
                layout.label(text="Blend threshold needs a scene camera", icon="ERROR")
        layout.prop(props, "allow_oversized")
        layout.prop(props, "material_mode")

        column = layout.column()
        column.enabled = not native.reason()
        column.scale_y = 1.4
        column.operator("texsynth.synthesize", icon="TEXTURE")
        layout.operator("texsynth.clear", icon="X")

        box = layout.box()
        box.label(text="Bake", icon="RENDER_STILL")
        box.prop(props, "bake_target")
        obj = context.active_object
        if obj is not None and obj.type == "MESH":
            box.prop_search(props, "bake_uv_map", obj.data, "uv_layers")
            if props.bake_uv_map == pipeline.BASE_UV_NAME:
                box.label(text="TexSynth's own UV map overlaps: choose another", icon="ERROR")
        else:
            box.prop(props, "bake_uv_map")
        box.prop(props, "bake_create_uv")
        row = box.row(align=True)
        row.prop(props, "bake_size")
        row.prop(props, "bake_margin")
        box.prop(props, "bake_save_mode")
        box.prop(props, "bake_material")
        box.operator("texsynth.bake", icon="RENDER_STILL")


class TEXSYNTH_PT_field(bpy.types.Panel):
    bl_label = "Direction Field"
    bl_idname = "TEXSYNTH_PT_field"
    bl_parent_id = "TEXSYNTH_PT_main"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "TexSynth"

    def draw(self, context):
        from ..fields import tools
        layout = self.layout
        props = context.scene.texsynth
        column = layout.column()
        column.enabled = not native.reason()
        row = column.row(align=True)
        row.operator("texsynth.comb", icon="BRUSH_DATA")
        row.prop(props, "field_erase", toggle=True, icon="X", text="")
        row = column.row(align=True)
        row.prop(props, "field_brush_radius")
        row.prop(props, "field_brush_strength")
        row = column.row(align=True)
        row.operator("texsynth.singularity", text="Source").mode = "SOURCE"
        row.operator("texsynth.singularity", text="Sink").mode = "SINK"
        row.operator("texsynth.singularity", text="Remove").mode = "REMOVE"
        column.operator("texsynth.field_from_strokes", icon="GREASEPENCIL")
        row = column.row(align=True)
        row.operator("texsynth.field_preset", text="Axis").preset = "AXIS"
        row.operator("texsynth.field_preset", text="Curvature").preset = "CURVATURE"
        row.operator("texsynth.field_preset", text="Smooth").preset = "SMOOTH"
        row = column.row(align=True)
        row.prop(props, "show_field", toggle=True, icon="ORIENTATION_GIMBAL")
        row.prop(props, "field_arrow_density")
        column.prop(props, "field_arrow_length")
        column.prop(props, "field_live_update")
        if "live_native" in tools.last_timings:
            column.label(text="Last live update: %.0f ms (native %.0f ms)" % (
                1000 * tools.last_timings["live_update"], 1000 * tools.last_timings["live_native"]))


def _wrap(text, width):
    words, lines, line = text.split(), [], ""
    for word in words:
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = (line + " " + word).strip()
    return lines + ([line] if line else [])


classes = (TEXSYNTH_PT_main, TEXSYNTH_PT_field)
