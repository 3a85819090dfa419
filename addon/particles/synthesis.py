# SPDX-License-Identifier: GPL-3.0-or-later
"""One Texture Particles run over Blender objects, shared by the operators and the CLI (same stages as
uv_methods.synthesis.Job, so the modal Synthesize operator runs it in a worker thread with Esc):

prepare()  main thread: validates; reads the sample, the label image, every mesh (loop triangles, field
           attribute, scale field, per-face overrides); the analysis (cached); the background sample
           written to the cache folder and its jump-map / texton Job prepared.
compute()  any thread: the background synthesis, then per object the walk mesh, the direction field,
           place_particles, the sprites and atlas, decal_mesh per class and the instance frames.
apply()    main thread: the particle objects (scene.write_outputs, all or nothing), then the background
           layers; a background that fails removes that object's new particle objects again.

Re-synthesizing one class (only_class=c) places the classes up to c in the artist's order and outputs c
alone (its rows are those of a full run: placement tests every particle against all classes placed before
it), and replaces only its decal / points objects; the background is left as it is.
"""
import os
import time

import bpy
import numpy as np

from .. import native
from ..bridge import mesh_io, mesh_layers, sources
from ..fields import mesh_state
from ..core.jobs import Cancelled
from ..core import orientation
from ..core.reporting import Report, Timings
from ..core.settings import Settings, SettingsError, object_seed
from ..uv_methods import synthesis as uv_synthesis
from . import core, outputs, scene

PLACEMENT_KEYS = ("class", "sprite", "triangle", "barycentric", "position", "normal", "sprite_axis", "pixel_size")


def missing_native(module):
    """Which native functions this run needs and the module lacks (a build from before they landed)."""
    return [name for name in ("particle_analysis", "particle_sprite", "surface_walk_mesh", "place_particles",
                              "decal_mesh") if not hasattr(module, name)]


class _Item:
    def __init__(self, obj, arrays, triangles, overrides):
        self.obj, self.arrays, self.triangles, self.overrides = obj, arrays, triangles, overrides
        self.outputs = None      # [scene.ClassOutput]
        self.atlas = None
        self.atlas_pixels = None
        self.stats = {}


