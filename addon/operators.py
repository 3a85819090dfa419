# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators: Preprocess, Synthesize (all selected mesh objects), Clear."""
import bpy

from . import compat, pipeline, properties, synthesis

# Last known cache status per sample description, shown by the panel.
cache_status_by_sample = {}


def sample_from_settings(settings):
    if settings.sample_source == "IMAGE":
        if settings.sample_image is None:
            raise pipeline.SettingsError("no sample image: choose an image in the .blend")
        return synthesis.Sample(image=settings.sample_image)
    return synthesis.Sample(path=settings.sample_path)


class _Progress:
    """Window-manager progress bar + status text; always ended."""

    def __init__(self, context):
        self.context = context
        self.wm = context.window_manager

    def __enter__(self):
        self.wm.progress_begin(0, 1000)
        return self

    def __call__(self, fraction, text):
        self.wm.progress_update(int(1000 * min(max(fraction, 0.0), 1.0)))
        compat.status_text_set(self.context, text)

    def __exit__(self, *exc):
        self.wm.progress_end()
        compat.status_text_set(self.context, None)
        return False


class TEXSYNTH_OT_preprocess(bpy.types.Operator):
    """Preprocess the sample (textons and jump map) into the cache"""
    bl_idname = "texsynth.preprocess"
    bl_label = "Preprocess"
    bl_options = {"REGISTER"}

    def execute(self, context):
        props = context.scene.texsynth
        try:
            sample = sample_from_settings(props)
            settings = props.to_settings().validate()
            with _Progress(context) as progress:
                progress(0.0, "TexSynth: preprocessing %s" % sample.describe())
                timings = pipeline.Timings()
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


class TEXSYNTH_OT_synthesize(bpy.types.Operator):
    """Synthesize the sample texture on every selected mesh object"""
    bl_idname = "texsynth.synthesize"
    bl_label = "Synthesize"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT"

    def execute(self, context):
        props = context.scene.texsynth
        objects = sorted(context.selected_objects, key=lambda obj: obj.name)
        try:
            sample = sample_from_settings(props)
            with _Progress(context) as progress:
                report = synthesis.synthesize(objects, sample, props.to_settings(), properties.cache_dir(context),
                                              props.material_mode, progress)
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        cache_status_by_sample[sample.describe()] = "fresh"
        self.last_report = report
        if not report.objects:
            self.report({"ERROR"}, report.summary())
            return {"CANCELLED"}
        self.report({"WARNING"} if report.failures else {"INFO"}, report.summary())
        return {"FINISHED"}


class TEXSYNTH_OT_clear(bpy.types.Operator):
    """Remove every UV map and attribute TexSynth wrote from the selected mesh objects"""
    bl_idname = "texsynth.clear"
    bl_label = "Clear"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT"

    def execute(self, context):
        changed, removed = synthesis.clear(context.selected_objects)
        self.report({"INFO"}, "TexSynth: removed %d layer(s) from %d object(s)" % (removed, changed))
        return {"FINISHED"}


classes = (TEXSYNTH_OT_preprocess, TEXSYNTH_OT_check_cache, TEXSYNTH_OT_synthesize, TEXSYNTH_OT_clear)
