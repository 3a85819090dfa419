# SPDX-License-Identifier: GPL-3.0-or-later
"""One Synthesize / Preprocess / Clear run over Blender objects, shared by the operators and the CLI.

Data flows one way: mesh_io.read_mesh (every object) -> native preprocess (cached) -> native
synthesis (every object; may run in a worker thread, cancellable) -> mesh_write.write_result (atomic)
-> material. Per-object failures are reported and do not stop the other objects; nothing is written
until every native call has finished, so cancelling leaves every mesh untouched.
"""
import threading
import time

import bpy

from .. import native
from ..bridge import mesh_io, mesh_layers, sources
from ..fields import mesh_state
from ..core.jobs import Cancelled
from ..core.reporting import Report, Timings
from ..core.sample_image import sample_pixels
from ..core.settings import Settings, SettingsError, object_seed, texels_per_unit
from .core import BlendShading, View, blend_shading
from . import core as uv_core
from . import mesh_write
from ..shading import blend_groups


def cache_status(sample, settings, cache_dir):
    return uv_core.cache_status(sample.native_input(), settings, cache_dir or sources.default_cache_dir())


def preprocess(sample, settings, cache_dir, timings=None):
    """Preprocessed sample (cached on disk)."""
    timings = timings or Timings()
    with timings.phase("preprocess"):
        native_input = sample.native_input()
        return uv_core.preprocess(native_input, settings, cache_dir or sources.default_cache_dir())


def camera_view(scene):
    """The scene camera as a View (world position, λ = render width / field of view), or None."""
    camera = scene.camera if scene is not None else None
    if camera is None or camera.type != "CAMERA":
        return None
    angle = float(camera.data.angle)  # horizontal field of view for the default sensor fit
    width = scene.render.resolution_x * scene.render.resolution_percentage / 100.0
    if not (angle > 0.0) or width <= 0:
        return None
    return View(position=tuple(camera.matrix_world.translation), pixels_per_radian=width / angle)


