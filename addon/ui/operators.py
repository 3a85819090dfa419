# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators: Preprocess, Synthesize (all selected mesh objects), Clear, Bake (active object)."""
import bpy

from ..bridge import sources
from ..core.reporting import Timings
from ..core.settings import SURFACE_METHODS
from . import properties
from .modal_jobs import JobOperator, Progress, cache_status_by_sample, sample_from_settings
from ..uv_methods import synthesis


class TEXSYNTH_OT_preprocess(bpy.types.Operator):
    """Preprocess the sample (textons and jump map) into the cache"""
    bl_idname = "texsynth.preprocess"
    bl_label = "Preprocess"
    bl_options = {"REGISTER"}

    def execute(self, context):
        props = context.scene.texsynth
        if props.method in SURFACE_METHODS + ("PARTICLES",):
            self.report({"INFO"}, "TexSynth: %s works on the sample directly; nothing to preprocess"
                        % props.bl_rna.properties["method"].enum_items[props.method].name)
            return {"FINISHED"}
        try:
            sample = sample_from_settings(props)
            settings = props.to_settings().validate()
            with Progress(context) as progress:
                progress(0.0, "TexSynth: preprocessing %s" % sample.describe())
                timings = Timings()
                pre = synthesis.preprocess(sample, settings, properties.cache_dir(context), timings)
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        cache_status_by_sample[sample.describe()] = "fresh"
        self.report({"INFO"}, "TexSynth: %s %dx%d preprocessed in %.2f s (cache %s)" % (
            sample.describe(), pre.width, pre.height, timings.as_dict()["total"],
            "hit" if pre.cache_hit else "miss"))
        return {"FINISHED"}


class TEXSYNTH_OT_check_cache(bpy.types.Operator):
    """Check whether the sample's cached preprocessing is fresh, stale or missing"""
    bl_idname = "texsynth.check_cache"
    bl_label = "Check Cache"
    bl_options = {"REGISTER"}

    def execute(self, context):
        props = context.scene.texsynth
        try:
            sample = sample_from_settings(props)
            status = synthesis.cache_status(sample, props.to_settings().validate(), properties.cache_dir(context))
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        cache_status_by_sample[sample.describe()] = status
        self.report({"INFO"}, "TexSynth cache: %s" % status)
        return {"FINISHED"}


class TEXSYNTH_OT_synthesize(JobOperator, bpy.types.Operator):
    """Synthesize the sample texture on every selected mesh object (Esc cancels, changing nothing)"""
    bl_idname = "texsynth.synthesize"
    bl_label = "Synthesize"
    bl_options = {"REGISTER", "UNDO"}

    def _job(self, context):
        props = context.scene.texsynth
        objects = sorted(context.selected_objects, key=lambda obj: obj.name)
        settings = props.to_settings()
        if settings.method == "PARTICLES":
            from .particle_operators import particle_job
            return particle_job(context, objects)
        if settings.method in SURFACE_METHODS:
            from ..surface_colour import synthesis as surface_synthesis
            return surface_synthesis.Job(objects, sample_from_settings(props), settings, props.to_bake_request(),
                                         props.material_mode, context,
                                         properties.cache_dir(context) or sources.default_cache_dir())
        return synthesis.Job(objects, sample_from_settings(props), settings, properties.cache_dir(context),
                             props.material_mode, context.scene)


class TEXSYNTH_OT_clear(bpy.types.Operator):
    """Remove every UV map and attribute TexSynth wrote from the selected mesh objects, and their particle decals and instances"""
    bl_idname = "texsynth.clear"
    bl_label = "Clear"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT"

    def execute(self, context):
        from ..particles import synthesis as particle_synthesis
        changed, removed = particle_synthesis.clear(context.selected_objects)
        self.report({"INFO"}, "TexSynth: removed %d layer(s) from %d object(s)" % (removed, changed))
        return {"FINISHED"}


class TEXSYNTH_OT_bake(bpy.types.Operator):
    """Bake the active object's TexSynth result into one image through a UV map (Cycles), for export and painting"""
    bl_idname = "texsynth.bake"
    bl_label = "Bake"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return context.mode == "OBJECT" and obj is not None and obj.type == "MESH"

    def execute(self, context):
        from ..bake import baking
        obj = context.active_object
        try:
            request = context.scene.texsynth.to_bake_request()
            with Progress(context) as progress:
                result = baking.bake(obj, request, context, progress)
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, "TexSynth bake: %s" % error)
            return {"CANCELLED"}
        self.last_result = result
        self.report({"WARNING"} if result.notes else {"INFO"}, result.summary(obj.name))
        return {"FINISHED"}


classes = (TEXSYNTH_OT_preprocess, TEXSYNTH_OT_check_cache, TEXSYNTH_OT_synthesize, TEXSYNTH_OT_clear,
           TEXSYNTH_OT_bake)
