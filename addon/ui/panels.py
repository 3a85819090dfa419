# SPDX-License-Identifier: GPL-3.0-or-later
"""3D Viewport sidebar tab "TexSynth"."""
import bpy

from .. import methods, native
from ..core.layers import BASE_UV_NAME
from . import modal_jobs


class _SubPanel:
    bl_parent_id = "TEXSYNTH_PT_main"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "TexSynth"


class TEXSYNTH_PT_main(bpy.types.Panel):
    """Synthesize / Clear on top; the settings in the sub-panels below, in the order an artist sets them."""
    bl_label = "TexSynth"
    bl_idname = "TEXSYNTH_PT_main"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "TexSynth"

    def draw(self, context):
        layout = self.layout
        if native.reason():
            box = layout.box()
            box.label(text="Native module unavailable:", icon="ERROR")
            for line in _wrap(native.reason(), 40):
                box.label(text=line)
        column = layout.column()
        column.enabled = not native.reason()
        column.scale_y = 1.4
        column.operator("texsynth.synthesize", icon="TEXTURE")
        layout.operator("texsynth.clear", icon="X")


class TEXSYNTH_PT_sample(_SubPanel, bpy.types.Panel):
    bl_label = "Sample"
    bl_idname = "TEXSYNTH_PT_sample"

    def draw(self, context):
        layout = self.layout
        props = context.scene.texsynth
        layout.prop(props, "sample_source", expand=True)
        if props.sample_source == "FILE":
            layout.prop(props, "sample_path", text="")
            key = props.sample_path or "<none>"
        else:
            layout.template_ID(props, "sample_image", open="image.open")
            key = props.sample_image.name if props.sample_image else "<none>"
        if not methods.get(props.method).writes_uv:  # only the UV methods analyse the sample ahead
            layout.label(text="No preprocessing needed", icon="INFO")
            return
        row = layout.row(align=True)
        row.operator("texsynth.preprocess")
        row.operator("texsynth.check_cache", text="", icon="FILE_REFRESH")
        layout.label(text="Cache: %s" % modal_jobs.cache_status_by_sample.get(key, "unknown"))


class TEXSYNTH_PT_method(_SubPanel, bpy.types.Panel):
    bl_label = "Method"
    bl_idname = "TEXSYNTH_PT_method"

    def draw(self, context):
        layout = self.layout
        props = context.scene.texsynth
        layout.prop(props, "method", text="")
        layout.prop(props, "seed")
        methods.get(props.method).draw(layout, props, context)  # the method's own settings


class TEXSYNTH_PT_orientation(_SubPanel, bpy.types.Panel):
    bl_label = "Orientation & Scale"
    bl_idname = "TEXSYNTH_PT_orientation"

    def draw(self, context):
        layout = self.layout
        props = context.scene.texsynth
        layout.prop(props, "scale")
        layout.label(text="Orientation:")
        layout.prop(props, "orientation", text="")
        if props.orientation == "AXIS":
            layout.row().prop(props, "axis", text="")
        else:
            layout.prop(props, "direction_attribute", text="")
        layout.label(text="Scale Map:")
        layout.prop(props, "scale_source", text="")
        if props.scale_source == "ATTRIBUTE":
            layout.prop(props, "scale_attribute", text="")
        elif props.scale_source == "VERTEX_GROUP":
            obj = context.active_object
            if obj is not None and obj.type == "MESH":
                layout.prop_search(props, "scale_group", obj, "vertex_groups", text="")
            else:
                layout.prop(props, "scale_group", text="")
            row = layout.row(align=True)
            row.prop(props, "scale_min")
            row.prop(props, "scale_max")


class TEXSYNTH_PT_output(_SubPanel, bpy.types.Panel):
    bl_label = "Output / Bake"
    bl_idname = "TEXSYNTH_PT_output"

    def draw(self, context):
        layout = self.layout
        props = context.scene.texsynth
        layout.label(text="Material:")
        layout.prop(props, "material_mode", text="")
        spec = methods.get(props.method)
        if not (spec.writes_uv or spec.colours_surface):
            return  # a method with its own outputs (particles) shows them in its own panel
        surface = spec.colours_surface
        if surface:
            layout.label(text="Target:")
            layout.prop(props, "surface_target", expand=True)
            if props.surface_target == "VERTICES":
                layout.label(text="Attribute: TexSynth_Colour")
                return
        box = layout.box()
        box.label(text="Image" if surface else "Bake", icon="IMAGE_DATA" if surface else "RENDER_STILL")
        box.label(text="Name (empty: per object):")
        box.prop(props, "bake_target", text="")
        box.label(text="UV Map:")
        obj = context.active_object
        if obj is not None and obj.type == "MESH":
            box.prop_search(props, "bake_uv_map", obj.data, "uv_layers", text="")
            if props.bake_uv_map == BASE_UV_NAME:
                box.label(text="TexSynth's map overlaps", icon="ERROR")
        else:
            box.prop(props, "bake_uv_map", text="")
        box.prop(props, "bake_create_uv")
        sizes = box.column(align=True)
        sizes.prop(props, "bake_size")
        sizes.prop(props, "bake_margin")
        box.prop(props, "bake_save_mode", text="")
        if not surface:
            box.label(text="Baked Material:")
            box.prop(props, "bake_material", text="")
            box.operator("texsynth.bake", icon="RENDER_STILL")


