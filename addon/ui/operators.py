# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators: Preprocess, Synthesize (all selected mesh objects), Clear, Bake (active object)."""
import bpy

from .. import methods
from ..core.reporting import Timings
from . import properties
from .modal_jobs import JobOperator, Progress, cache_status_by_sample, method_job, sample_from_settings
from ..uv_methods import synthesis


class TEXSYNTH_OT_preprocess(bpy.types.Operator):
    """Preprocess the sample (textons and jump map) into the cache"""
    bl_idname = "texsynth.preprocess"
    bl_label = "Preprocess"
    bl_options = {"REGISTER"}

    def execute(self, context):
        props = context.scene.texsynth
        spec = methods.get(props.method)
        if not spec.writes_uv:  # only the UV methods analyse the sample ahead (textons, jump map)
            self.report({"INFO"}, "TexSynth: %s works on the sample directly; nothing to preprocess" % spec.label)
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
        return method_job(context, sorted(context.selected_objects, key=lambda obj: obj.name))


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
