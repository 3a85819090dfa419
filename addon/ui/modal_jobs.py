# SPDX-License-Identifier: GPL-3.0-or-later
"""How every method's run is driven from the UI: a Job (prepare / compute / apply) blocking from scripts, or
with its compute in a worker thread and Esc to cancel from the UI, with the progress bar and the report."""
import atexit
import threading
import weakref

from .. import compat, methods
from ..bridge import mesh_io, sources
from ..core.jobs import Cancelled
from ..core.method_spec import RunRequest
from ..core.settings import SettingsError
from . import properties


# Last known cache status per sample description, shown by the panel.
cache_status_by_sample = {}


def sample_from_settings(settings):
    if settings.sample_source == "IMAGE":
        if settings.sample_image is None:
            raise SettingsError("no sample image: choose an image in the .blend")
        return sources.Sample(image=settings.sample_image)
    return sources.Sample(path=settings.sample_path)


def label_pixels(props):
    """The label image's pixels, bottom row first (what the particle analysis takes), or None."""
    image = props.particle_label_image
    if image is None:
        return None
    return mesh_io.read_image_pixels(image)[::-1]


def method_job(context, objects, only_class=None):
    """The Job of the panel's method for these objects, from the method's own factory (methods.py)."""
    props = context.scene.texsynth
    settings = props.to_settings()
    spec = methods.get(settings.method)
    run = RunRequest(objects, sample_from_settings(props), settings, cache_dir=properties.cache_dir(context),
                     material_mode=props.material_mode, bake_request=props.to_bake_request(), context=context,
                     scene=context.scene, label_pixels=label_pixels(props) if spec.reads_label_image else None,
                     only_class=only_class)
    return spec.make_job(run)


class Progress:
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
            with Progress(context) as progress:
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
            self.report({"WARNING"} if isinstance(error, Cancelled) else {"ERROR"}, str(error))
            return {"CANCELLED"}
        return self._finish(state.job)


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
        """Waits for the worker; raises its error (Cancelled after cancel())."""
        self.thread.join(timeout)
        if self.error is not None:
            raise self.error
        return self.job


@atexit.register
def _stop_running_jobs():
    """Blender quitting mid-run: stop the native work before the interpreter and the native module's
    threads are torn down under it."""
    for state in list(ModalSynthesis.running_states):
        if state.running():
            state.job.cancel()
            state.thread.join(10.0)