class TEXSYNTH_PT_field(bpy.types.Panel):
    bl_label = "Direction Field"
    bl_idname = "TEXSYNTH_PT_field"
    bl_parent_id = "TEXSYNTH_PT_main"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "TexSynth"

    def draw(self, context):
        from . import field_edits
        layout = self.layout
        props = context.scene.texsynth
        column = layout.column()
        column.enabled = not native.reason()
        row = column.row(align=True)
        row.operator("texsynth.comb", icon="BRUSH_DATA")
        row.prop(props, "field_erase", toggle=True, icon="X", text="")
        brush = column.column(align=True)
        brush.prop(props, "field_brush_radius")
        brush.prop(props, "field_brush_strength")
        row = column.row(align=True)
        row.operator("texsynth.singularity", text="Source").mode = "SOURCE"
        row.operator("texsynth.singularity", text="Sink").mode = "SINK"
        row.operator("texsynth.singularity", text="Remove").mode = "REMOVE"
        column.operator("texsynth.field_from_strokes", icon="GREASEPENCIL")
        row = column.row(align=True)
        row.operator("texsynth.field_preset", text="Axis").preset = "AXIS"
        row.operator("texsynth.field_preset", text="Curvature").preset = "CURVATURE"
        row.operator("texsynth.field_preset", text="Smooth").preset = "SMOOTH"
        column.prop(props, "show_field", toggle=True, icon="ORIENTATION_GIMBAL")
        arrows = column.column(align=True)
        arrows.prop(props, "field_arrow_density")
        arrows.prop(props, "field_arrow_length")
        column.prop(props, "field_live_update")
        if "live_native" in field_edits.last_timings:
            column.label(text="Last live update: %.0f ms (native %.0f ms)" % (
                1000 * field_edits.last_timings["live_update"], 1000 * field_edits.last_timings["live_native"]))


class TEXSYNTH_PT_particles(_SubPanel, bpy.types.Panel):
    """Texture Particles: the analysis view (classes, segmentation), the artist's edits, the outputs."""
    bl_label = "Particles"
    bl_idname = "TEXSYNTH_PT_particles"

    @classmethod
    def poll(cls, context):
        return cls.bl_idname in methods.get(context.scene.texsynth.method).extra_panels

    def draw(self, context):
        layout = self.layout
        props = context.scene.texsynth
        if props.particle_preview is not None:
            layout.template_icon(icon_value=layout.icon(props.particle_preview), scale=8.0)
            layout.operator("texsynth.particle_show_segmentation", icon="IMAGE_DATA")
        if not props.particle_rows:
            layout.label(text="Analyse the sample first", icon="INFO")
        for item in props.particle_rows:
            row = layout.row(align=True)
            row.prop(item, "colour", text="")
            flags = "bg" if item.background else ("rnd" if item.random else "")
            row.label(text="%d: %dpx %d/%d %s" % (item.class_id, item.pixels, item.complete, item.particles, flags))
        row = layout.row(align=True)
        row.prop(props, "particle_active_class")
        row.operator("texsynth.particle_pick_class", text="", icon="EYEDROPPER")
        row = layout.row(align=True)
        row.operator("texsynth.particle_merge", text="Merge")
        row.prop(props, "particle_merge_into", text="")
        layout.operator("texsynth.particle_set_background")
        layout.label(text="Merges (a>b):")
        layout.prop(props, "particle_merges", text="")
        layout.label(text="Class Order:")
        layout.prop(props, "particle_class_order", text="")
        layout.label(text="Output:")
        layout.prop(props, "particle_output", text="")
        if props.particle_output != "DECALS":
            layout.label(text="Instance Collection:")
            layout.prop(props, "particle_collection", text="")
        layout.prop(props, "particle_size_jitter")
        layout.label(text="Background:")
        layout.prop(props, "particle_background", text="")
        obj = context.active_object
        for name, label in (("particle_density_source", "Density Override:"),
                            ("particle_probability_source", "Probability Override:"),
                            ("particle_size_source", "Size Override:")):
            layout.label(text=label)  # a face attribute or a vertex group (searched among the groups)
            if obj is not None and obj.type == "MESH":
                layout.prop_search(props, name, obj, "vertex_groups", text="")
            else:
                layout.prop(props, name, text="")
        layout.operator("texsynth.particle_resynthesize", icon="FILE_REFRESH")


def _wrap(text, width):
    words, lines, line = text.split(), [], ""
    for word in words:
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = (line + " " + word).strip()
    return lines + ([line] if line else [])


# Registration order is the sidebar order.
classes = (TEXSYNTH_PT_main, TEXSYNTH_PT_sample, TEXSYNTH_PT_method, TEXSYNTH_PT_orientation, TEXSYNTH_PT_field,
           TEXSYNTH_PT_particles, TEXSYNTH_PT_output)
