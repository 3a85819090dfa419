# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators: Preprocess, Synthesize (all selected mesh objects), Clear, Bake (active object)."""
import atexit
import threading
import weakref

import bpy

from .. import compat
from ..core.reporting import Timings
from ..core.settings import SURFACE_METHODS, SettingsError
from . import properties
from ..uv_methods import synthesis

# Last known cache status per sample description, shown by the panel.
cache_status_by_sample = {}


def sample_from_settings(settings):
    if settings.sample_source == "IMAGE":
        if settings.sample_image is None:
            raise SettingsError("no sample image: choose an image in the .blend")
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
        if props.method in SURFACE_METHODS + ("PARTICLES",):
            self.report({"INFO"}, "TexSynth: %s works on the sample directly; nothing to preprocess"
                        % props.bl_rna.properties["method"].enum_items[props.method].name)
            return {"FINISHED"}
        try:
            sample = sample_from_settings(props)
            settings = props.to_settings().validate()
            with _Progress(context) as progress:
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


class JobOperator:
    """An operator running a Job (prepare / compute / apply): blocking from scripts, in a worker thread with
    Esc from the UI. Subclasses give _job(context)."""

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT"

    def _job(self, context):
        raise NotImplementedError

    def _finish(self, job):
        cache_status_by_sample[job.sample.describe()] = "fresh"
        report = self.last_report = job.report
        if not report.objects:
            self.report({"ERROR"}, report.summary())
            return {"CANCELLED"}
        self.report({"WARNING"} if report.failures or report.notes else {"INFO"}, report.summary())
        return {"FINISHED"}

    def execute(self, context):
        """Blocking run (scripts, tests, redo panel)."""
        job = None
        try:
            job = self._job(context)
            job.prepare()
            with _Progress(context) as progress:
                job.compute(progress).apply(progress)
        except (ValueError, RuntimeError) as error:
            if job is not None:
                job.discard()
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        return self._finish(job)

    def invoke(self, context, event):
        """From the UI: native work in a worker thread (GIL released), Esc cancels it."""
        if context.window is None:
            return self.execute(context)
        job = None
        try:
            job = self._job(context)
            self._job_state = ModalSynthesis(job.prepare())
        except (ValueError, RuntimeError) as error:
            if job is not None:
                job.discard()
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self._job_state.start()
        self._timer = context.window_manager.event_timer_add(ModalSynthesis.POLL_SECONDS, window=context.window)
        context.window_manager.modal_handler_add(self)
        context.window_manager.progress_begin(0, 1000)
        compat.status_text_set(context, "TexSynth: synthesizing... (Esc to cancel)")
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        state = self._job_state
        if event.type == "ESC" and event.value == "PRESS":
            state.job.cancel()
        if event.type != "TIMER" and event.type != "ESC":
            return {"RUNNING_MODAL"}  # block other input: the meshes must not change mid-run
        if state.running():
            context.window_manager.progress_update(int(1000 * state.live_fraction()))
            return {"RUNNING_MODAL"}
        context.window_manager.event_timer_remove(self._timer)
        context.window_manager.progress_end()
        compat.status_text_set(context, None)
        try:
            state.finish()  # re-raises the worker's error, or Cancelled
            state.job.apply()
        except (ValueError, RuntimeError) as error:
            state.job.discard()
            self.report({"WARNING"} if isinstance(error, synthesis.Cancelled) else {"ERROR"}, str(error))
            return {"CANCELLED"}
        return self._finish(state.job)


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
                                         properties.cache_dir(context) or synthesis.default_cache_dir())
        return synthesis.Job(objects, sample_from_settings(props), settings, properties.cache_dir(context),
                             props.material_mode, context.scene)

class ModalSynthesis:
    """Runs Job.compute in a worker thread; the modal operator polls it (and the tests drive it)."""
    POLL_SECONDS = 0.05
    running_states = weakref.WeakSet()  # cancelled and joined when Python shuts down (Blender quits)

    def __init__(self, job):
        self.job = job
        self.fraction = 0.0
        self.error = None
        self.thread = threading.Thread(target=self._run, name="TexSynth synthesis", daemon=True)

    def _progress(self, fraction, text):
        self.fraction = fraction  # read by the main thread; no bpy access from the worker

    def live_fraction(self):
        """The job's own finer progress (native progress of a long call) when it has one."""
        live = getattr(self.job, "live_fraction", None)
        return max(self.fraction, live()) if live is not None else self.fraction

    def _run(self):
        try:
            self.job.compute(self._progress)
        except BaseException as error:  # handed to the main thread by finish()
            self.error = error

    def start(self):
        ModalSynthesis.running_states.add(self)
        self.thread.start()
        return self

    def running(self):
        return self.thread.is_alive()

    def finish(self, timeout=None):
        """Waits for the worker; raises its error (synthesis.Cancelled after cancel())."""
        self.thread.join(timeout)
        if self.error is not None:
            raise self.error
        return self.job


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
            with _Progress(context) as progress:
                result = baking.bake(obj, request, context, progress)
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, "TexSynth bake: %s" % error)
            return {"CANCELLED"}
        self.last_result = result
        self.report({"WARNING"} if result.notes else {"INFO"}, result.summary(obj.name))
        return {"FINISHED"}


@atexit.register
def _stop_running_jobs():
    """Blender quitting mid-run: stop the native work before the interpreter and the native module's
    threads are torn down under it."""
    for state in list(ModalSynthesis.running_states):
        if state.running():
            state.job.cancel()
            state.thread.join(10.0)


classes = (TEXSYNTH_OT_preprocess, TEXSYNTH_OT_check_cache, TEXSYNTH_OT_synthesize, TEXSYNTH_OT_clear,
           TEXSYNTH_OT_bake)