class Job:
    def __init__(self, objects, sample, settings, cache_dir="", label_pixels=None, only_class=None,
                 material_mode="NEW", scene_=None):
        self.objects, self.sample, self.settings = objects, sample, settings
        self.cache_dir = cache_dir or sources.default_cache_dir()
        self.label_pixels = label_pixels   # (H, W, 4) bottom row first, or None
        self.only_class = only_class
        self.material_mode, self.scene = material_mode, scene_
        self.report, self.timings = Report(uses_cache=False), Timings()
        self.items = []
        self.background_job = None
        self.token = None
        self.cancelled = False
        self.analysis = None
        self.child_bounds = None  # per child of the instance collection, as the node group picks them

    # -- main thread --------------------------------------------------------------------------

    def prepare(self):
        settings = self.settings.validate()
        if settings.method != "PARTICLES":
            raise SettingsError("method %r is not Texture Particles" % settings.method)
        module = native.require()
        meshes, self.report.failures = sources.mesh_objects(self.objects)
        if not meshes:
            raise SettingsError("no mesh object selected")
        self.collection = None
        if settings.particle_output != "DECALS":
            self.collection = bpy.data.collections.get(settings.particle_collection)
            if self.collection is None:
                raise SettingsError("instance collection %r does not exist" % settings.particle_collection)
            if not self.collection.all_objects:
                raise SettingsError("instance collection %r is empty: add the objects to place per class"
                                             % self.collection.name)
        self.child_bounds = scene.instance_child_bounds(self.collection) if self.collection is not None else None
        self.token = module.CancelToken()
        with self.timings.phase("read"):
            pixels, self.sample_srgb = sources.read_sample_pixels(self.sample)
            self.sample_array = core.sample_for_analysis(pixels)
            height, width = self.sample_array.shape[:2]
            labels = None
            if self.label_pixels is not None:
                labels = core.labels_from_image(self.label_pixels, width, height)
            self.labels = labels
        with self.timings.phase("preprocess"):
            self.analysis, source = core.analyse(self.sample_array, settings, labels, self.cache_dir, self.token)
        self.report.notes += core.check_usable(self.analysis, settings)
        self.order = core.class_order(self.analysis, settings)
        if self.only_class is not None:
            if self.only_class not in self.order:
                raise SettingsError("class %d is not placed (placed classes: %s)"
                                             % (self.only_class, ", ".join(str(c) for c in self.order)))
        self.report.cache_status = "analysis " + source
        self.report.cache_hit = source != "built"
        for obj in meshes:
            try:
                with self.timings.phase("read"):
                    self.items.append(self._read(obj))
            except (ValueError, RuntimeError) as error:
                self.report.failures.append((obj.name, str(error)))
        if not self.items:
            raise SettingsError("; ".join("%s: %s" % failure for failure in self.report.failures))
        missing = missing_native(module)
        if missing:  # checked after the inputs, whose errors are worth more to the artist
            raise SettingsError("this build of texsynth_native lacks %s: rebuild with scripts/build.sh"
                                         % ", ".join(missing))
        if settings.particle_background != "NONE" and self.only_class is None:
            with self.timings.phase("background"):  # its preprocessing (the background job's own phases)
                self._prepare_background([item.obj for item in self.items])
        return self

    def _read(self, obj):
        settings = self.settings
        arrays = mesh_io.read_mesh(obj, settings.direction_attribute if settings.orientation != "AXIS" else "")
        arrays.scale_multiplier = mesh_state.read_scale_multiplier(obj, settings)
        triangles, _ = mesh_io.read_loop_triangles(obj)
        area = outputs.triangle_areas(arrays.positions, triangles).sum() if triangles.shape[0] else 0.0
        if area <= 0.0:
            raise SettingsError("mesh %r has no area: particles need faces to sit on" % obj.data.name)
        core.check_particle_count(core.expected_particles(self.analysis, settings.sample_world_size, area),
                                  settings.sample_world_size, obj.name)
        overrides = {}
        polygons = None
        for key, name in (("face_density", settings.particle_density_source),
                          ("face_probability", settings.particle_probability_source),
                          ("face_size", settings.particle_size_source)):
            if name:
                polygons = mesh_io.read_triangle_polygons(obj) if polygons is None else polygons
                values = mesh_io.read_face_values(obj, name, triangles, polygons)
                overrides[key] = np.minimum(values, 1.0) if key == "face_probability" else values
        return _Item(obj, arrays, triangles, overrides)

    def _prepare_background(self, objects):
        """The analysis' filled background as a file in the cache folder, synthesized by the UV method."""
        background = self.analysis.background
        path = core.background_file_path(self.cache_dir, background, self.sample_array, self.labels)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        height, width = background.shape[:2]
        if not scene.background_file_usable(path, width, height):  # missing, damaged or another size
            scene.save_background(background, path)
        uv_settings = Settings(**{**self.settings.__dict__, "method": self.settings.particle_background})
        self.background_job = uv_synthesis.Job(objects, sources.Sample(path=path), uv_settings,
                                               self.cache_dir, self.material_mode, self.scene).prepare()

    def discard(self):
        """Nothing to undo: prepare() creates no datablock (the background file is a cache entry)."""

    # -- any thread ---------------------------------------------------------------------------

    def cancel(self):
        self.cancelled = True
        if self.token is not None:
            self.token.cancel()
        if self.background_job is not None:
            self.background_job.cancel()

    def live_fraction(self):
        return float(self.token.progress) if self.token is not None else 0.0

    def compute(self, progress=None):
        progress = progress or (lambda fraction, text: None)
        module = native.require()
        try:
            if self.background_job is not None:
                progress(0.0, "TexSynth: background")
                with self.timings.phase("background"):
                    self.background_job.compute()
            for index, item in enumerate(self.items):
                if self.cancelled:
                    raise module.Cancelled("cancelled")
                progress(index / max(len(self.items), 1), "TexSynth: particles on %s" % item.obj.name)
                try:
                    self._compute_item(module, item)
                except module.Cancelled:
                    raise
                except (ValueError, RuntimeError) as error:
                    self.report.failures.append((item.obj.name, str(error)))
        except (module.Cancelled, Cancelled):
            self.cancelled = True
            raise Cancelled("TexSynth: cancelled, nothing was changed") from None
        return self

    def place(self, module, item):
        """place_particles on one item (the native call, no bpy)."""
        settings = self.settings
        arrays = item.arrays
        walk_mesh = module.surface_walk_mesh(arrays.positions, item.triangles)
        directions = np.ascontiguousarray(orientation.directions(arrays, settings), dtype=np.float32)
        kwargs = dict(sample_world_width=float(settings.sample_world_size), classes=list(self.order),
                      size_jitter=float(settings.particle_size_jitter),
                      seed=int(object_seed(settings.seed, item.obj.name)), cancel=self.token)
        if arrays.scale_multiplier is not None:
            kwargs["vertex_scale"] = arrays.scale_multiplier
        kwargs.update(item.overrides)
        if self.only_class is not None:
            if "output_classes" not in (module.place_particles.__doc__ or ""):  # a build from before issue 30
                raise SettingsError("this build of texsynth_native's place_particles cannot re-synthesize "
                                             "one class: rebuild with scripts/build.sh")
            kwargs["output_classes"] = [self.only_class]
        placed = dict(module.place_particles(self.analysis, walk_mesh, directions, **kwargs))
        for key in PLACEMENT_KEYS:
            if key not in placed:
                raise SettingsError("place_particles returned no %r" % key)
        return walk_mesh, placed

    def _compute_item(self, module, item):
        settings = self.settings
        start = time.perf_counter()
        with self.timings.phase("synthesis"):
            walk_mesh, placed = self.place(module, item)
        item.stats = {"placed": int(len(placed["class"])), "placement": dict(placed.get("stats") or {}),
                      "seconds_placement": time.perf_counter() - start, "seconds_atlas": 0.0,
                      "seconds_decal_mesh": 0.0}
        if len(placed["class"]) == 0:
            raise SettingsError("no particle could be placed (surface too small for the particles at "
                                         "this scale, or every face overridden to 0)")
        classes = [self.only_class] if self.only_class is not None else list(self.order)
        rank = {c: self.order.index(c) for c in classes}
        decals = settings.particle_output in ("DECALS", "BOTH")
        points = settings.particle_output in ("INSTANCES", "BOTH")
        if decals:
            start = time.perf_counter()
            with self.timings.phase("synthesis"):
                self._build_atlas(module, item)
            item.stats["seconds_atlas"] = time.perf_counter() - start
        diagonal = outputs.bbox_diagonal(item.arrays.positions)
        item.outputs = []
        item.stats["per_class"] = {int(c): int(np.count_nonzero(placed["class"] == c)) for c in classes}
        for c in classes:
            rows = np.flatnonzero(placed["class"] == c)
            out = scene.ClassOutput(c, rank[c], int(rows.size))
            out.target_triangles = int(item.triangles.shape[0])
            if rows.size == 0:
                item.outputs.append(out)
                continue
            part = {key: np.asarray(placed[key])[rows] for key in PLACEMENT_KEYS}
            if decals:
                start = time.perf_counter()
                with self.timings.phase("synthesis"):
                    axes, rects, uv_rects, _ = outputs.decal_inputs(part, self.analysis, item.atlas, item.sprite_boxes)
                    out.decals = dict(module.decal_mesh(
                        walk_mesh, np.ascontiguousarray(part["triangle"], np.int32),
                        np.ascontiguousarray(part["barycentric"], np.float64), axes, rects, uv_rects,
                        **outputs.decal_lift(rank[c], diagonal), cancel=self.token))
                stacking = out.decals["stats"]
                item.stats["decals_stacked"] = item.stats.get("decals_stacked", 0) + int(stacking.get("stacked", 0))
                item.stats["decal_max_level"] = max(item.stats.get("decal_max_level", 0),
                                                    int(stacking.get("max_level", 0)))
                if "source_triangle" not in out.decals:  # a build from before baking needed them
                    raise SettingsError("this build of texsynth_native's decal_mesh returns no source "
                                                 "triangles: rebuild with scripts/build.sh")
                item.stats["seconds_decal_mesh"] += time.perf_counter() - start
            if points:
                rotation_axes = outputs.rotate_in_plane(
                    part["sprite_axis"], part["normal"],
                    np.asarray(self.analysis.particles["box_angle"], np.float64)[part["sprite"]])
                _, scale = outputs.instance_frames(part, self.analysis)
                position, rotation_axes, scale = outputs.fit_instances(
                    part["position"], rotation_axes, part["normal"], scale, np.full(rows.size, c), self.child_bounds)
                out.points = dict(position=position, axis=rotation_axes, normal=part["normal"], scale=scale)
            item.outputs.append(out)

    def _build_atlas(self, module, item):
        """Sprites of every complete particle of the placed classes, packed (deterministic for the analysis
        and seed, so a one-class re-run rebuilds the same atlas the other classes' UVs point into)."""
        particles = self.analysis.particles
        wanted = np.flatnonzero(np.isin(particles["class"], self.order) & particles["complete"])
        sprites, sizes, boxes = [], [], {}
        for pid in wanted:
            sprite = module.particle_sprite(self.analysis, self.sample_array, int(pid))
            rgba = np.asarray(sprite["rgba"], np.float32)
            sprites.append(rgba)
            sizes.append((rgba.shape[1], rgba.shape[0]))
            boxes[int(pid)] = (sprite["origin"][0], sprite["origin"][1], rgba.shape[1], rgba.shape[0])
        atlas = outputs.pack_atlas(wanted, sizes, particles["class"][wanted], seed=int(self.settings.seed))
        order = {int(s): i for i, s in enumerate(wanted)}
        item.atlas = atlas
        item.atlas_pixels = outputs.atlas_pixels(atlas, [sprites[order[int(s)]] for s in atlas.ids])
        item.sprite_boxes = boxes
        if atlas.dropped:
            self.report.notes.append("%s: atlas limited to %d px: %s sprite(s) left out (their particles reuse "
                                     "kept sprites of the class)" % (item.obj.name, outputs.ATLAS_MAX_SIDE, ", ".join(
                                         "class %d: %d" % kv for kv in sorted(atlas.dropped.items()))))

    # -- main thread --------------------------------------------------------------------------

    def apply(self, progress=None):
        progress = progress or (lambda fraction, text: None)
        if self.cancelled:
            raise Cancelled("TexSynth: cancelled, nothing was changed")
        float_atlas = not self.sample_srgb
        for item in self.items:
            if item.outputs is None:
                continue
            try:
                name = item.obj.name
                creation = scene.Creation()
                with self.timings.phase("write"):
                    made = scene.write_outputs(
                        item.obj, item.outputs, item.atlas_pixels,
                        (item.atlas.width, item.atlas.height) if item.atlas is not None else None,
                        self.collection, float_atlas, creation, keep_atlas=self.only_class is not None)
                item.made = made
                self.report.add_object(name, item.arrays, item.stats)
                counts = ", ".join("class %d: %d" % (out.class_id, out.count) for out in item.outputs)
                self.report.outputs.append("%s: %d particles (%s) in %d object(s)" % (
                    name, item.stats["placed"], counts, len(made)))
            except (ValueError, RuntimeError, ReferenceError) as error:
                self.report.failures.append((getattr(item.obj, "name", "?"), str(error)))
        if self.background_job is not None:
            written = set(self.report.objects)
            for entry in self.background_job.items:  # no background where the particles could not be written
                if entry[0].name not in written:
                    entry[2] = None
            with self.timings.phase("background"):
                background = self.background_job.apply()
            self.report.notes += background.notes
            for name, message in background.failures:
                if name in self.report.objects:  # particles without their background: taken out again
                    for obj in scene.owned_objects(name):
                        if obj.name in getattr(self._item(name), "made", ()):
                            scene.remove_object(obj)
                    self.report.objects.remove(name)
                self.report.failures.append((name, "background: %s" % message))
        progress(1.0, "TexSynth: done")
        self.report.seconds = self.timings.as_dict()
        return self.report

    def _item(self, name):
        return next((item for item in self.items if item.obj.name == name), None)