class Job:
    """One Synthesize run in three stages, so the native work can run in a worker thread:

    prepare()  main thread: validates, reads every mesh and the sample (bpy access);
    compute()  any thread: only native calls (GIL released), cancellable with cancel();
    apply()    main thread: writes every result (atomically per mesh) and the materials.

    Nothing is written before apply(), so a run cancelled or failing in compute() changes nothing.
    """

    def __init__(self, objects, sample, settings, cache_dir=None, material_mode="NEW", scene=None, preprocessed=None):
        self.objects, self.sample, self.settings = objects, sample, settings
        self.cache_dir, self.material_mode, self.scene = cache_dir, material_mode, scene
        self.preprocessed = preprocessed  # given: preprocessing is skipped (live updates)
        self.pixels = self.view = None
        self.shading = BlendShading()
        self.report, self.timings = Report(), Timings()
        self.items = []  # [obj, arrays, result]
        self.token = None
        self.cancelled = False

    def prepare(self):
        """Raises SettingsError / NativeUnavailable / ValueError for problems of the whole run."""
        self.settings.validate()
        meshes, self.report.failures = sources.mesh_objects(self.objects)
        if not meshes:
            raise SettingsError("no mesh object selected")
        module = native.require()
        self.token = module.CancelToken() if hasattr(module, "CancelToken") else None
        with self.timings.phase("preprocess"):
            self.native_input = self.sample.native_input()
        self.cache_dir = self.cache_dir or sources.default_cache_dir()
        if self.settings.method == "TEXTON":
            self.pixels = sample_pixels(self.native_input)
            self.view = camera_view(self.scene or bpy.context.scene)
            if self.settings.blend_threshold > 0.0 and self.view is None:
                raise SettingsError(
                    "a blend threshold needs a scene camera (the blending metric is view-dependent)")
        for obj in meshes:
            try:
                with self.timings.phase("read"):
                    arrays = mesh_io.read_mesh(obj, self.settings.direction_attribute
                                              if self.settings.orientation != "AXIS" else "")
                    arrays.scale_multiplier = mesh_state.read_scale_multiplier(obj, self.settings)
                if arrays.num_faces == 0:
                    raise SettingsError("mesh %r has no faces" % obj.data.name)
                mesh_layers.check_capacity(obj.data)
                self.items.append([obj, arrays, None])
            except (ValueError, RuntimeError) as error:
                self.report.failures.append((obj.name, str(error)))
        return self

    def discard(self):
        """Nothing to undo: prepare() only reads (the surface-colour Job may add UV maps)."""

    def cancel(self):
        """Asks compute() to stop (from any thread); it then raises Cancelled."""
        self.cancelled = True
        if self.token is not None:
            self.token.cancel()

    def _check_cancelled(self):
        if self.cancelled:
            raise Cancelled("TexSynth: cancelled, nothing was changed")

    def compute(self, progress=None):
        """Native preprocessing and synthesis for every prepared mesh; no bpy access."""
        progress = progress or (lambda fraction, text: None)
        module = native.require()
        native_cancelled = getattr(module, "Cancelled", Cancelled)
        try:
            self._check_cancelled()
            progress(0.0, "TexSynth: preprocessing %s" % self.sample.describe())
            if self.preprocessed is None:
                with self.timings.phase("preprocess"):
                    self.preprocessed = uv_core.preprocess(self.native_input, self.settings, self.cache_dir,
                                                            self.token)
            preprocessed = self.preprocessed
            self.report.cache_hit = bool(preprocessed.cache_hit)
            self.report.cache_status = str(getattr(preprocessed, "cache_status", ""))
            if self.material_mode != "NONE" and self.items:
                with self.timings.phase("preprocess"):
                    self.shading = blend_shading(self.native_input, self.settings, self.cache_dir)
                self.report.blend_mode = self.shading.mode
                self.report.blend_reason = self.shading.reason
                if self.shading.note:
                    self.report.notes.append(self.shading.note)
            scale = texels_per_unit(int(preprocessed.width), self.settings.sample_world_size)
            for index, item in enumerate(self.items):
                self._check_cancelled()
                obj_name = item[0].name
                progress((index + 0.1) / max(len(self.items), 1),
                         "TexSynth: %s (%d/%d)" % (obj_name, index + 1, len(self.items)))
                try:
                    with self.timings.phase("synthesis"):
                        item[2] = uv_core.synthesize(preprocessed, item[1], self.settings,
                                                      object_seed(self.settings.seed, obj_name), scale,
                                                      self.pixels, self.view, self.token)
                except native_cancelled:
                    raise
                except (ValueError, RuntimeError) as error:
                    self.report.failures.append((obj_name, str(error)))
            self._check_cancelled()
        except native_cancelled:
            self.cancelled = True
            raise Cancelled("TexSynth: cancelled, nothing was changed") from None
        return self

    def apply(self, progress=None):
        """Writes every computed result (main thread); returns the Report."""
        progress = progress or (lambda fraction, text: None)
        self._check_cancelled()
        # Loaded only now: Blender reads a file's header when loading it, and a hostile file must have
        # been refused by the native checks before that (a truncated EXR header can hang Blender).
        image = inputs = None
        if self.material_mode != "NONE" and any(item[2] is not None for item in self.items):
            image = self.sample.shader_image()
            self.shading.with_colour_space(image.colorspace_settings.name == "sRGB")
            zone = uv_core.patch_zone(self.settings.method, self.shading.mode)
            inputs = blend_groups.blend_inputs(self.shading, image, zone, wrap=self.settings.tileable)
        for obj, arrays, result in self.items:
            if result is None:
                continue
            try:
                name = obj.name  # ReferenceError if the object was deleted meanwhile
                with self.timings.phase("write"):
                    snapshot = mesh_write.write_result(obj.data, result)
                with self.timings.phase("material"):
                    try:
                        mesh_io.fail_point("material")
                        blend_groups.apply_material(obj, image, self.material_mode, inputs)
                    except Exception as error:
                        mesh_layers.restore(obj.data, snapshot)
                        raise mesh_io.MeshWriteError("material setup failed (mesh restored): %s" % error) from error
                self.report.add_object(name, arrays, result.get("stats"))
            except (ValueError, RuntimeError, ReferenceError) as error:
                self.report.failures.append((getattr(obj, "name", "?"), str(error)))
        progress(1.0, "TexSynth: done")
        self.report.seconds = self.timings.as_dict()
        return self.report


