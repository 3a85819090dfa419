# SPDX-License-Identifier: GPL-3.0-or-later
"""Texture Particles operators: Analyse Sample (the analysis view), Pick Class (a click in the Image
Editor), Merge Class, Set as Background, Re-synthesize Class. Synthesize and Clear are the common ones."""
import os

import bpy

from ..core.settings import Settings, SettingsError
from ..particles import method as particle_method
from . import modal_jobs, properties
from .modal_jobs import label_pixels


def analyse(context):
    """Runs the analysis for the panel's settings; fills the class rows and the segmentation image.
    Returns (analysis, source, notes)."""
    from ..particles import core, scene, synthesis
    props = context.scene.texsynth
    settings = props.to_settings()
    if settings.method != particle_method.PARTICLES.id:  # the analysis view works whatever method is selected
        settings = Settings(**{**settings.__dict__, "method": particle_method.PARTICLES.id,
                               **particle_method.panel_settings(props)})
    sample = modal_jobs.sample_from_settings(props)
    analysis, source, notes = synthesis.analyse(sample, settings, properties.cache_dir(context), label_pixels(props))
    rows = core.class_rows(analysis)
    props.particle_rows.clear()
    for row in rows:
        item = props.particle_rows.add()
        item.class_id, item.colour, item.pixels = row["id"], row["colour"], row["pixels"]
        item.particles, item.complete = row["particles"], row["complete"]
        item.background, item.random = row["background"], row["random"]
    props.particle_preview = scene.segmentation_image(os.path.basename(sample.describe()),
                                                      core.segmentation_preview(analysis))
    return analysis, source, notes


class TEXSYNTH_OT_particle_analyse(bpy.types.Operator):
    """Segment the sample into particle classes and show the classes and a segmentation image"""
    bl_idname = "texsynth.particle_analyse"
    bl_label = "Analyse Sample"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        try:
            analysis, source, notes = analyse(context)
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        rows = context.scene.texsynth.particle_rows
        self.report({"WARNING"} if notes else {"INFO"}, "TexSynth: %d classes, %d particles (%d complete), "
                    "analysis %s%s" % (len(rows), sum(r.particles for r in rows if not r.background),
                                       sum(r.complete for r in rows if not r.background), source,
                                       "; " + "; ".join(notes) if notes else ""))
        return {"FINISHED"}


class TEXSYNTH_OT_particle_pick_class(bpy.types.Operator):
    """Pick the class under the Image Editor's cursor (or a click) in the segmentation or sample image"""
    bl_idname = "texsynth.particle_pick_class"
    bl_label = "Pick Class"
    bl_options = {"REGISTER", "UNDO"}

    x: bpy.props.IntProperty(name="X", default=-1, description="Sample pixel column (-1: the Image Editor's cursor)")
    y: bpy.props.IntProperty(name="Y", default=-1, description="Sample pixel row from the bottom")

    def invoke(self, context, event):
        space = context.space_data
        region = context.region
        if space is not None and space.type == "IMAGE_EDITOR" and space.image is not None and region is not None \
                and region.type == "WINDOW":  # a click in the image (from a header button: the 2D cursor)
            u, v = region.view2d.region_to_view(event.mouse_region_x, event.mouse_region_y)
            self.x, self.y = int(u * space.image.size[0]), int(v * space.image.size[1])
        return self.execute(context)

    def execute(self, context):
        from ..particles import core
        props = context.scene.texsynth
        try:
            x, y = self.x, self.y
            if x < 0 or y < 0:
                x, y = self._cursor(context)
            analysis, _, _ = analyse(context)
            props.particle_active_class = core.class_at(analysis, x, y)
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self.report({"INFO"}, "TexSynth: class %d picked at (%d, %d)" % (props.particle_active_class, x, y))
        return {"FINISHED"}

    @staticmethod
    def _cursor(context):
        space = context.space_data
        if space is None or space.type != "IMAGE_EDITOR" or space.image is None:
            raise SettingsError("pick a class in the Image Editor (showing the segmentation or the sample), "
                                         "or give the pixel's x and y")
        u, v = space.cursor_location
        return int(u * space.image.size[0]), int(v * space.image.size[1])