def synthesize(objects, sample, settings, cache_dir="", label_pixels=None, only_class=None, material_mode="NEW",
               progress=None, scene_=None):
    """Every stage; returns the Report."""
    job = Job(objects, sample, settings, cache_dir, label_pixels, only_class, material_mode, scene_).prepare()
    return job.compute(progress).apply(progress)


def analyse(sample, settings, cache_dir="", label_pixels=None):
    """(analysis, source, notes) for the analysis view (main thread; cached like Synthesize's)."""
    settings.validate()
    pixels, _ = sources.read_sample_pixels(sample)
    array = core.sample_for_analysis(pixels)
    labels = None
    if label_pixels is not None:
        labels = core.labels_from_image(label_pixels, array.shape[1], array.shape[0])
    analysis, source = core.analyse(array, settings, labels, cache_dir or sources.default_cache_dir())
    return analysis, source, core.check_usable(analysis, settings)


def clear(objects):
    """Removes every object's particle outputs and TexSynth layers; returns (objects changed, items removed)."""
    meshes, _ = sources.mesh_objects([obj for obj in objects if scene.TAG not in obj])  # outputs go with their target
    changed = removed = 0
    for obj in meshes:
        count = scene.clear(obj.name) + mesh_layers.clear(obj.data)
        changed += bool(count)
        removed += count
    return changed, removed
