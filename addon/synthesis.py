# SPDX-License-Identifier: GPL-3.0-or-later
"""One Synthesize / Preprocess / Clear run over Blender objects, shared by the operators and the CLI.

Data flows one way: sample -> native preprocess (cached) -> per object: bridge.read_mesh ->
native synthesis -> bridge.write_result (atomic) -> material. Per-object failures are reported and
do not stop the other objects.
"""
import os

import bpy

from . import bridge, native, pipeline, shading


class Sample:
    """The sample image: a file path or an image already in the .blend (packed ones too)."""

    def __init__(self, path="", image=None):
        self.path = path
        self.image = image

    def describe(self):
        return self.image.name if self.image is not None else (self.path or "<none>")

    def native_input(self):
        """What texsynth_native.preprocess accepts: a path, or the image's pixels as numpy."""
        if self.image is not None:
            return bridge.read_image_pixels(self.image)
        if not self.path:
            raise pipeline.SettingsError("no sample image: choose an image file or an image in the .blend")
        path = bpy.path.abspath(self.path)
        if not os.path.isfile(path):
            raise pipeline.SettingsError("sample image not found: %s" % path)
        return path

    def shader_image(self):
        """The bpy image the node group samples (loaded once for file samples)."""
        if self.image is not None:
            return self.image
        return bpy.data.images.load(bpy.path.abspath(self.path), check_existing=True)


def default_cache_dir():
    for resource in ("CACHE", "SCRIPTS"):
        try:
            base = bpy.utils.user_resource(resource)
        except (TypeError, ValueError):
            continue
        if base:
            return pipeline.default_cache_dir(base)
    return pipeline.default_cache_dir(bpy.app.tempdir or "/tmp")


def cache_status(sample, settings, cache_dir):
    return pipeline.cache_status(sample.native_input(), settings, cache_dir or default_cache_dir())


def preprocess(sample, settings, cache_dir, timings=None):
    """Preprocessed sample (cached on disk)."""
    timings = timings or pipeline.Timings()
    with timings.phase("preprocess"):
        native_input = sample.native_input()
        return pipeline.preprocess(native_input, settings, cache_dir or default_cache_dir())


def mesh_objects(objects):
    """(mesh objects with distinct mesh data, skipped (name, reason)) in a stable order."""
    seen, meshes, skipped = set(), [], []
    for obj in objects:
        if obj.type != "MESH":
            skipped.append((obj.name, "not a mesh object (%s)" % obj.type.lower()))
        elif obj.data.name in seen:
            skipped.append((obj.name, "shares mesh %r with an object already processed" % obj.data.name))
        elif obj.data.library is not None:
            skipped.append((obj.name, "mesh %r is linked from a library and cannot be edited" % obj.data.name))
        else:
            seen.add(obj.data.name)
            meshes.append(obj)
    return meshes, skipped


def camera_view(scene):
    """The scene camera as a pipeline.View (world position, λ = render width / field of view), or None."""
    camera = scene.camera if scene is not None else None
    if camera is None or camera.type != "CAMERA":
        return None
    angle = float(camera.data.angle)  # horizontal field of view for the default sensor fit
    width = scene.render.resolution_x * scene.render.resolution_percentage / 100.0
    if not (angle > 0.0) or width <= 0:
        return None
    return pipeline.View(position=tuple(camera.matrix_world.translation), pixels_per_radian=width / angle)


def synthesize(objects, sample, settings, cache_dir=None, material_mode="NEW", progress=None, scene=None,
               preprocessed=None):
    """Synthesizes on every mesh object; returns a pipeline.Report. Raises SettingsError /
    NativeUnavailable / ValueError for problems that concern the whole run (nothing is changed then).
    `preprocessed` (optional) skips preprocessing, e.g. for live updates with a sample kept in memory."""
    settings.validate()
    report, timings = pipeline.Report(), pipeline.Timings()
    meshes, report.failures = mesh_objects(objects)
    if not meshes:
        raise pipeline.SettingsError("no mesh object selected")
    native.require()
    progress = progress or (lambda fraction, text: None)
    progress(0.0, "TexSynth: preprocessing %s" % sample.describe())
    if preprocessed is None:
        preprocessed = preprocess(sample, settings, cache_dir, timings)
    report.cache_hit = bool(preprocessed.cache_hit)
    report.cache_status = str(getattr(preprocessed, "cache_status", ""))
    image = sample.shader_image()
    scale = pipeline.texels_per_unit(int(preprocessed.width), settings.sample_world_size)
    pixels = view = None
    if settings.method == "TEXTON":
        pixels = pipeline.sample_pixels(sample.native_input())
        view = camera_view(scene or bpy.context.scene)
        if settings.blend_threshold > 0.0 and view is None:
            raise pipeline.SettingsError("a blend threshold needs a scene camera (the blending metric is view-dependent)")
    for index, obj in enumerate(meshes):
        progress((index + 0.1) / len(meshes), "TexSynth: %s (%d/%d)" % (obj.name, index + 1, len(meshes)))
        try:
            with timings.phase("read"):
                arrays = bridge.read_mesh(obj, settings.direction_attribute if settings.orientation != "AXIS" else "")
                arrays.scale_multiplier = bridge.read_scale_multiplier(obj, settings)
            if arrays.num_faces == 0:
                raise pipeline.SettingsError("mesh %r has no faces" % obj.data.name)
            bridge.check_capacity(obj.data, pipeline.needed_blend_sets(arrays, settings.blend))
            with timings.phase("synthesis"):
                result = pipeline.synthesize(preprocessed, arrays, settings,
                                             pipeline.object_seed(settings.seed, obj.name), scale, pixels, view)
            with timings.phase("write"):
                bridge.write_result(obj.data, result)
            with timings.phase("material"):
                shading.apply_material(obj, image, material_mode)
            report.add_object(obj.name, arrays, result.get("stats"))
        except (ValueError, RuntimeError) as error:
            report.failures.append((obj.name, str(error)))
    progress(1.0, "TexSynth: done")
    report.seconds = timings.as_dict()
    return report


def clear(objects):
    """Removes TexSynth's layers from every mesh object; returns (objects changed, layers removed)."""
    meshes, _ = mesh_objects(objects)
    changed = removed = 0
    for obj in meshes:
        count = bridge.clear(obj.data)
        changed += bool(count)
        removed += count
    return changed, removed