def blend_inputs(image, mode="HISTOGRAM", cache_dir=None, method="JUMPMAP", tileable=False):
    """blend_groups.BlendInputs for any image of the .blend (e.g. a roughness or normal map driven through
    the same mapping): Gaussianizes it for HISTOGRAM (cached), falling back to VARIANCE as Synthesize does.
    tileable: the mapping was made with Tileable on (the look-ups repeat the image)."""
    settings = Settings(blend_mode=mode, method=method).validate()
    srgb = image.colorspace_settings.name == "sRGB"
    blend = blend_shading(sources.Sample(image=image).native_input(), settings, cache_dir or sources.default_cache_dir(), srgb)
    return blend_groups.blend_inputs(blend, image, uv_core.patch_zone(method, blend.mode), wrap=tileable)


def synthesize(objects, sample, settings, cache_dir=None, material_mode="NEW", progress=None, scene=None,
               preprocessed=None):
    """Synthesizes on every mesh object; returns a Report. Raises SettingsError /
    NativeUnavailable / ValueError for problems that concern the whole run (nothing is changed then).
    `preprocessed` (optional) skips preprocessing, e.g. for live updates with a sample kept in memory."""
    job = Job(objects, sample, settings, cache_dir, material_mode, scene, preprocessed).prepare()
    return job.compute(progress).apply(progress)


def synthesize_from_memory(obj, arrays, settings, preprocessed, main_thread_work=None, overlap=True,
                           reuse_snapshot=None):
    """A live update's re-synthesis of one object (JUMPMAP) from mesh arrays the edit session holds
    in memory (no mesh or field re-read). The native call runs in a worker thread with the GIL
    released; meanwhile the main thread runs main_thread_work() (e.g. the field attribute writes)
    and snapshots the layers the write replaces, the bpy reads write_result would otherwise do after
    it. Then writes atomically as Synthesize does (no material). The worker touches no bpy data.
    Returns a Report (seconds: read, synthesis, overlap (main-thread work during the native
    call), write, total). Raises SettingsError / ValueError / RuntimeError; main_thread_work's
    exceptions propagate after the worker has finished. overlap=False: the same steps one after
    the other on the calling thread (main_thread_work, snapshot, native, write). reuse_snapshot:
    the snapshot of the object's previous live update (its buffers are reused, see mesh_layers.snapshot);
    the new one is in report.snapshot."""
    if settings.method != "JUMPMAP":
        raise SettingsError("synthesize_from_memory supports the jump-map method only")
    start = time.perf_counter()
    report = Report()
    seconds = {}
    arrays.scale_multiplier = mesh_state.read_scale_multiplier(obj, settings)
    if arrays.num_faces == 0:
        raise SettingsError("mesh %r has no faces" % obj.data.name)
    seed = object_seed(settings.seed, obj.name)
    scale = texels_per_unit(int(preprocessed.width), settings.sample_world_size)
    seconds["read"] = time.perf_counter() - start
    outcome = {}

    def run():
        begin = time.perf_counter()
        try:
            outcome["result"] = uv_core.synthesize(preprocessed, arrays, settings, seed, scale)
        except BaseException as error:  # re-raised on the main thread below
            outcome["error"] = error
        outcome["seconds"] = time.perf_counter() - begin

    worker = threading.Thread(target=run, name="TexSynth live update", daemon=True)
    native_start = time.perf_counter()
    if overlap:
        worker.start()
    try:
        if main_thread_work is not None:
            main_thread_work()
        mesh_layers.check_capacity(obj.data)
        taken = mesh_layers.snapshot(obj.data, reuse_snapshot)
        seconds["overlap"] = time.perf_counter() - native_start
    finally:
        if overlap:
            worker.join()
        else:
            run()
    seconds["synthesis"] = outcome.get("seconds", 0.0)
    seconds["wait"] = time.perf_counter() - native_start - seconds.get("overlap", 0.0)
    if "error" in outcome:
        raise outcome["error"]
    result = outcome["result"]
    write_start = time.perf_counter()
    report.snapshot = mesh_write.write_result(obj.data, result, taken)
    seconds["write"] = time.perf_counter() - write_start
    report.add_object(obj.name, arrays, result.get("stats"))
    seconds["total"] = time.perf_counter() - start
    report.seconds = seconds
    return report


def clear(objects):
    """Removes TexSynth's layers from every mesh object; returns (objects changed, layers removed)."""
    meshes, _ = sources.mesh_objects(objects)
    changed = removed = 0
    for obj in meshes:
        count = mesh_layers.clear(obj.data)
        changed += bool(count)
        removed += count
    return changed, removed