class TEXSYNTH_OT_particle_show_segmentation(bpy.types.Operator):
    """Show the segmentation image in the Image Editors of this window (pick classes there)"""
    bl_idname = "texsynth.particle_show_segmentation"
    bl_label = "Show in Image Editor"
    bl_options = {"REGISTER"}

    def execute(self, context):
        image = context.scene.texsynth.particle_preview
        screen = getattr(context, "screen", None)
        editors = [area.spaces.active for area in (screen.areas if screen else ()) if area.type == "IMAGE_EDITOR"]
        if image is None or not editors:
            self.report({"ERROR"}, "TexSynth: %s" % ("analyse the sample first" if image is None else
                                                     "open an Image Editor in this window first"))
            return {"CANCELLED"}
        for space in editors:
            space.image = image
        return {"FINISHED"}


def _reanalyse(operator, context, name, value):
    """Sets one analysis setting and analyses again; on an error the setting is put back and reported."""
    props = context.scene.texsynth
    old = getattr(props, name)
    setattr(props, name, value)
    try:
        analyse(context)
    except (ValueError, RuntimeError) as error:
        setattr(props, name, old)
        operator.report({"ERROR"}, str(error))
        return {"CANCELLED"}
    return {"FINISHED"}


class TEXSYNTH_OT_particle_merge(bpy.types.Operator):
    """Merge the picked class into another class (recorded in Merges, re-analysed)"""
    bl_idname = "texsynth.particle_merge"
    bl_label = "Merge Into"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        from ..particles import core
        props = context.scene.texsynth
        shown = len(props.particle_rows)
        a, b = props.particle_active_class, props.particle_merge_into
        try:
            merges = core.parse_merges(props.particle_merges)
            if a == b or not (0 <= a < shown and 0 <= b < shown):
                raise SettingsError("merge needs two different classes of the analysis (0..%d)" % (shown - 1))
            count = shown + len(merges)  # classes before the merges
            pair = (core.original_id(a, count, merges), core.original_id(b, count, merges))
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        return _reanalyse(self, context, "particle_merges", core.format_merges(merges + (pair,)))


class TEXSYNTH_OT_particle_set_background(bpy.types.Operator):
    """Make the picked class the background (synthesized as texture under the particles)"""
    bl_idname = "texsynth.particle_set_background"
    bl_label = "Set as Background"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        return _reanalyse(self, context, "particle_background_class", context.scene.texsynth.particle_active_class)


class TEXSYNTH_OT_particle_resynthesize(modal_jobs.JobOperator, bpy.types.Operator):
    """Place the picked class again on the selected objects, replacing only its decals / instances (Esc cancels)"""
    bl_idname = "texsynth.particle_resynthesize"
    bl_label = "Re-synthesize Class"
    bl_options = {"REGISTER", "UNDO"}

    def _job(self, context):
        return modal_jobs.method_job(context, sorted(context.selected_objects, key=lambda obj: obj.name),
                                     context.scene.texsynth.particle_active_class)


classes = (TEXSYNTH_OT_particle_analyse, TEXSYNTH_OT_particle_pick_class, TEXSYNTH_OT_particle_merge,
           TEXSYNTH_OT_particle_set_background, TEXSYNTH_OT_particle_resynthesize,
           TEXSYNTH_OT_particle_show_segmentation)


def _image_editor_button(self, context):
    """Pick Class in the Image Editor's header while it shows a segmentation image (uses the 2D cursor)."""
    space = context.space_data
    if space is not None and space.image is not None and space.image.name.startswith("TexSynth Segmentation: "):
        self.layout.operator(TEXSYNTH_OT_particle_pick_class.bl_idname, icon="EYEDROPPER")


def register_header():
    unregister_header()
    bpy.types.IMAGE_HT_header.append(_image_editor_button)


def unregister_header():
    try:
        bpy.types.IMAGE_HT_header.remove(_image_editor_button)
    except (ValueError, AttributeError):
        pass
